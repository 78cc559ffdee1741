// The bake's plan: the settings checked and normalized, the samples laid out, the tracer built,
// and the --max-error choice of order and directions (bake_driver.h: planBake).
#include "driver/bake_driver.h"

#include "fnv1a.h"
#include "parallel.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <thread>

namespace shrefract::bake::detail {

namespace {

Result<void> checkSettings(const BakeSettings& s) {
  auto bad = [](const std::string& m) { return makeError(ErrorCode::InvalidArgument, m); };
  if (s.order > static_cast<uint32_t>(kMaxFitOrder))
    return bad("--order must be 0.." + std::to_string(kMaxFitOrder) + ", got " + std::to_string(s.order));
  if (s.directionsTheta < kMinDirectionRows || s.directionsTheta > kMaxDirectionRows ||
      s.directionsPhi < kMinDirectionColumns || s.directionsPhi > kMaxDirectionColumns)
    return bad("--directions must be " + std::to_string(kMinDirectionRows) + ".." + std::to_string(kMaxDirectionRows) +
               " x " + std::to_string(kMinDirectionColumns) + ".." + std::to_string(kMaxDirectionColumns));
  if (s.spatialNeighbours != 0 && s.spatialNeighbours != 3 && s.spatialNeighbours != 5)
    return bad("--spatial must be 0, 3 or 5, got " + std::to_string(s.spatialNeighbours));
  if (s.maxBounces < 1 || s.maxBounces > kMaxBakeBounces)
    return bad("--max-bounces must be 1.." + std::to_string(kMaxBakeBounces));
  if (!(s.regularization >= 0.0f) || !std::isfinite(s.regularization)) return bad("regularization must be >= 0");
  if (s.shFit != ShFit::LeastSquares && s.shFit != ShFit::Robust) return bad("unknown SH fit");
  if (!(s.maxErrorDegrees >= 0.0f) || !std::isfinite(s.maxErrorDegrees) || s.maxErrorDegrees > 180.0f)
    return bad("--max-error must be in (0, 180] degrees");
  if (!(s.samplesPerUnitArea >= 0.0f) || !std::isfinite(s.samplesPerUnitArea))
    return bad("sample density must be finite and >= 0");
  return {};
}

struct Selection {
  uint32_t order = 0, rows = 0, columns = 0;
  double meanDegrees = 0.0;
  bool met = false;
};

// The samples the --max-error choice is measured on: up to maxCount of the n, evenly strided.
std::vector<size_t> selectionSubset(size_t n, size_t maxCount) {
  std::vector<size_t> subset;
  const size_t step = std::max<size_t>(1, n / maxCount);
  for (size_t i = 0; i < n && subset.size() < maxCount; i += step) subset.push_back(i);
  return subset;
}

// The direction grids the --max-error choice tries: rows doubling from 8 up to the requested grid,
// which is always the last.
std::vector<std::pair<uint32_t, uint32_t>> selectionGrids(const BakeSettings& s) {
  std::vector<std::pair<uint32_t, uint32_t>> grids;
  for (uint32_t rows = 8; rows <= s.directionsTheta; rows *= 2) grids.emplace_back(rows, 2 * rows);
  if (grids.empty() || grids.back() != std::make_pair(s.directionsTheta, s.directionsPhi))
    grids.emplace_back(s.directionsTheta, s.directionsPhi);
  return grids;
}

// The traced exits (3 floats each, as storedExit) of every grid direction at each subset sample.
std::vector<float> traceGridExits(const SampleAtlas& atlas, const Tracer& tracer, const TraceSettings& ts,
                                  const std::vector<size_t>& subset, const DirectionGrid& grid, bool sampleFrame,
                                  uint32_t threads) {
  const uint32_t nd = static_cast<uint32_t>(grid.directions.size());
  std::vector<float> values(subset.size() * nd * 3);
  parallelFor(subset.size(), threads, [&](size_t k) {
    const SurfacePoint& p = atlas.samples[subset[k]];
    const LocalFrame frame = frameAt(p);
    for (uint32_t d = 0; d < nd; ++d) {
      const glm::vec3 incident = -localToWorld(frame, glm::vec3(grid.directions[d]));
      const glm::vec3 e = storedExit(sampleFrame, frame, tracer.traceFromSurface(p, incident, ts).exitDirection);
      for (int c = 0; c < 3; ++c) values[(k * nd + d) * 3 + size_t(c)] = e[c];
    }
  });
  return values;
}

// The SH fit the settings ask for, of `order`: one rule for the --max-error choice, the budget's
// candidates and the field.
Result<HemisphereFit> shFitOf(const DirectionGrid& grid, uint32_t order, const BakeSettings& s) {
  const FitMethod method =
      s.shFit == ShFit::Robust ? FitMethod::RobustLeastSquares : FitMethod::RegularizedLeastSquares;
  return HemisphereFit::create(grid, static_cast<int>(order), static_cast<double>(s.regularization), method);
}

// The cosine-weighted mean angle (degrees) between the fit of order `order` of each subset
// sample's grid values and its held-out exits; the sums run in sample order whatever the threads.
double heldOutMeanDegrees(const HemisphereFit& fit, uint32_t order, const std::vector<float>& values, uint32_t nd,
                          const TracedViews& held, uint32_t perSample, size_t subsetSize, uint32_t threads) {
  std::vector<double> sums(subsetSize, 0.0), weights(subsetSize, 0.0);
  parallelFor(subsetSize, threads, [&](size_t k) {
    std::vector<float> c(size_t(fit.basisCount()) * 3);
    fit.fit(&values[k * nd * 3], 3, c.data());
    float out[3];
    for (uint32_t h = 0; h < perSample; ++h) {
      const glm::vec3 w = held.directions[k * perSample + h];
      evaluateExpansion(static_cast<int>(order), c.data(), 3, w, out);
      sums[k] += double(w.z) * angleDegrees(glm::vec3(out[0], out[1], out[2]), held.exits[k * perSample + h]);
      weights[k] += double(w.z);
    }
  });
  double sum = 0.0, weight = 0.0;
  for (size_t k = 0; k < subsetSize; ++k) {
    sum += sums[k];
    weight += weights[k];
  }
  return weight > 0.0 ? sum / weight : 0.0;
}

// The --max-error choice (see bake.h).
Result<Selection> selectOrderAndDirections(const SampleAtlas& atlas, const Tracer& tracer, const BakeSettings& s,
                                           uint32_t threads, const std::function<void(const std::string&)>& note) {
  constexpr size_t kSubset = 192;
  constexpr uint32_t kHeldOut = 64;
  const std::vector<size_t> subset = selectionSubset(atlas.samples.size(), kSubset);
  const TraceSettings ts = traceSettingsOf(s);
  const bool sampleFrame = tracesInSampleFrame(s);  // values and exits as the field stores them

  // Held-out directions, cosine-weighted over the hemisphere, and their traced exits.
  const TracedViews held =
      traceCosineViews(atlas, tracer, ts, subset, kHeldOut, 0x4d41584552524f52ull, sampleFrame, threads);

  Selection best;
  bool haveBest = false;
  Selection fallback;
  for (auto [rows, columns] : selectionGrids(s)) {
    const DirectionGrid grid = makeHemisphereGrid(rows, columns);
    const uint32_t nd = static_cast<uint32_t>(grid.directions.size());
    const std::vector<float> values = traceGridExits(atlas, tracer, ts, subset, grid, sampleFrame, threads);
    for (uint32_t order = 0; order <= s.order; ++order) {
      auto fit = shFitOf(grid, order, s);
      if (!fit) continue;  // too few directions for this order
      const double mean = heldOutMeanDegrees(fit.value(), order, values, nd, held, kHeldOut, subset.size(), threads);
      if (note)
        note("max-error: order " + std::to_string(order) + ", " + std::to_string(rows) + "x" + std::to_string(columns) +
             " directions: mean error " + std::to_string(mean) + " deg");
      fallback = {order, rows, columns, mean, false};
      if (mean <= double(s.maxErrorDegrees)) {
        const Selection candidate{order, rows, columns, mean, true};
        if (!haveBest || order < best.order) {
          best = candidate;
          haveBest = true;
        }
        break;  // higher orders on this grid cost more
      }
    }
  }
  if (!haveBest) return fallback;
  return best;
}

Result<void> checkEncoding(const BakeSettings& s) {
  auto bad = [](const std::string& m) { return makeError(ErrorCode::InvalidArgument, m); };
  if (s.directionSampling != DirectionSampling::Grid && s.directionSampling != DirectionSampling::Nodes)
    return bad("unknown direction sampling");
  if (s.encoding == Encoding::Sh)
    return s.directionSampling == DirectionSampling::Grid
               ? Result<void>{}
               : bad("direction sampling 'nodes' needs --encoding table or pca (SH is fitted to a grid)");
  if (s.encoding == Encoding::Volume)
    return s.volumeSize >= kMinVolumeSize && s.volumeSize <= kMaxVolumeSize
               ? Result<void>{}
               : bad("--volume-size must be " + std::to_string(kMinVolumeSize) + ".." + std::to_string(kMaxVolumeSize) +
                     ", got " + std::to_string(s.volumeSize));
  if (s.encoding != Encoding::Table && s.encoding != Encoding::Pca) return bad("unknown encoding");
  if (s.tableSize < 2 || s.tableSize > kMaxBakeTableSize)
    return bad("--table-size must be 2.." + std::to_string(kMaxBakeTableSize) + ", got " + std::to_string(s.tableSize));
  if (s.encoding == Encoding::Pca && (s.components < 1 || s.components > kMaxComponents))
    return bad("--components must be 1.." + std::to_string(kMaxComponents) + ", got " + std::to_string(s.components));
  if (s.clusters > kMaxClusters)
    return bad("--clusters must be 1.." + std::to_string(kMaxClusters) + ", got " + std::to_string(s.clusters));
  return {};
}

// FNV-1a over what a merge must share with the parts: the layout's samples, texels, gutters,
// neighbours and mesh, and the media. A changed scene file or override changes it.
uint64_t sceneFingerprint(const Scene& scene, const SampleAtlas& atlas) {
  Fnv1a f;
  const uint32_t size[2] = {atlas.width, atlas.height};
  f.add(size, 2);
  f.add(atlas.texelKinds);
  f.add(atlas.texelSample);
  for (const SurfacePoint& p : atlas.samples) {  // field by field: the struct may have padding
    const float v[9] = {p.position.x, p.position.y, p.position.z, p.shadingNormal.x, p.shadingNormal.y,
                        p.shadingNormal.z, p.geometricNormal.x, p.geometricNormal.y, p.geometricNormal.z};
    f.add(v, 9);
    const uint32_t ids[2] = {p.surface, p.triangle};
    f.add(ids, 2);
  }
  for (const GutterTexel& g : atlas.gutters) {
    const uint32_t t[4] = {g.target, g.a, g.b, g.c};
    f.add(t, 4);
  }
  f.add(atlas.neighbours);
  f.add(atlas.mesh.positions);
  f.add(atlas.mesh.normals);
  f.add(atlas.mesh.uvs);
  f.add(atlas.mesh.frontIor);
  f.add(atlas.mesh.indices);
  for (const Medium& m : scene.media) {
    const float v[5] = {m.ior, m.absorption, m.color.x, m.color.y, m.color.z};
    f.add(v, 5);
    f.add(m.name.data(), m.name.size());
  }
  return f.value();
}

}  // namespace

// Checks and normalizes the settings, lays out the samples, builds the tracer and, with `choose`,
// makes the --max-error and --max-bytes-per-sample choices (a merge takes them from its parts).

Result<BakePlan> planBake(const Scene& scene, const BakeOptions& options, bool choose) {
  BakePlan plan;
  BakeSettings& settings = plan.settings;
  settings = options.settings;
  plan.note = options.note;
  plan.stage = options.stage;
  if (auto ok = checkSettings(settings); !ok) return ok.error();
  if (auto ok = checkEncoding(settings); !ok) return ok.error();
  if (auto ok = validateScene(scene); !ok) return ok.error();
  if (settings.encoding == Encoding::Volume)
    if (const std::string problem = volumeSceneProblem(scene); !problem.empty())
      return makeError(ErrorCode::InvalidArgument, problem);
  if (settings.regularization == 0.0f) settings.regularization = static_cast<float>(kDefaultRegularization);
  if (settings.encoding != Encoding::Sh) settings.order = 0;
  if (settings.encoding != Encoding::Pca) settings.components = settings.clusters = 0;
  if (settings.encoding == Encoding::Sh || settings.encoding == Encoding::Volume) settings.tableSize = 0;
  // The volume is tried by a Pca bake only; a Volume bake has its size.
  if (settings.encoding != Encoding::Pca) settings.tryVolume = false;
  if (settings.encoding != Encoding::Volume && !settings.tryVolume) settings.volumeSize = 0;
  if (settings.threads == 0) settings.threads = std::max(1u, std::thread::hardware_concurrency());

  LayoutOptions layoutOptions;
  layoutOptions.sampleBudget = settings.sampleBudget;
  layoutOptions.samplesPerUnitArea = settings.samplesPerUnitArea;
  auto atlas = settings.layout == SampleLayout::Split ? buildSplitLayout(scene, layoutOptions)
                                                       : buildChartsLayout(scene, layoutOptions);
  if (!atlas) return atlas.error();
  plan.atlas = std::move(atlas.value());
  auto tracer = Tracer::create(scene);
  if (!tracer) return tracer.error();
  plan.tracer = std::move(tracer.value());
  // Only where the field may be a volume (one medium in air): a field of another encoding stores its
  // exits, and first-refraction's have fewer jumps to store.
  if (choose && settings.choosePathRule && volumeSceneProblem(scene).empty())
    if (auto chosen = choosePathRule(scene, plan); !chosen) return chosen.error();
  settings.choosePathRule = false;  // chosen once: a part file carries the rule, and a merge keeps it

  if (choose && settings.maxErrorDegrees > 0.0f && settings.encoding == Encoding::Sh) {
    auto chosen = selectOrderAndDirections(plan.atlas, *plan.tracer, settings, settings.threads, options.note);
    if (!chosen) return chosen.error();
    const Selection& sel = chosen.value();
    if (options.note)
      options.note(std::string(sel.met ? "max-error: chose" : "max-error: target not met; using") + " order " +
                   std::to_string(sel.order) + ", " + std::to_string(sel.rows) + "x" + std::to_string(sel.columns) +
                   " directions (mean error " + std::to_string(sel.meanDegrees) + " deg, target " +
                   std::to_string(settings.maxErrorDegrees) + " deg)");
    settings.order = sel.order;
    settings.directionsTheta = sel.rows;
    settings.directionsPhi = sel.columns;
  }

  bool absorbs = false;
  for (size_t m = 1; m < scene.media.size(); ++m) absorbs = absorbs || scene.media[m].absorption > 0.0f;
  // Leave out what the scene does not need: without absorption the optical depth is always zero.
  plan.channels = 3u + (absorbs ? 1u : 0u) + (settings.throughput ? 1u : 0u);
  if (choose && settings.maxBytesPerSample > 0.0f) {
    auto chosen = selectForBudget(plan.atlas, *plan.tracer, settings, plan.channels, settings.threads, options.note);
    if (!chosen) return chosen.error();
    settings = chosen.value();
    bakeChoiceAtItsShape(settings, options.settings, options.note);
  }
  // After the budget's choice, whose SH candidates fit as asked: tables are fitted by least squares.
  if (settings.encoding != Encoding::Sh) settings.shFit = ShFit::LeastSquares;
  settings.jumpDistance = storesJumpDistance(settings);  // the field records whether it was stored
  if (settings.jumpDistance) plan.channels += 1;
  plan.grid = settings.directionSampling == DirectionSampling::Nodes
                  ? makeNodeGrid(settings.tableSize)
                  : makeHemisphereGrid(settings.directionsTheta, settings.directionsPhi);
  for (const Medium& m : scene.media) plan.media.push_back({m.name, m.ior, m.absorption, {m.color.x, m.color.y, m.color.z}});
  plan.sceneHash = sceneFingerprint(scene, plan.atlas);
  return plan;
}

}  // namespace shrefract::bake::detail
