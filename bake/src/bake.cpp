#include <shrefract/bake/bake.h>
#include <shrefract/bake/distance_volume.h>
#include <shrefract/bake/fit.h>
#include <shrefract/bake/image.h>
#include <shrefract/bake/image_metrics.h>
#include <shrefract/bake/jump_distance.h>
#include <shrefract/bake/layout.h>
#include <shrefract/bake/reference_render.h>
#include <shrefract/bake/sample_frame.h>
#include <shrefract/bake/shard.h>
#include <shrefract/bake/table_fit.h>
#include <shrefract/bake/tracer.h>
#include <shrefract/gpu_layout.h>
#include <shrefract/sh.h>
#include <shrefract/cpu_reference.h>

#include "splitmix.h"
#include "parallel.h"

#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>


namespace shrefract::bake {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

uint64_t peakResidentBytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<uint64_t>(usage.ru_maxrss) * 1024u;  // Linux reports kilobytes
}

// The jump distance channel where the decode is jump-aware (field.h BakeSettings::jumpDistance).
bool storesJumpDistance(const BakeSettings& s) {
  return s.jumpDistance && s.encoding != Encoding::Sh && s.directionSampling == DirectionSampling::Nodes &&
         s.tableSize >= gpu::kJumpMinTableSize;
}

// Exits traced into the sample's frame (ExitFrame::Sample, and Auto until a Pca bake chooses).
bool tracesInSampleFrame(const BakeSettings& s) { return s.exitFrame != ExitFrame::Object; }

EncodingShape shapeOf(const BakeSettings& s, uint32_t channels) {
  return {s.encoding, s.order, s.tableSize, s.components, channels,
          s.encoding != Encoding::Sh && s.directionSampling == DirectionSampling::Nodes, storesJumpDistance(s),
          tracesInSampleFrame(s)};
}
size_t strideOf(const EncodingShape& shape) { return size_t(shape.layerCount()) * shape.valuesPerLayer(); }

// Values of one node table (Table, Pca): N x N nodes of every encoded channel.
size_t tableValues(const EncodingShape& shape) { return size_t(shape.tableSize) * shape.tableSize * shape.channels; }

// The rows of M_s, as the field stores a sample's frame.
std::array<float, 12> sampleRows(const SurfacePoint& p) {
  return localFromWorldRows(p.position, frameAt(p));
}

// The float (unquantized) encoding at local direction w of the sample at `point`: the engine's
// own sums (field_decode.h), jump-aware as the decoder is, so the bake measures exactly what the
// decoder will compute before quantization.
void decodeFloat(const EncodingShape& shape, const std::vector<float>& basis, const float* coeffs,
                 const SurfacePoint& point, glm::vec3 w, float* out) {
  const std::array<float, 12> rows = sampleRows(point);
  evaluateCoefficients(shape, coeffs, basis.empty() ? nullptr : basis.data(), {w.x, w.y, w.z}, out, rows.data());
}

// A sample's coefficients as something cheap to decode at many directions. A Pca sample's weights
// are summed once into its table (Table's layout), which decodes as the weights do: the same
// products added in the same order as evaluateStored's corners (the cube's statistics came out
// bit-identical, docs/performance.md). Decoding the weights
// reads K scattered basis values per corner and direction instead, and that was most of a
// components field's bake after learning (the cube's two checks at 40000 samples: 50 s of 378).
// Other shapes decode their coefficients as they are.
struct ManyDirectionDecoder {
  EncodingShape shape;
  const float* coeffs = nullptr;
  const float* basis = nullptr;
  std::vector<float> table;  // the summed table, where there is one: it stands for coeffs and basis

  ManyDirectionDecoder(const EncodingShape& s, const float* basisValues, const float* c)
      : shape(s), coeffs(c), basis(basisValues) {
    if (s.encoding != Encoding::Pca || s.clustered) return;
    const size_t values = tableValues(s);
    table.assign(values, 0.0f);
    for (uint32_t k = 0; k < s.components; ++k) {
      const float a = c[k], *f = basisValues + k * values;
      for (size_t v = 0; v < values; ++v) table[v] += a * f[v];
    }
    shape.encoding = Encoding::Table;
    shape.components = 0;
  }
  void decode(glm::vec3 w, const float* rows, float* out) const {
    const bool summed = !table.empty();
    evaluateCoefficients(shape, summed ? table.data() : coeffs, summed ? nullptr : basis, {w.x, w.y, w.z}, out, rows);
  }
};

// Angle in degrees between two directions; a zero-length reconstruction counts as 180 degrees.
double angleDegrees(glm::vec3 a, glm::vec3 b) {
  const float la = glm::length(a), lb = glm::length(b);
  if (!(la > 0.0f) || !(lb > 0.0f)) return 180.0;
  const double c = std::clamp(static_cast<double>(glm::dot(a, b) / (la * lb)), -1.0, 1.0);
  return std::acos(c) * (180.0 / 3.14159265358979323846);
}

// How every path of the bake is traced, the --max-error and --max-bytes-per-sample probes included.
TraceSettings traceSettingsOf(const BakeSettings& s) {
  TraceSettings ts;
  ts.maxBounces = s.maxBounces;
  ts.pathRule = s.pathRule;
  return ts;
}

// The exit direction as the field stores it: in the sample's frame or in object space.
glm::vec3 storedExit(bool sampleFrame, const LocalFrame& frame, glm::vec3 exit) {
  return sampleFrame ? worldToLocal(frame, exit) : exit;
}

// A traced path as the field's channels: x, y, z of the exit direction (storedExit), then the
// optical depth when a medium absorbs, then the Fresnel throughput when it is stored.
struct ChannelLayout {
  uint32_t channels = 3;
  bool depth = false, throughput = false, sampleFrame = false;
  static ChannelLayout of(uint32_t channels, const BakeSettings& s) {
    return {channels, channels == (s.throughput ? 5u : 4u), s.throughput, tracesInSampleFrame(s)};
  }
  void store(const PathResult& path, const LocalFrame& frame, float* v) const {
    const glm::vec3 exit = storedExit(sampleFrame, frame, path.exitDirection);
    for (int c = 0; c < 3; ++c) v[c] = exit[c];
    if (depth) v[3] = path.opticalDepth;
    if (throughput) v[channels - 1] = path.energy;
  }
};

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

struct SampleError {
  double gridSquares = 0.0, gridMax = 0.0;
  double heldSquares = 0.0, heldMax = 0.0;
  uint32_t gridCount = 0, heldCount = 0;
};


// `perSample` cosine-weighted view directions (in the sample's frame) at each of `samples`, from the
// fixed sequence of seed ^ (sample * golden ratio), and their traced exits: in the sample's frame
// when sampleFrame (storedExit), in object space otherwise. Held-out checks of the bake's choices.
struct TracedViews {
  std::vector<glm::vec3> directions, exits;  // samples.size() x perSample
};
TracedViews traceCosineViews(const SampleAtlas& atlas, const Tracer& tracer, const TraceSettings& ts,
                             const std::vector<size_t>& samples, uint32_t perSample, uint64_t seed, bool sampleFrame,
                             uint32_t threads) {
  TracedViews v;
  v.directions.resize(samples.size() * perSample);
  v.exits = v.directions;
  parallelFor(samples.size(), threads, [&](size_t k) {
    const SurfacePoint& p = atlas.samples[samples[k]];
    const LocalFrame frame = frameAt(p);
    uint64_t rng = seed ^ (uint64_t(samples[k]) * 0x9e3779b97f4a7c15ull);
    for (uint32_t h = 0; h < perSample; ++h) {
      const glm::vec3 w = cosineWeightedDirection(rng);
      v.directions[k * perSample + h] = w;
      const glm::vec3 exit = tracer.traceFromSurface(p, -localToWorld(frame, w), ts).exitDirection;
      v.exits[k * perSample + h] = storedExit(sampleFrame, frame, exit);
    }
  });
  return v;
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

// Fits one sample's traced grid values into the floats the field stores for it (Pca: into its
// table; the weights come once the whole field has been traced).
constexpr uint32_t kBudgetPcaTableSize = 16;  // N of the basis tables when the budget picks Pca

std::string candidateLabel(const BakeSettings& s) {
  const std::string q = toString(s.quantization);
  switch (s.encoding) {
    case Encoding::Sh: return "sh order " + std::to_string(s.order) + " " + q;
    case Encoding::Table: return "table " + std::to_string(s.tableSize) + "x" + std::to_string(s.tableSize) + " " + q;
    case Encoding::Pca: return "pca " + std::to_string(s.components) + " components " + q;
    case Encoding::Volume: return "volume " + std::to_string(s.volumeSize) + "^3";
  }
  return "unknown";
}

class SampleEncoder {
 public:
  static Result<SampleEncoder> create(const DirectionGrid& grid, const BakeSettings& s, uint32_t channels) {
    SampleEncoder e;
    e.channels_ = channels;
    if (s.encoding == Encoding::Sh) {
      auto fit = shFitOf(grid, s.order, s);
      if (!fit) return fit.error();
      e.sh_.emplace(std::move(fit.value()));
      e.stride_ = size_t(e.sh_->basisCount()) * channels;
    } else {
      auto fit = s.directionSampling == DirectionSampling::Nodes ? TableFit::atNodes(s.tableSize)
                                                                 : TableFit::create(grid, s.tableSize);
      if (!fit) return fit.error();
      e.table_.emplace(std::move(fit.value()));
      e.stride_ = size_t(e.table_->nodeCount()) * channels;
    }
    return e;
  }
  size_t stride() const { return stride_; }
  void fit(const float* values, float* out) const {
    if (sh_) sh_->fit(values, channels_, out);
    else table_->fit(values, channels_, out);
  }

 private:
  std::optional<HemisphereFit> sh_;
  std::optional<TableFit> table_;
  uint32_t channels_ = 0;
  size_t stride_ = 0;
};

// What the statistics need after the field is encoded: the traced exits at held-out directions of
// every sample, and at the grid directions of every kGridCheckStride-th sample.
struct TracedChecks {
  std::vector<glm::vec3> heldDirections, heldExits;  // samples x heldOut
  std::vector<glm::vec3> gridExits;                  // (samples / stride, rounded up) x directions
};

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

// Everything a bake decides before tracing; every shard of a bake and its merge decide alike.
struct BakePlan {
  BakeSettings settings;  // normalized, after the --max-error / --max-bytes-per-sample choices
  uint32_t channels = 3;
  SampleAtlas atlas;
  std::unique_ptr<Tracer> tracer;
  DirectionGrid grid;
  std::vector<FieldMedium> media;
  uint64_t sceneHash = 0;
  std::function<void(const std::string&)> note;  // BakeOptions::note (none for a merge)
  std::function<void(const std::string&)> stage;  // BakeOptions::stage
  void begin(const std::string& what) const {
    if (stage) stage(what);
  }
};

// The jump distance channel of one sample (jump_distance.h): the nodes as traced, bisections traced
// at the same point. Stored in grid cells times kJumpDistanceScale / (N - 1) (gpu_layout.h).
void storeJumpDistances(const Tracer& tracer, const SurfacePoint& point, const LocalFrame& frame, uint32_t n,
                        const std::vector<glm::vec3>& incidents, const std::vector<PathResult>& paths,
                        const TraceSettings& ts, uint32_t channels, float* values, uint64_t& rays) {
  std::vector<TracedView> nodes(paths.size());
  for (size_t d = 0; d < paths.size(); ++d) nodes[d] = {paths[d].exitDirection, incidents[d], paths[d].trapped};
  const std::vector<float> cells = jumpDistances(n, nodes, [&](float x, float y) {
    const glm::vec3 incident = -localToWorld(frame, glm::vec3(nodeDirection(x, y, n)));
    const PathResult path = tracer.traceFromSurface(point, incident, ts);
    rays += path.rays;
    return TracedView{path.exitDirection, incident};
  });
  const float unit = gpu::kJumpDistanceScale / float(n - 1);
  for (size_t d = 0; d < cells.size(); ++d) values[d * channels + channels - 1] = cells[d] * unit;
}

// What the workers of traceAndFit share. Each sample writes only its own slots of part's arrays.
struct ShardTrace {
  const BakePlan& plan;
  const Tracer& tracer;
  const SampleEncoder& encoder;
  Shard shard;
  uint32_t held;
  TraceSettings traceSettings;
  ChannelLayout layout;
  std::vector<size_t> gridSlot;  // local sample -> its slot of part.gridExits, SIZE_MAX for none
  BakePart& part;
};

// One worker's buffers (reused from sample to sample), counters and thread times.
struct TraceWorker {
  std::vector<float> values;
  std::vector<glm::vec3> incidents;
  std::vector<PathResult> paths;
  uint64_t rays = 0, pathCount = 0, trapped = 0;
  double traceSeconds = 0.0, fitSeconds = 0.0;
  TraceWorker(uint32_t nd, uint32_t channels) : values(size_t(nd) * channels), incidents(nd), paths(nd) {}
};

// The shard's samples on the grid-check lattice get consecutive slots of part.gridExits.
std::vector<size_t> gridCheckSlots(Shard shard, size_t count, size_t& slots) {
  std::vector<size_t> gridSlot(count, SIZE_MAX);
  slots = 0;
  for (size_t k = 0; k < count; ++k)
    if ((shard.index + k * shard.count) % kGridCheckStride == 0) gridSlot[k] = slots++;
  return gridSlot;
}

// Traces every grid direction of local sample k into w.values, and its exits into part.gridExits
// where the sample is on the grid-check lattice.
void traceGridDirections(const ShardTrace& t, size_t k, const SurfacePoint& point, const LocalFrame& frame,
                         TraceWorker& w) {
  const DirectionGrid& grid = t.plan.grid;
  const uint32_t nd = static_cast<uint32_t>(grid.directions.size()), channels = t.plan.channels;
  // The eye looks along -w: the incident ray travels toward the surface.
  for (uint32_t d = 0; d < nd; ++d) w.incidents[d] = -localToWorld(frame, glm::vec3(grid.directions[d]));
  t.tracer.traceFromSurface(point, w.incidents, t.traceSettings, w.paths);
  for (uint32_t d = 0; d < nd; ++d) {
    const PathResult& path = w.paths[d];
    w.rays += path.rays;
    w.pathCount += 1;
    w.trapped += path.trapped ? 1u : 0u;
    t.layout.store(path, frame, &w.values[size_t(d) * channels]);
    if (t.gridSlot[k] != SIZE_MAX)
      for (int c = 0; c < 3; ++c) t.part.gridExits[(t.gridSlot[k] * nd + d) * 3 + size_t(c)] = path.exitDirection[c];
  }
}

// Traces the held-out directions of local sample k (global sample s) into part.heldOut.
void traceHeldOut(const ShardTrace& t, size_t k, uint64_t s, const SurfacePoint& point, const LocalFrame& frame,
                  TraceWorker& w) {
  uint64_t rng = 0x5348524546ull ^ (s * 0x9e3779b97f4a7c15ull);
  for (uint32_t h = 0; h < t.held; ++h) {
    // Uniform over the hemisphere, away from the exact horizon.
    const float z = 0.02f + 0.98f * unitFloat(rng);
    const float phi = 6.28318530718f * unitFloat(rng);
    const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    const glm::vec3 dir(r * std::cos(phi), r * std::sin(phi), z);
    const PathResult path = t.tracer.traceFromSurface(point, -localToWorld(frame, dir), t.traceSettings);
    w.rays += path.rays;
    w.pathCount += 1;
    float* slot = &t.part.heldOut[(k * t.held + h) * 6];
    for (int c = 0; c < 3; ++c) slot[c] = dir[c], slot[3 + c] = path.exitDirection[c];
  }
}

// Traces, fits and checks local sample k, timing the tracing and the fit apart.
void traceSample(const ShardTrace& t, size_t k, TraceWorker& w) {
  const BakeSettings& settings = t.plan.settings;
  const uint64_t s = t.shard.index + uint64_t(k) * t.shard.count;
  const auto sampleStart = Clock::now();
  const SurfacePoint& point = t.plan.atlas.samples[s];
  const LocalFrame frame = frameAt(point);
  traceGridDirections(t, k, point, frame, w);
  if (settings.jumpDistance)
    storeJumpDistances(t.tracer, point, frame, settings.tableSize, w.incidents, w.paths, t.traceSettings,
                       t.plan.channels, w.values.data(), w.rays);
  const auto fitStart = Clock::now();
  t.encoder.fit(w.values.data(), &t.part.coefficients[k * t.encoder.stride()]);
  const auto heldOutStart = Clock::now();
  traceHeldOut(t, k, s, point, frame, w);
  const auto sampleEnd = Clock::now();
  w.fitSeconds += std::chrono::duration<double>(heldOutStart - fitStart).count();
  w.traceSeconds += std::chrono::duration<double>((fitStart - sampleStart) + (sampleEnd - heldOutStart)).count();
}

// Traces every grid direction of the shard's samples (threads), fits each sample with `encoder`,
// and records what the checks need: part.coefficients, heldOut, gridExits, the counters and the
// thread times. Local sample k is sample shard.index + k * shard.count.
void traceAndFit(const BakePlan& plan, const SampleEncoder& encoder, const BakeOptions& options, Shard shard,
                 Clock::time_point start, BakePart& part) {
  const size_t count = shardSampleCount(plan.atlas.samples.size(), shard);
  const uint32_t nd = static_cast<uint32_t>(plan.grid.directions.size());
  const uint32_t held = options.heldOutDirections, channels = plan.channels;
  size_t slots = 0;
  std::vector<size_t> gridSlot = gridCheckSlots(shard, count, slots);
  part.coefficients.assign(count * encoder.stride(), 0.0f);
  part.heldOut.assign(count * held * 6, 0.0f);
  part.gridExits.assign(slots * nd * 3, 0.0f);
  // The traced channels; the jump distance, when stored, is the last one (storeJumpDistances).
  const ChannelLayout layout =
      ChannelLayout::of(channels - (plan.settings.jumpDistance ? 1u : 0u), plan.settings);
  const ShardTrace trace{plan, *plan.tracer, encoder, shard, held, traceSettingsOf(plan.settings),
                         layout, std::move(gridSlot), part};

  std::atomic<size_t> next{0};
  std::atomic<uint64_t> done{0}, raysSoFar{0};
  std::mutex totalsMutex;
  constexpr size_t kChunk = 8;
  auto worker = [&]() {
    TraceWorker w(nd, channels);
    for (;;) {
      const size_t begin = next.fetch_add(kChunk);
      if (begin >= count) break;
      const size_t end = std::min(count, begin + kChunk);
      const uint64_t raysBefore = w.rays;
      for (size_t k = begin; k < end; ++k) traceSample(trace, k, w);
      raysSoFar.fetch_add(w.rays - raysBefore);
      done.fetch_add(end - begin);
    }
    const std::lock_guard<std::mutex> lock(totalsMutex);
    part.rays += w.rays;
    part.paths += w.pathCount;
    part.trappedPaths += w.trapped;
    part.timings.threadTraceSeconds += w.traceSeconds;
    part.timings.threadFitSeconds += w.fitSeconds;
  };
  std::vector<std::thread> pool;
  for (uint32_t t = 1; t < plan.settings.threads; ++t) pool.emplace_back(worker);
  std::thread mainWorker(worker);
  while (done.load() < count) {
    if (options.progress) options.progress({done.load(), count, raysSoFar.load(), secondsSince(start)});
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  mainWorker.join();
  for (auto& t : pool) t.join();
  if (options.progress) options.progress({count, count, raysSoFar.load(), secondsSince(start)});
}

// Where the fit check decodes grid direction d. A node grid's border nodes are traced lifted to
// kNodeMinZ, which the table maps up to half a cell inside its border (N = 64): decoded there, the
// check measured the interpolation toward the next row, where grazing paths jump, as fit error
// (7.9 deg RMS on the torus's uncompressed 64x64 table). At the node's own direction the decode
// reads that node alone, so only the Pca truncation errs, as the summary says.
glm::vec3 fitCheckDirection(const EncodingShape& shape, const DirectionGrid& grid, uint32_t d) {
  if (!shape.jumpAware) return glm::vec3(grid.directions[d]);  // a fitted grid: its own directions
  const std::array<float, 3> node = hemiOctDirection(d % shape.tableSize, d / shape.tableSize, shape.tableSize);
  return {node[0], node[1], node[2]};
}

// Fit and held-out errors of the float encoding (grid: every kGridCheckStride-th sample), one
// sample per task: each writes only its own errors[s].
void measureFit(const EncodingShape& shape, const std::vector<float>& basis, const std::vector<float>& coeffs,
                const SampleAtlas& atlas, const DirectionGrid& grid, const TracedChecks& checks, uint32_t held,
                uint32_t threads, std::vector<SampleError>& errors) {
  const uint32_t nd = static_cast<uint32_t>(grid.directions.size());
  parallelFor(errors.size(), threads, [&](size_t s) {
    std::vector<float> out(shape.channels);
    SampleError& err = errors[s];
    const float* c = &coeffs[s * strideOf(shape)];
    if (s % kGridCheckStride == 0) {
      const ManyDirectionDecoder decoder(shape, basis.data(), c);
      const std::array<float, 12> rows = sampleRows(atlas.samples[s]);
      for (uint32_t d = 0; d < nd; ++d) {
        decoder.decode(fitCheckDirection(shape, grid, d), rows.data(), out.data());
        const glm::vec3 traced = checks.gridExits[s / kGridCheckStride * nd + d];
        const double a = angleDegrees(glm::vec3(out[0], out[1], out[2]), traced);
        err.gridSquares += a * a;
        err.gridMax = std::max(err.gridMax, a);
        ++err.gridCount;
      }
    }
    for (uint32_t h = 0; h < held; ++h) {
      decodeFloat(shape, basis, c, atlas.samples[s], checks.heldDirections[s * held + h], out.data());
      const double a = angleDegrees(glm::vec3(out[0], out[1], out[2]), checks.heldExits[s * held + h]);
      err.heldSquares += a * a;
      err.heldMax = std::max(err.heldMax, a);
      ++err.heldCount;
    }
  });
}

// A Pca basis of a field's tables and their weights.
struct LearnedBasis {
  std::vector<float> basis, weights;
};

Result<LearnedBasis> learnBasis(const EncodingShape& shape, const std::vector<float>& tables, size_t sampleCount,
                                uint32_t threads) {
  LearnedBasis out;
  auto pca = fitPcaBasis(tables, sampleCount, shape.tableSize, shape.channels, shape.components, out.weights, threads);
  if (!pca) return pca.error();
  out.basis = std::move(pca.value().basis);
  return out;
}

// Tables traced in the sample's frame (table k belongs to sample samples[k]): channels 0..2 of
// every node rotated to object space, in place.
void rotateExitsToObjectSpace(std::vector<float>& tables, const std::vector<size_t>& samples,
                              const SampleAtlas& atlas, const EncodingShape& shape) {
  const size_t nodes = size_t(shape.tableSize) * shape.tableSize, dim = nodes * shape.channels;
  for (size_t k = 0; k < samples.size(); ++k) {
    const LocalFrame frame = frameAt(atlas.samples[samples[k]]);
    for (size_t node = 0; node < nodes; ++node) {
      float* v = &tables[k * dim + node * shape.channels];
      const glm::vec3 exit = localToWorld(frame, glm::vec3(v[0], v[1], v[2]));
      for (int c = 0; c < 3; ++c) v[c] = exit[c];
    }
  }
}

// The tables of `samples`, in that order.
std::vector<float> gatherTables(const std::vector<float>& tables, const std::vector<size_t>& samples, size_t dim) {
  std::vector<float> out(samples.size() * dim);
  for (size_t k = 0; k < samples.size(); ++k)
    std::copy_n(&tables[samples[k] * dim], dim, &out[k * dim]);
  return out;
}

// Traced views the exit frame and the basis (keepClusters) are chosen on: kFrameChoiceViews
// cosine-weighted directions at every (n / kFrameChoiceSamples)-th sample (all of a field under 2
// kFrameChoiceSamples samples, otherwise between kFrameChoiceSamples and twice as many), traced for
// the choice alone (so it does not depend on --held-out), with a fixed sequence per sample.
constexpr size_t kFrameChoiceSamples = 2048;
constexpr uint32_t kFrameChoiceViews = 8;
struct FrameChoiceViews {
  std::vector<size_t> samples;
  TracedViews views;  // exits in object space
};

size_t frameChoiceStep(size_t n) { return std::max<size_t>(1, n / kFrameChoiceSamples); }

FrameChoiceViews traceFrameChoiceViews(const BakePlan& plan) {
  FrameChoiceViews v;
  const size_t n = plan.atlas.samples.size(), step = frameChoiceStep(n);
  for (size_t s = 0; s < n; s += step) v.samples.push_back(s);
  v.views = traceCosineViews(plan.atlas, *plan.tracer, traceSettingsOf(plan.settings), v.samples, kFrameChoiceViews,
                             0x4652414d45ull, false, plan.settings.threads);
  return v;
}

// The samples the two candidate bases are learned from: as many as the views' samples, midway
// between them, so that the views test each basis on tables it was not learned from (a field under
// 2 kFrameChoiceSamples samples: all of them, the views' samples included).
std::vector<size_t> frameChoiceTrainingSamples(size_t n) {
  const size_t step = frameChoiceStep(n);
  std::vector<size_t> out;
  for (size_t s = step / 2; s < n; s += step) out.push_back(s);
  return out;
}

// The mean angle (degrees), each clipped at kFrameChoiceClipDegrees, between a learned basis's float
// decode (jump-aware, as the engine decodes) and the traced exits of the views; weights: those of the
// views' samples, in their order. Clipped, because
// an exit a few degrees off already shows another part of the environment, so that the image's
// error saturates where the angle does not: the bunny's mean angles (34.07 deg in the sample's
// frame, 34.17 in object space, over views 3 % of which decode within 1 deg) rank the frames against
// its images (14.78 against 15.01 dB at the angular step); clipped at 5 deg (4.42, 4.35) they rank
// them as the images do, and so on the sphere, torus and glass of water (16x16 tables). The cube's
// images then preferred object space by 0.42 dB, which no statistic of these views said; at 64x64
// they prefer the sample's frame by 2.46 dB, as the views do (docs/encodings.md).
constexpr double kFrameChoiceClipDegrees = 5.0;
double meanClippedDegrees(const EncodingShape& shape, const std::vector<float>& basis,
                          const std::vector<float>& weights, const SampleAtlas& atlas, const FrameChoiceViews& v) {
  std::vector<float> out(shape.channels);
  double sum = 0.0;
  for (size_t k = 0; k < v.samples.size(); ++k)
    for (uint32_t h = 0; h < kFrameChoiceViews; ++h) {
      const size_t s = v.samples[k], i = k * kFrameChoiceViews + h;
      decodeFloat(shape, basis, &weights[k * shape.components], atlas.samples[s], v.views.directions[i], out.data());
      sum += std::min(angleDegrees(glm::vec3(out[0], out[1], out[2]), v.views.exits[i]), kFrameChoiceClipDegrees);
    }
  return v.views.directions.empty() ? 0.0 : sum / double(v.views.directions.size());
}

// One candidate frame: a basis learned from the training tables (with the training tables' weights)
// and the clipped mean angle of the views' tables projected on it.
struct FrameCandidate {
  double degrees = 0.0;
  LearnedBasis learned;
};

Result<FrameCandidate> candidateFrame(const EncodingShape& shape, const std::vector<float>& training, size_t trainingCount,
                                      const std::vector<float>& viewTables, const SampleAtlas& atlas,
                                      const FrameChoiceViews& views, uint32_t threads) {
  FrameCandidate c;
  auto pca = fitPcaBasis(training, trainingCount, shape.tableSize, shape.channels, shape.components, c.learned.weights,
                         threads);
  if (!pca) return pca.error();
  const std::vector<float> weights = projectOnBasis(viewTables, views.samples.size(), pca.value(), threads);
  c.degrees = meanClippedDegrees(shape, pca.value().basis, weights, atlas, views);
  c.learned.basis = std::move(pca.value().basis);
  return c;
}

// ExitFrame::Auto: whether the tables (traced in the sample's frame) keep it rather than object
// space. Each frame's basis is learned from a subset of the samples (frameChoiceTrainingSamples) and
// the one whose decode is closer to freshly traced exits kept (FrameChoiceViews, meanClippedDegrees;
// the rank-K residual, tried as the criterion, chose the sample's frame on the bunny, whose images
// are worse there); the field's basis is then learned once, in the frame kept. Learning both from
// every sample took two full fits: the cube's default 64x64 bake took 700 s and 5.17 GiB at peak,
// now 519 to 561 s and 3.55 GiB (docs/encodings.md, "Choosing the frame on a subset"). A field
// under 2 kFrameChoiceSamples samples learns both candidates from every sample, in order: then the
// kept frame's basis and weights are the field's, returned in `kept`, and not learned again.
Result<bool> keepSampleFrame(const BakePlan& plan, const EncodingShape& shape, const std::vector<float>& tables,
                             const FrameChoiceViews& views, std::optional<LearnedBasis>& kept) {
  const SampleAtlas& atlas = plan.atlas;
  const size_t dim = tableValues(shape);
  const std::vector<size_t> trainingSamples = frameChoiceTrainingSamples(atlas.samples.size());
  plan.begin("choosing the exit frame: bases of " + std::to_string(shape.components) + " components in each frame from " +
             std::to_string(trainingSamples.size()) + " samples");
  std::vector<float> training = gatherTables(tables, trainingSamples, dim), viewTables = gatherTables(tables, views.samples, dim);
  auto sample = candidateFrame(shape, training, trainingSamples.size(), viewTables, atlas, views, plan.settings.threads);
  if (!sample) return sample.error();
  EncodingShape objectShape = shape;
  objectShape.sampleFrameExits = false;
  rotateExitsToObjectSpace(training, trainingSamples, atlas, shape);
  rotateExitsToObjectSpace(viewTables, views.samples, atlas, shape);
  auto object = candidateFrame(objectShape, training, trainingSamples.size(), viewTables, atlas, views,
                               plan.settings.threads);
  if (!object) return object.error();
  const bool keep = !(object->degrees < sample->degrees);
  if (trainingSamples.size() == atlas.samples.size()) kept = std::move(keep ? sample->learned : object->learned);
  if (plan.note)
    plan.note(std::string("exit frame: chose ") + (keep ? "the sample's frame" : "object space") + " (mean angle, clipped at " +
              std::to_string(int(kFrameChoiceClipDegrees)) + " deg, to " + std::to_string(views.views.directions.size()) +
              " traced views, bases learned from " + std::to_string(trainingSamples.size()) + " samples: " +
              std::to_string(sample->degrees) + " deg in the sample's frame, " + std::to_string(object->degrees) +
              " deg in object space)");
  return keep;
}

// A cluster's mean stands for its samples when it has a population: the encoding test's cube of
// 294 samples chose 64 clusters of 4.6 samples each by 0.01 deg on the views (0.843 against 0.856)
// and then decoded its test directions worse than 256 components, out of the ladder's order. From
// 8 samples a cluster they rendered better or the same (4000-sample bakes, 12.5 to 14 a cluster:
// torus +0.32 dB, glass of water +0.19, sphere -0.01; the report's glass of water sweep at K = 324,
// 9.9 a cluster: +0.06, which keeps that sweep rising with the bytes: docs/encodings.md, "The
// report's Pca sweep with clusters").
constexpr size_t kMinSamplesPerCluster = 8;
// k-means finds a local optimum, and the torus's images differ by seed (25.42 to 25.81 dB at 4x4
// over three): the clusterings of this many seeds are measured on the views, the closest kept.
constexpr uint32_t kClusterRestarts = 4;

// With BakeSettings::moreClusters (the tool's default) the bake also tries this many times as many
// clusters as components: a cluster's table is stored once per field, not per sample, so more of
// them cost memory, not bytes per sample, and each holds fewer samples' jumps (the torus's default
// field 26.39 -> 26.65 dB against the 4x4 full tree with 972 clusters for 324, the glass of
// water's 24.59 -> 25.07 against the 8x8; docs/encodings.md "Three times the clusters").
// Tried, not assumed: on a 1500-sample sphere of 8x8 tables 96 clusters read farther on the views
// than 24. Their tables stay within kDefaultClusterTableBytes, well under the smallest storage
// buffer range Vulkan allows a device (2^27 bytes).
constexpr uint32_t kDefaultClustersPerComponent = 3;
constexpr size_t kDefaultClusterTableBytes = size_t(64) << 20;

// The cluster counts a Pca bake tries, fewest first: BakeSettings::clusters where asked, else the
// components' count and, with BakeSettings::moreClusters where the samples and the tables' memory
// allow, kDefaultClustersPerComponent times it.
uint32_t fewestClusters(const BakeSettings& settings, const EncodingShape& shape) {
  return settings.clusters ? settings.clusters : shape.components;
}

std::vector<uint32_t> clusterCounts(const BakeSettings& settings, const EncodingShape& shape, size_t samples) {
  std::vector<uint32_t> counts{fewestClusters(settings, shape)};
  if (settings.clusters || !settings.moreClusters) return counts;
  const uint64_t more = uint64_t(shape.components) * kDefaultClustersPerComponent;
  const size_t tableBytes = tableValues(shape) * sizeof(uint16_t);  // binary16 (docs/encodings.md)
  if (more <= kMaxClusters && samples >= kMinSamplesPerCluster * more &&
      more * tableBytes <= kDefaultClusterTableBytes)
    counts.push_back(uint32_t(more));
  return counts;
}

// Spatial smoothing (--spatial) blends neighbours' weights, which an index cannot hold: those bakes
// keep the components.
bool clustersEligible(const BakeSettings& settings, size_t samples, const EncodingShape& shape) {
  return settings.spatialNeighbours == 0 && samples >= kMinSamplesPerCluster * size_t(fewestClusters(settings, shape));
}

// The best of kClusterRestarts k-means seeds at `count` clusters, by the views' clipped mean angle.
struct ClusterTry {
  ClusteredBasis basis;
  uint32_t count = 0;
  double degrees = std::numeric_limits<double>::max();
};

Result<ClusterTry> bestClustering(const BakePlan& plan, const EncodingShape& shape, const std::vector<float>& tables,
                                  const FrameChoiceViews& views, const LearnedBasis& learned, uint32_t count) {
  const size_t n = plan.atlas.samples.size(), dim = tableValues(shape);
  EncodingShape clusteredShape = shape;
  clusteredShape.components = count;
  plan.begin("clustering " + std::to_string(n) + " samples into " + std::to_string(count) + " tables, " +
             std::to_string(kClusterRestarts) + " times");
  ClusterTry best;
  best.count = count;
  for (uint32_t seed = 0; seed < kClusterRestarts; ++seed) {
    auto clustered =
        clusterTables(tables, n, dim, learned.weights, shape.components, count, seed, plan.settings.threads);
    if (!clustered) return clustered.error();
    const std::vector<float> weights = gatherTables(clustered.value().weights, views.samples, count);
    const double degrees = meanClippedDegrees(clusteredShape, clustered.value().basis, weights, plan.atlas, views);
    if (degrees < best.degrees) {
      best.degrees = degrees;
      best.basis = std::move(clustered.value());
    }
  }
  return best;
}

// Clusters (table_fit.h): whether the field keeps the mean tables of clusters of its samples (the
// closest of clusterCounts' tries), each sample storing its cluster's index (EncodingShape::clustered:
// 2 bytes, one table read per decode), rather than its K components; `learned` is replaced where it
// does: the cluster means and one float per sample, the index. Chosen by the exit frame's measure
// (meanClippedDegrees, the same views): the nodes' RMS prefers the components on every scene (torus
// 15.9 against 18.7 deg), while the images prefer the clusters on glass turned on a lathe
// (docs/encodings.md, "Clusters"). Returns the clusters kept, 0 where the components stay.
Result<uint32_t> keepClusters(const BakePlan& plan, const EncodingShape& shape, const std::vector<float>& tables,
                              const FrameChoiceViews& views, LearnedBasis& learned) {
  const size_t n = plan.atlas.samples.size();
  if (!clustersEligible(plan.settings, n, shape)) return 0u;
  const double components = meanClippedDegrees(shape, learned.basis, gatherTables(learned.weights, views.samples,
                                                                                  shape.components),
                                               plan.atlas, views);
  ClusterTry best;
  std::string others;
  for (uint32_t count : clusterCounts(plan.settings, shape, n)) {
    auto tried = bestClustering(plan, shape, tables, views, learned, count);
    if (!tried) return tried.error();
    if (tried.value().degrees < best.degrees) std::swap(best, tried.value());
    if (tried.value().count)  // the try that lost (none before the first)
      others += "; " + std::to_string(tried.value().degrees) + " deg with " + std::to_string(tried.value().count);
  }
  const bool keep = best.degrees < components;
  if (plan.note)
    plan.note(std::string("pca basis: chose ") + (keep ? "clusters" : "components") + " (mean angle, clipped at " +
              std::to_string(int(kFrameChoiceClipDegrees)) + " deg, to " + std::to_string(views.views.directions.size()) +
              " traced views: " + std::to_string(components) + " deg with " + std::to_string(shape.components) +
              " components, " + std::to_string(best.degrees) + " deg with " +
              (best.count == shape.components ? std::string("as many") : std::to_string(best.count)) +
              " clusters" + others + ", the best of " + std::to_string(kClusterRestarts) + " seeds each)");
  if (!keep) return 0u;
  learned = LearnedBasis{std::move(best.basis.basis),
                         std::vector<float>(best.basis.cluster.begin(), best.basis.cluster.end())};
  return best.count;
}

// Pca: replaces each sample's table by its weights over a basis learned from all of them, in the
// frame of ExitFrame::Auto's choice (keepSampleFrame) where the tables were traced in the sample's
// frame. The sample's frame shares functions among samples alike up to a rotation about the up
// axis; object space among samples that face alike (docs/encodings.md, "Exits in the sample's
// frame"). Sets shape.sampleFrameExits to the frame kept, and shape.clustered where the basis is
// the clusters' means (keepClusters: each sample's coefficients are then its index).
Result<void> learnBasisInItsFrame(const BakePlan& plan, EncodingShape& shape, std::vector<float>& coeffs,
                                  std::vector<float>& basis) {
  const SampleAtlas& atlas = plan.atlas;
  const size_t n = atlas.samples.size();
  // The views serve both choices; a field that makes neither traces none.
  FrameChoiceViews views;
  if (plan.settings.exitFrame == ExitFrame::Auto || clustersEligible(plan.settings, n, shape)) {
    plan.begin("tracing the views the frame and the basis are chosen on");
    views = traceFrameChoiceViews(plan);
  }
  std::optional<LearnedBasis> learnedInTheChoice;
  if (plan.settings.exitFrame == ExitFrame::Auto) {
    auto keep = keepSampleFrame(plan, shape, coeffs, views, learnedInTheChoice);
    if (!keep) return keep.error();
    if (!keep.value()) {
      std::vector<size_t> all(n);
      for (size_t s = 0; s < n; ++s) all[s] = s;
      rotateExitsToObjectSpace(coeffs, all, atlas, shape);
      shape.sampleFrameExits = false;
    }
  }
  plan.begin("learning the pca basis: " + std::to_string(shape.components) + " components from " + std::to_string(n) +
             " samples of " + std::to_string(tableValues(shape)) + " values" +
             (learnedInTheChoice ? ": the exit frame's choice learned it" : ""));
  auto learned = learnedInTheChoice ? Result<LearnedBasis>(std::move(*learnedInTheChoice))
                                    : learnBasis(shape, coeffs, n, plan.settings.threads);
  if (!learned) return learned.error();
  auto clusters = keepClusters(plan, shape, coeffs, views, learned.value());
  if (!clusters) return clusters.error();
  shape.clustered = clusters.value() != 0;
  if (shape.clustered) shape.components = clusters.value();
  basis = std::move(learned.value().basis);
  coeffs = std::move(learned.value().weights);
  return {};
}

// ---- --max-bytes-per-sample: the encoding with the lowest error within a byte budget ----------

struct BudgetCandidate {
  BakeSettings settings;  // encoding, order / tableSize / components, quantization
  uint32_t bytes = 0;
  double meanDegrees = 0.0;
};

// The largest parameter of each encoding and quantization that fits `budget` bytes per sample.
std::vector<BudgetCandidate> budgetCandidates(const BakeSettings& base, uint32_t channels, double budget) {
  std::vector<BudgetCandidate> out;
  for (Quantization q : {Quantization::U8, Quantization::F16}) {
    const double perValue = q == Quantization::U8 ? 1.0 : 2.0;
    const double functions = budget / perValue;  // layers x values that fit
    auto add = [&](Encoding e, uint32_t order, uint32_t n, uint32_t k, uint32_t bytes) {
      BudgetCandidate c{base, bytes, 0.0};
      c.settings.directionSampling = DirectionSampling::Grid;  // all fitted to the probe's grid
      c.settings.encoding = e;
      c.settings.order = order;
      c.settings.tableSize = n;
      c.settings.components = k;
      c.settings.quantization = q;
      out.push_back(c);
    };
    const uint32_t order = static_cast<uint32_t>(std::floor(std::sqrt(functions / channels))) - 1u;
    if (functions >= channels && order <= static_cast<uint32_t>(kMaxFitOrder))
      add(Encoding::Sh, order, 0, 0, (order + 1) * (order + 1) * channels * uint32_t(perValue));
    const uint32_t n = std::min(kMaxBakeTableSize, static_cast<uint32_t>(std::floor(std::sqrt(functions / channels))));
    if (n >= 2) add(Encoding::Table, 0, n, 0, n * n * channels * uint32_t(perValue));
    const uint32_t k = std::min(kMaxComponents, static_cast<uint32_t>(functions));
    if (k >= 1) add(Encoding::Pca, 0, kBudgetPcaTableSize, k, k * uint32_t(perValue));
  }
  return out;
}

// U8 as the field stores it: per (layer, value) range over the given samples, 255 levels.
void simulateU8(std::vector<float>& coeffs, size_t samples, size_t stride) {
  for (size_t i = 0; i < stride; ++i) {
    float lo = coeffs[i], hi = coeffs[i];
    for (size_t s = 0; s < samples; ++s) {
      lo = std::min(lo, coeffs[s * stride + i]);
      hi = std::max(hi, coeffs[s * stride + i]);
    }
    const float range = hi - lo;
    if (!(range > 0.0f)) continue;
    for (size_t s = 0; s < samples; ++s) {
      float& v = coeffs[s * stride + i];
      v = lo + range * std::round((v - lo) / range * 255.0f) / 255.0f;
    }
  }
}

// Samples traced on the grid (fit input) and at cosine-weighted held-out directions (error).
struct BudgetProbe {
  std::vector<size_t> train, test;          // sample indices (test disjoint from train when possible)
  std::vector<float> values;                // (train + test) x grid directions x channels
  std::vector<glm::vec3> heldDirs, heldExits;  // test x kHeld
  static constexpr uint32_t kHeld = 64;
};

BudgetProbe traceProbe(const SampleAtlas& atlas, const Tracer& tracer, const DirectionGrid& grid,
                       const BakeSettings& s, uint32_t channels, uint32_t threads) {
  BudgetProbe p;
  const size_t n = atlas.samples.size();
  const size_t trainCount = std::min<size_t>(n, 1024), testCount = std::min<size_t>(n, 192);
  for (size_t i = 0; i < trainCount; ++i) p.train.push_back(i * n / trainCount);
  for (size_t i = 0; i < testCount; ++i) p.test.push_back((i * n / testCount + n / (2 * testCount) + 1) % n);
  std::vector<size_t> all = p.train;
  all.insert(all.end(), p.test.begin(), p.test.end());
  const size_t nd = grid.directions.size();
  p.values.assign(all.size() * nd * channels, 0.0f);
  p.heldDirs.assign(testCount * BudgetProbe::kHeld, glm::vec3(0.0f));
  p.heldExits = p.heldDirs;
  const TraceSettings ts = traceSettingsOf(s);
  const ChannelLayout layout = ChannelLayout::of(channels, s);
  parallelFor(all.size(), threads, [&](size_t k) {
    const SurfacePoint& point = atlas.samples[all[k]];
    const LocalFrame frame = frameAt(point);
    for (size_t d = 0; d < nd; ++d) {
      const PathResult path = tracer.traceFromSurface(point, -localToWorld(frame, glm::vec3(grid.directions[d])), ts);
      layout.store(path, frame, &p.values[(k * nd + d) * channels]);
    }
    if (k < p.train.size()) return;
    const size_t t = k - p.train.size();
    uint64_t rng = 0x4255444745540000ull ^ (uint64_t(all[k]) * 0x9e3779b97f4a7c15ull);
    for (uint32_t h = 0; h < BudgetProbe::kHeld; ++h) {
      const glm::vec3 w = cosineWeightedDirection(rng);
      p.heldDirs[t * BudgetProbe::kHeld + h] = w;
      p.heldExits[t * BudgetProbe::kHeld + h] = tracer.traceFromSurface(point, -localToWorld(frame, w), ts).exitDirection;
    }
  });
  return p;
}

// Mean angular error of one candidate on the probe's test samples, cosine-weighted (as often as a
// view direction covers the screen), after quantization.
Result<double> candidateError(const BudgetCandidate& c, const BudgetProbe& p, const SampleAtlas& atlas,
                              const DirectionGrid& grid, uint32_t channels, uint32_t threads) {
  auto encoder = SampleEncoder::create(grid, c.settings, channels);
  if (!encoder) return encoder.error();
  const size_t nd = grid.directions.size(), fitStride = encoder->stride();
  const size_t all = p.train.size() + p.test.size();
  std::vector<float> fitted(all * fitStride);
  for (size_t k = 0; k < all; ++k) encoder->fit(&p.values[k * nd * channels], &fitted[k * fitStride]);
  const EncodingShape shape = shapeOf(c.settings, channels);
  std::vector<float> test(fitted.begin() + std::ptrdiff_t(p.train.size() * fitStride), fitted.end());
  std::vector<float> basis;
  if (c.settings.encoding == Encoding::Pca) {
    // The basis is learned from the training samples only; the test samples are projected on it.
    std::vector<float> train(fitted.begin(), fitted.begin() + std::ptrdiff_t(p.train.size() * fitStride)), weights;
    auto pca = fitPcaBasis(train, p.train.size(), shape.tableSize, channels, shape.components, weights, threads);
    if (!pca) return pca.error();
    test = projectOnBasis(test, p.test.size(), pca.value(), threads);
    basis = std::move(pca.value().basis);
    if (c.settings.quantization == Quantization::U8) {  // as finishBake: refined on the training weights
      const std::vector<uint32_t> refined = chooseRefinedComponents(weights, p.train.size(), shape.components);
      makeRefinementLayers(test, p.test.size(), shape.components, basis, tableValues(shape), refined);
      std::vector<float> coarse = test;
      simulateU8(coarse, p.test.size(), strideOf(shape));
      fillRefinementWeights(test, p.test.size(), shape.components, refined,
                            [&](size_t s, uint32_t k) { return coarse[s * shape.components + k]; });
      for (size_t s = 0; s < p.test.size(); ++s)  // the coarse layers as quantized; simulateU8 keeps them
        for (uint32_t k : refined) test[s * shape.components + k] = coarse[s * shape.components + k];
    }
  }
  if (c.settings.quantization == Quantization::U8) simulateU8(test, p.test.size(), strideOf(shape));
  double sum = 0.0, weight = 0.0;
  std::vector<float> out(channels);
  for (size_t t = 0; t < p.test.size(); ++t)
    for (uint32_t h = 0; h < BudgetProbe::kHeld; ++h) {
      const glm::vec3 w = p.heldDirs[t * BudgetProbe::kHeld + h];
      decodeFloat(shape, basis, &test[t * strideOf(shape)], atlas.samples[p.test[t]], w, out.data());
      sum += double(w.z) * angleDegrees(glm::vec3(out[0], out[1], out[2]), p.heldExits[t * BudgetProbe::kHeld + h]);
      weight += double(w.z);
    }
  return weight > 0.0 ? sum / weight : 0.0;
}

// Picks the candidate of lowest error and reports every one through `note`.
Result<BakeSettings> selectForBudget(const SampleAtlas& atlas, const Tracer& tracer, const BakeSettings& s,
                                     uint32_t channels, uint32_t threads,
                                     const std::function<void(const std::string&)>& note) {
  const DirectionGrid grid = makeHemisphereGrid(s.directionsTheta, s.directionsPhi);
  std::vector<BudgetCandidate> candidates = budgetCandidates(s, channels, double(s.maxBytesPerSample));
  if (candidates.empty())
    return makeError(ErrorCode::InvalidArgument, "--max-bytes-per-sample " + std::to_string(s.maxBytesPerSample) +
                                                     " is below the smallest encoding (" + std::to_string(channels) +
                                                     " bytes for " + std::to_string(channels) + " channels)");
  const BudgetProbe probe = traceProbe(atlas, tracer, grid, s, channels, threads);
  const BudgetCandidate* best = nullptr;
  for (BudgetCandidate& c : candidates) {
    auto error = candidateError(c, probe, atlas, grid, channels, threads);
    if (!error) {  // e.g. too few directions for an SH order: not a candidate
      if (note) note("max-bytes-per-sample: " + candidateLabel(c.settings) + " skipped: " + error.error().message);
      continue;
    }
    c.meanDegrees = error.value();
    if (note)
      note("max-bytes-per-sample: " + candidateLabel(c.settings) + ", " + std::to_string(c.bytes) +
           " bytes: mean error " + std::to_string(c.meanDegrees) + " deg");
    if (!best || c.meanDegrees < best->meanDegrees) best = &c;
  }
  if (!best) return makeError(ErrorCode::InvalidArgument, "--max-bytes-per-sample: no encoding could be fitted");
  if (note)
    note("max-bytes-per-sample: chose " + candidateLabel(best->settings) + " (" + std::to_string(best->bytes) +
         " bytes per sample, lowest mean error " + std::to_string(best->meanDegrees) + " deg on " +
         std::to_string(probe.test.size()) + " held-out samples)");
  return best->settings;
}

// The budget measures every candidate on one grid probe, Pca on kBudgetPcaTableSize grid-fitted
// tables; the field is then baked in the chosen encoding's own shape. SH and Table fields are grid
// fits (node sampling pays for Pca's tables only: docs/encodings.md, "Sampling"). A Pca field
// keeps the requested node sampling and table size, the tool's default (32x32 nodes, with the jump
// distance), which measured better than 16x16 tables on the built-in scenes (docs/encodings.md,
// "Choosing"): there the probe's figure overstates the baked Pca field's error.
void bakeChoiceAtItsShape(BakeSettings& chosen, const BakeSettings& requested,
                          const std::function<void(const std::string&)>& note) {
  // Every candidate is a grid fit (budgetCandidates): only a Pca field asked at its nodes changes.
  if (chosen.encoding != Encoding::Pca || requested.directionSampling != DirectionSampling::Nodes) return;
  chosen.directionSampling = DirectionSampling::Nodes;
  chosen.tableSize = requested.tableSize;
  if (note)
    note("max-bytes-per-sample: baking the pca field on " + std::to_string(chosen.tableSize) + "x" +
         std::to_string(chosen.tableSize) + " node tables (the probe measured " + std::to_string(kBudgetPcaTableSize) +
         "x" + std::to_string(kBudgetPcaTableSize) + " grid fits)");
}

// FNV-1a over what a merge must share with the parts: the layout's samples, texels, gutters,
// neighbours and mesh, and the media. A changed scene file or override changes it.
class Fingerprint {
 public:
  template <class T>
  void add(const T* data, size_t count) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(data);
    for (size_t i = 0; i < count * sizeof(T); ++i) hash_ = (hash_ ^ bytes[i]) * 0x100000001b3ull;
  }
  template <class T>
  void add(const std::vector<T>& v) {
    const uint64_t n = v.size();
    add(&n, 1);
    add(v.data(), v.size());
  }
  uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 0xcbf29ce484222325ull;
};

uint64_t sceneFingerprint(const Scene& scene, const SampleAtlas& atlas) {
  Fingerprint f;
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

// Checks and normalizes the settings, lays out the samples, builds the tracer and, with `choose`,
// makes the --max-error and --max-bytes-per-sample choices (a merge takes them from its parts).
Result<void> choosePathRule(const Scene& scene, BakePlan& plan);

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

// Traces and fits the shard's samples of a planned bake.
Result<BakePart> tracePart(const BakePlan& plan, const BakeOptions& options, Shard shard, Clock::time_point start) {
  auto encoder = SampleEncoder::create(plan.grid, plan.settings, plan.channels);
  if (!encoder) return encoder.error();
  BakePart part;
  part.settings = plan.settings;
  part.heldOutDirections = options.heldOutDirections;
  part.shard = shard;
  part.sampleCount = plan.atlas.samples.size();
  part.sceneHash = plan.sceneHash;
  part.channels = plan.channels;
  part.directions = static_cast<uint32_t>(plan.grid.directions.size());
  part.stride = encoder->stride();
  const auto traceStart = Clock::now();
  traceAndFit(plan, encoder.value(), options, shard, start, part);
  part.timings.traceWallSeconds = secondsSince(traceStart);
  part.timings.bakeSeconds = secondsSince(start);
  part.timings.peakMemoryBytes = peakResidentBytes();
  return part;
}

// The parts' per-sample results in sample order, as one process would have them; each part's
// arrays are freed once copied.
struct Gathered {
  std::vector<float> coeffs;  // samples x stride
  TracedChecks checks;
};
Gathered gatherParts(std::vector<BakePart>& parts, size_t stride, uint32_t nd, uint32_t held) {
  const size_t n = parts.front().sampleCount;
  Gathered g;
  if (parts.size() == 1) g.coeffs = std::move(parts.front().coefficients);  // already in sample order
  else g.coeffs.assign(n * stride, 0.0f);
  g.checks.heldDirections.assign(n * held, glm::vec3(0.0f));
  g.checks.heldExits.assign(n * held, glm::vec3(0.0f));
  g.checks.gridExits.assign((n + kGridCheckStride - 1) / kGridCheckStride * nd, glm::vec3(0.0f));
  for (BakePart& part : parts) {
    size_t slot = 0;
    for (size_t k = 0, s = part.shard.index; s < n; ++k, s += part.shard.count) {
      if (parts.size() > 1)
        std::copy_n(&part.coefficients[k * stride], stride, &g.coeffs[s * stride]);
      for (uint32_t h = 0; h < held; ++h) {
        const float* v = &part.heldOut[(k * held + h) * 6];
        g.checks.heldDirections[s * held + h] = glm::vec3(v[0], v[1], v[2]);
        g.checks.heldExits[s * held + h] = glm::vec3(v[3], v[4], v[5]);
      }
      if (s % kGridCheckStride != 0) continue;
      for (uint32_t d = 0; d < nd; ++d) {
        const float* v = &part.gridExits[(slot * nd + d) * 3];
        g.checks.gridExits[s / kGridCheckStride * nd + d] = glm::vec3(v[0], v[1], v[2]);
      }
      ++slot;
    }
    part.coefficients = {};
    part.heldOut = {};
    part.gridExits = {};
  }
  return g;
}

// encodeCoefficients straight from the per-sample fits (coeffs: stride floats a sample, layer i's
// values at i * valuesPerLayer): texels of kind kTexelSample read their sample's, the rest are
// zeros. No texel-ordered float copy of the atlas, which was the bake's largest allocation.
Result<void> encodeSamples(Field& field, const SampleAtlas& atlas, const EncodingShape& shape,
                           const std::vector<float>& coeffs) {
  const size_t stride = strideOf(shape);
  return encodeCoefficients(
      field,
      [&](uint64_t t) -> const float* {
        return atlas.texelKinds[t] == kTexelSample ? coeffs.data() + size_t(atlas.texelSample[t]) * stride : nullptr;
      },
      shape.valuesPerLayer());
}

// The first texel of every sample (UINT64_MAX for a sample no texel holds).
std::vector<uint64_t> firstTexels(const SampleAtlas& atlas) {
  std::vector<uint64_t> texelOf(atlas.samples.size(), UINT64_MAX);
  for (size_t t = 0; t < size_t(atlas.width) * atlas.height; ++t)
    if (atlas.texelKinds[t] == kTexelSample && texelOf[atlas.texelSample[t]] == UINT64_MAX)
      texelOf[atlas.texelSample[t]] = t;
  return texelOf;
}

// A u8 Pca field's refinement layers (table_fit.h): quantizes the field once with them at zero,
// fills them with what each refined layer lost, and quantizes again (each layer has its own
// range, so the refined layers' codes do not change).
Result<void> encodeWithRefinement(Field& field, const SampleAtlas& atlas, const EncodingShape& shape,
                                  const std::vector<float>& fitted, const std::vector<uint32_t>& refined) {
  if (auto r = encodeSamples(field, atlas, shape, fitted); !r || refined.empty()) return r;
  // The weights are filled into a copy: the statistics that follow compare the field with the fit.
  std::vector<float> coeffs = fitted;
  const std::vector<uint64_t> texelOf = firstTexels(atlas);
  fillRefinementWeights(coeffs, atlas.samples.size(), shape.components, refined, [&](size_t s, uint32_t k) {
    return texelOf[s] == UINT64_MAX ? coeffs[s * shape.components + k] : fieldCoefficient(field, k, texelOf[s], 0);
  });
  return encodeSamples(field, atlas, shape, coeffs);
}

// Quantization error: the decoded direction from quantized coefficients against the float
// encoding, at every third grid direction of every 7th sample (deterministic subset; the sums run
// in sample order whatever the threads).
void measureQuantization(const Field& field, const SampleAtlas& atlas, const std::vector<float>& basis,
                         const std::vector<float>& coeffs, const DirectionGrid& grid, uint32_t threads,
                         BakeStatistics& st) {
  constexpr size_t kSampleStride = 7;
  const EncodingShape shape = field.shape();
  const std::vector<uint64_t> texelOf = firstTexels(atlas);
  // One slot per checked sample; its grid* fields hold the quantization angles (the held* stay 0).
  std::vector<SampleError> errors((atlas.samples.size() + kSampleStride - 1) / kSampleStride);
  parallelFor(errors.size(), threads, [&](size_t i) {
    const size_t s = i * kSampleStride;
    if (texelOf[s] == UINT64_MAX) return;
    std::vector<float> a(shape.channels), b(shape.channels), quantized;
    // Once per sample, not per direction: a 64x64 table has 4096 layers to dequantize.
    dequantizeSample(field, texelOf[s], quantized);
    const ManyDirectionDecoder exact(shape, basis.data(), &coeffs[s * strideOf(shape)]);
    const ManyDirectionDecoder stored(shape, field.basis.data(), quantized.data());
    const std::array<float, 12> sampleFrame = sampleRows(atlas.samples[s]);
    const float* rows = &field.frames[texelOf[s] * 12];
    for (size_t d = 0; d < grid.directions.size(); d += 3) {
      const glm::vec3 w(grid.directions[d]);
      exact.decode(w, sampleFrame.data(), a.data());
      stored.decode(w, rows, b.data());
      const double angle = angleDegrees(glm::vec3(a[0], a[1], a[2]), glm::vec3(b[0], b[1], b[2]));
      errors[i].gridSquares += angle * angle;
      errors[i].gridMax = std::max(errors[i].gridMax, angle);
      ++errors[i].gridCount;
    }
  });
  double squares = 0.0, maxAngle = 0.0;
  uint64_t count = 0;
  for (const SampleError& e : errors) {
    squares += e.gridSquares;
    maxAngle = std::max(maxAngle, e.gridMax);
    count += e.gridCount;
  }
  st.quantizationRmsDegrees = count ? static_cast<float>(std::sqrt(squares / double(count))) : 0.0f;
  st.quantizationMaxDegrees = static_cast<float>(maxAngle);
}

// The atlas's texels of kind kTexelSample: the field's samples, as its statistics count them.
uint64_t sampleTexelCount(const SampleAtlas& atlas) {
  uint64_t samples = 0;
  for (uint8_t kind : atlas.texelKinds) samples += kind == kTexelSample ? 1u : 0u;
  return samples;
}

// Counts, fit errors and timings. Parts may have run at the same time on different machines: the
// longest one is the bake's wall time, the thread times of all apportion it between trace and fit.
void fillStatistics(const SampleAtlas& atlas, const std::vector<BakePart>& parts, const std::vector<SampleError>& errors,
                    uint32_t nd, double finishSeconds, BakeStatistics& st) {
  st.uniqueSamples = atlas.samples.size();
  st.samples = sampleTexelCount(atlas);
  st.directions = nd;
  double gridSquares = 0, heldSquares = 0, traceWall = 0, partSeconds = 0, threadTrace = 0, threadFit = 0;
  uint64_t gridCount = 0, heldCount = 0, peak = peakResidentBytes();
  for (const BakePart& p : parts) {
    st.rays += p.rays;
    st.paths += p.paths;
    st.trappedPaths += p.trappedPaths;
    traceWall = std::max(traceWall, p.timings.traceWallSeconds);
    partSeconds = std::max(partSeconds, p.timings.bakeSeconds);
    threadTrace += p.timings.threadTraceSeconds;
    threadFit += p.timings.threadFitSeconds;
    peak = std::max(peak, p.timings.peakMemoryBytes);
  }
  for (const SampleError& e : errors) {  // in sample order: deterministic sums
    gridSquares += e.gridSquares;
    heldSquares += e.heldSquares;
    gridCount += e.gridCount;
    heldCount += e.heldCount;
    st.fitMaxDegrees = std::max(st.fitMaxDegrees, static_cast<float>(e.gridMax));
    st.heldOutMaxDegrees = std::max(st.heldOutMaxDegrees, static_cast<float>(e.heldMax));
  }
  st.fitRmsDegrees = gridCount ? static_cast<float>(std::sqrt(gridSquares / double(gridCount))) : 0.0f;
  st.heldOutRmsDegrees = heldCount ? static_cast<float>(std::sqrt(heldSquares / double(heldCount))) : 0.0f;
  const double traceShare = threadTrace + threadFit > 0.0 ? threadTrace / (threadTrace + threadFit) : 1.0;
  st.traceSeconds = traceWall * traceShare;
  st.fitSeconds = traceWall * (1.0 - traceShare) + finishSeconds;
  st.bakeSeconds = partSeconds + finishSeconds;
  st.raysPerSecond = traceWall > 0.0 ? double(st.rays) / traceWall : 0.0;
  st.peakMemoryBytes = peak;
}

// Spatial smoothing (--spatial) of every sample's floats, then the SH band window.
void smoothSamples(const BakePlan& plan, const BakeSettings& settings, size_t stride, std::vector<float>& coeffs) {
  const SampleAtlas& atlas = plan.atlas;
  const size_t sampleCount = atlas.samples.size();
  if (settings.spatialNeighbours != 0) {
    std::vector<glm::vec3> positions(sampleCount);
    for (size_t s = 0; s < sampleCount; ++s) positions[s] = atlas.samples[s].position;
    smoothSpatially(coeffs, stride, positions, atlas.neighbours, settings.spatialNeighbours);
  }
  if (settings.window != SmoothingWindow::None && settings.encoding == Encoding::Sh) {
    const std::vector<double> weights = bandWindow(settings.window, static_cast<int>(settings.order));
    for (size_t s = 0; s < sampleCount; ++s)
      sh::applyWindow(static_cast<int>(settings.order), weights.data(), &coeffs[s * stride],
                      static_cast<int>(plan.channels));
  }
}

// The field as the plan lays it out, before its coefficients are encoded: header, texels, mesh
// and every sample texel's frame.
Field fieldLayout(const BakePlan& plan, const BakeSettings& settings, const EncodingShape& shape,
                  const std::vector<float>& basis) {
  const SampleAtlas& atlas = plan.atlas;
  Field field;
  field.width = atlas.width;
  field.height = atlas.height;
  field.encoding = settings.encoding;
  field.order = settings.order;
  field.tableSize = settings.tableSize;
  field.components = settings.components;
  field.channels = plan.channels;
  field.throughput = settings.throughput;
  field.jumpDistance = settings.jumpDistance;
  field.sampleFrameExits = shape.sampleFrameExits;
  field.clustered = shape.clustered;
  field.settings = settings;  // before encoding: its validation reads the direction sampling
  field.basis = basis;
  field.quantization = settings.quantization;
  field.texelKinds = atlas.texelKinds;
  field.gutters = atlas.gutters;
  field.mesh = atlas.mesh;
  const size_t texels = size_t(atlas.width) * atlas.height;
  field.frames.assign(texels * 12, 0.0f);
  for (size_t t = 0; t < texels; ++t) {
    if (atlas.texelKinds[t] != kTexelSample) continue;
    const auto rows = sampleRows(atlas.samples[atlas.texelSample[t]]);
    std::copy(rows.begin(), rows.end(), &field.frames[t * 12]);
  }
  return field;
}

// The steps that need every sample, the same for a single-process bake, a merge of part files and
// rank 0 of an MPI bake: the Pca basis, smoothing, the window, the error statistics, quantization.
// `parts` passed checkParts and match the plan.
Result<Field> finishBake(const BakePlan& plan, std::vector<BakePart> parts) {
  const auto finishStart = Clock::now();
  BakeSettings settings = plan.settings;
  const SampleAtlas& atlas = plan.atlas;
  const DirectionGrid& grid = plan.grid;
  const size_t sampleCount = atlas.samples.size();
  const uint32_t nd = static_cast<uint32_t>(grid.directions.size()), held = parts.front().heldOutDirections;
  EncodingShape shape = shapeOf(settings, plan.channels);
  Gathered g = gatherParts(parts, parts.front().stride, nd, held);
  std::vector<float>& coeffs = g.coeffs;

  std::vector<float> basis;
  if (settings.encoding == Encoding::Pca) {
    if (auto learned = learnBasisInItsFrame(plan, shape, coeffs, basis); !learned) return learned.error();
    settings.components = shape.components;  // what the field stores: the clusters, where it keeps them
  }
  settings.exitFrame = shape.sampleFrameExits ? ExitFrame::Sample : ExitFrame::Object;  // what the field stores
  smoothSamples(plan, settings, strideOf(shape), coeffs);
  std::vector<uint32_t> refined;
  // A clustered field stores one index a sample: nothing for refinement layers to refine.
  if (settings.encoding == Encoding::Pca && settings.quantization == Quantization::U8 && !shape.clustered) {
    refined = chooseRefinedComponents(coeffs, sampleCount, shape.components);
    makeRefinementLayers(coeffs, sampleCount, shape.components, basis,
                         tableValues(shape), refined);
  }
  std::vector<SampleError> errors(sampleCount);
  plan.begin("checking the fit against the traced directions");
  measureFit(shape, basis, coeffs, atlas, grid, g.checks, held, settings.threads, errors);

  Field field = fieldLayout(plan, settings, shape, basis);
  plan.begin("quantizing " + std::to_string(sampleCount) + " samples");
  if (auto encoded = encodeWithRefinement(field, atlas, shape, coeffs, refined); !encoded) return encoded.error();
  measureQuantization(field, atlas, basis, coeffs, grid, settings.threads, field.statistics);
  field.media = plan.media;
  field.settings = settings;
  for (const BakePart& p : parts) field.settings.threads = std::max(field.settings.threads, p.settings.threads);
  fillStatistics(atlas, parts, errors, nd, secondsSince(finishStart), field.statistics);

  if (auto valid = validateField(field); !valid)
    return makeError(ErrorCode::CorruptData, "bake produced an invalid field: " + valid.error().message);
  return field;
}

// A finished field's decode (evaluateSample at each view sample's first texel, object space)
// against the traced views: the mean angle with each clipped at kFrameChoiceClipDegrees (the
// measure the Pca bake chooses its frame and basis by, here on the field as stored), the RMS and
// largest angle unclipped, and the PSNR of the colours the two exits see in the built-in
// environment (clamped to [0, 1], as the report's images are compared): a miss counts by what it
// changes in the image, so a path that goes another way through chaotic glass (the torus's tube)
// counts fully, where the clipped angle gives it 5 deg.
struct ViewsError {
  double clippedMean = 0.0, rms = 0.0, max = 0.0, colourPsnr = 0.0;
};
// The built-in environment at the width its lookups here need (the report's is 1024 wide; a sun
// of a few texels survives at 512).
constexpr uint32_t kChoiceEnvironmentWidth = 512;
const Image& choiceEnvironment() {
  static const Image environment = proceduralEnvironment(kChoiceEnvironmentWidth);
  return environment;
}

// The colour an exit sees in the choices' built-in environment, clamped to [0, 1].
glm::vec3 choiceColour(glm::vec3 d) {
  return glm::clamp(sampleLatLong(choiceEnvironment(), d), glm::vec3(0.0f), glm::vec3(1.0f));
}

ViewsError fieldViewsError(const Field& field, const SampleAtlas& atlas, const FrameChoiceViews& v, uint32_t threads) {
  const std::vector<uint64_t> texelOf = firstTexels(atlas);
  std::vector<double> clipped(v.samples.size()), squares(v.samples.size()), worst(v.samples.size()),
      colour(v.samples.size());
  parallelFor(v.samples.size(), threads, [&](size_t k) {
    for (uint32_t h = 0; h < kFrameChoiceViews; ++h) {
      const glm::vec3 w = v.views.directions[k * kFrameChoiceViews + h];
      float out[kMaxFieldChannels] = {};
      evaluateSample(field, texelOf[v.samples[k]], {w.x, w.y, w.z}, out);
      const glm::vec3 decoded(out[0], out[1], out[2]), traced = v.views.exits[k * kFrameChoiceViews + h];
      const double a = angleDegrees(decoded, traced);
      clipped[k] += std::min(a, kFrameChoiceClipDegrees);
      squares[k] += a * a;
      worst[k] = std::max(worst[k], a);
      const glm::vec3 e = choiceColour(decoded) - choiceColour(traced);
      colour[k] += double(glm::dot(e, e)) / 3.0;
    }
  });
  ViewsError e;
  for (size_t k = 0; k < v.samples.size(); ++k) {  // in sample order: deterministic sums
    e.clippedMean += clipped[k];
    e.rms += squares[k];
    e.max = std::max(e.max, worst[k]);
    e.colourPsnr += colour[k];
  }
  const double count = double(v.views.directions.size());
  if (count > 0) {
    e.clippedMean /= count;
    e.rms = std::sqrt(e.rms / count);
    e.colourPsnr = 10.0 * std::log10(1.0 / std::max(e.colourPsnr / count, 1e-10));
  }
  return e;
}

// A sample texel's point and normal from its frame's rows (M_s = [R | -R p]).
glm::vec3 framePoint(const float* m) {
  return -(m[3] * glm::vec3(m[0], m[1], m[2]) + m[7] * glm::vec3(m[4], m[5], m[6]) +
           m[11] * glm::vec3(m[8], m[9], m[10]));
}

// How well a Volume field's texels predict the paths between them: for up to
// kVolumeDensityPairs pairs of sample texels side by side in the atlas (x and x + 1, at most twice
// the median spacing apart: not across a chart's border), kFrameChoiceViews cosine-weighted views
// about their mean normal; the path the field traces at the pair's midpoint against the mean of
// the two texels' exits (what bilinear filtering reads there), as the PSNR of the colours they see
// in the built-in environment. Smooth glass predicts well (the sphere 37.6 dB at the default 40000
// samples); where paths change faster than the texels (the bunny's 14.5, the cube's edges 28.0,
// the torus's reflections 24.3) the texels do not. Deterministic for any thread count.
double volumeSpatialPsnr(const Field& field, uint32_t threads) {
  std::vector<uint64_t> pairs;  // the left texel
  std::vector<float> spacing;
  for (uint64_t t = 0; t + 1 < field.texelCount(); ++t) {
    if ((t + 1) % field.width == 0 || field.texelKinds[t] != kTexelSample || field.texelKinds[t + 1] != kTexelSample)
      continue;
    pairs.push_back(t);
    spacing.push_back(glm::distance(framePoint(&field.frames[t * 12]), framePoint(&field.frames[(t + 1) * 12])));
  }
  if (pairs.empty()) return std::numeric_limits<double>::infinity();
  std::vector<float> sorted = spacing;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const float limit = 2.0f * sorted[sorted.size() / 2];
  const size_t step = std::max<size_t>(1, pairs.size() / kVolumeDensityPairs);
  std::vector<size_t> chosen;
  for (size_t i = 0; i < pairs.size(); i += step)
    if (spacing[i] <= limit) chosen.push_back(i);
  std::vector<double> squares(chosen.size());
  parallelFor(chosen.size(), threads, [&](size_t k) {
    const float* a = &field.frames[pairs[chosen[k]] * 12];
    const float* b = a + 12;
    const glm::vec3 normal = glm::normalize(glm::vec3(a[8], a[9], a[10]) + glm::vec3(b[8], b[9], b[10]));
    const LocalFrame frame = frameFromNormal(normal);
    const std::array<float, 12> m = localFromWorldRows(0.5f * (framePoint(a) + framePoint(b)), frame);
    uint64_t rng = 0x564f4c554d45ull ^ (uint64_t(chosen[k]) * 0x9e3779b97f4a7c15ull);
    for (uint32_t h = 0; h < kFrameChoiceViews; ++h) {
      const glm::vec3 toEye = localToWorld(frame, cosineWeightedDirection(rng));  // the eye far away
      auto exitAt = [&](const float* rows) {
        const std::array<float, 3> w{glm::dot(glm::vec3(rows[0], rows[1], rows[2]), toEye),
                                     glm::dot(glm::vec3(rows[4], rows[5], rows[6]), toEye),
                                     glm::dot(glm::vec3(rows[8], rows[9], rows[10]), toEye)};
        float out[kMaxFieldChannels] = {};
        traceVolumeSample(field, rows, w, out);
        return glm::vec3(out[0], out[1], out[2]);
      };
      const glm::vec3 between = exitAt(a) + exitAt(b);
      const glm::vec3 e = choiceColour(glm::length(between) > 0.0f ? glm::normalize(between) : toEye) -
                          choiceColour(exitAt(m.data()));
      squares[k] += double(glm::dot(e, e)) / 3.0;
    }
  });
  double sum = 0.0;
  for (double v : squares) sum += v;  // in pair order: deterministic
  const double mean = sum / double(std::max<size_t>(1, chosen.size() * kFrameChoiceViews));
  return 10.0 * std::log10(1.0 / std::max(mean, 1e-10));
}

// The default's choice between the baked field and the volume (keepVolumeWhereCloser), by their
// images: kChoiceViews views of the object (40 deg framing its bounds, from four sides and a little
// above), each field drawn by the CPU mirror of the engine's raster pass as the engine draws it by
// default (bake::renderDistortion: the baked field by its decoded sample texels, the volume traced
// per fragment) against the exact render of the field's path rule, kChoiceImageWidth x
// kChoiceImageHeight at 2x2 samples, in the built-in environment; PSNR over the exact render's
// object pixels, colours clamped to [0, 1], the views pooled. The traced views at the samples
// (fieldViewsError) did not rank them as the images do: the cube's Pca read 29.27 dB there against
// the volume's 24.15, where its image reads 31.45 against 33.39; nor at the midpoints of
// neighbouring texels (cosine-weighted views: 25.52 against 23.10; tried, not kept)
// (docs/encodings.md, "Volume traced per fragment"). At the report's 320x240: at 128x96 the
// torus's tube is a few pixels across and the pixel sampling term ranks them (its Pca 24.32 dB
// against the volume's 24.07; 192x144 25.62 / 25.50, 256x192 26.17 / 26.72, 320x240 26.55 /
// 27.74, where the report's views read the volume 1.2 to 2.0 dB closer to the full tree), for
// about 4 s of the bake (docs/encodings.md, "The choice's images at the report's size").
constexpr uint32_t kChoiceViews = 4, kChoiceImageWidth = 320, kChoiceImageHeight = 240;
struct ImageChoice {
  std::vector<double> psnr;  // per field, in the order given
  uint64_t pixels = 0;
};

// The cameras of the image choice: kChoiceViews eyes about the scene's bounds.
std::vector<Camera> choiceCameras(const Scene& scene) {
  const Bounds box = bounds(scene);
  const glm::vec3 centre = 0.5f * (box.min + box.max);
  const float radius = std::max(0.5f * glm::length(box.max - box.min), 1e-3f);
  const float distance = 1.1f * radius / std::sin(glm::radians(20.0f));
  std::vector<Camera> cameras;
  for (uint32_t k = 0; k < kChoiceViews; ++k) {
    const float azimuth = glm::radians(30.0f + 90.0f * float(k)), elevation = glm::radians(20.0f);
    const glm::vec3 eye = centre + distance * glm::vec3(std::sin(azimuth) * std::cos(elevation), std::sin(elevation),
                                                        std::cos(azimuth) * std::cos(elevation));
    Camera c;
    c.eye = {eye.x, eye.y, eye.z};
    c.target = {centre.x, centre.y, centre.z};
    c.verticalFovDegrees = 40.0f;
    c.nearPlane = 0.01f * distance;
    c.farPlane = 10.0f * distance;
    cameras.push_back(c);
  }
  return cameras;
}

// The mean squared colour error of `image` against `exact` over its object pixels (compareImages'
// PSNR undone) times their count, to pool views; adds the count to `pixels`.
Result<double> pooledSquares(const Image& image, const ReferenceImage& exact, uint64_t* pixels) {
  auto e = compareImages(image, exact.color, exact.mask, {}, {});
  if (!e) return e.error();
  if (pixels) *pixels += e.value().pixels;
  return double(e.value().pixels) * std::pow(10.0, -e.value().psnr / 10.0);
}

// pooledSquares' sum over `pixels` pixels as a PSNR again.
double pooledPsnr(double sum, uint64_t pixels) {
  return 10.0 * std::log10(1.0 / std::max(sum / double(std::max<uint64_t>(1, pixels)), 1e-10));
}

// The CPU reference render of one of the image choices' views (exact, the plan's rule and bounce
// cap; callers change what they measure).
ReferenceOptions choiceView(const BakePlan& plan, const Camera& camera) {
  ReferenceOptions ro;
  ro.width = kChoiceImageWidth;
  ro.height = kChoiceImageHeight;
  ro.camera = camera;
  ro.pathRule = plan.settings.pathRule;
  ro.maxBounces = plan.settings.maxBounces;
  ro.samplesPerAxis = 2;
  ro.threads = plan.settings.threads;
  return ro;
}

// The image choice's figures of `fields` (drawn as the engine draws each by default: a Volume field
// traced per fragment, the others by their decoded sample texels), rendered against the same
// exact renders; the path rule and bounce cap are the first field's.
Result<ImageChoice> imagesAgainstExact(const Scene& scene, const BakePlan& plan, std::span<const Field* const> fields) {
  const Image& environment = choiceEnvironment();
  std::vector<double> sums(fields.size(), 0.0);
  ImageChoice out;
  for (const Camera& camera : choiceCameras(scene)) {
    ReferenceOptions ro = choiceView(plan, camera);
    ro.pathRule = fields.front()->settings.pathRule;
    ro.maxBounces = fields.front()->settings.maxBounces;
    auto exact = renderReference(*plan.tracer, scene, environment, ro);
    if (!exact) return exact.error();
    DistortionRenderOptions d;
    d.width = ro.width;
    d.height = ro.height;
    d.camera = camera;
    d.samplesPerAxis = ro.samplesPerAxis;
    d.threads = ro.threads;
    for (size_t k = 0; k < fields.size(); ++k) {
      const bool traced = fields[k]->encoding == Encoding::Volume;
      d.volume = traced ? fields[k] : nullptr;
      const reference::DistortionImage decoded = traced ? reference::DistortionImage{}
                                                        : reference::decompress(*fields[k], camera.eye);
      auto image = renderDistortion(fields[k]->mesh, decoded, environment, d);
      if (!image) return image.error();
      auto e = pooledSquares(image.value().color, exact.value(), k == 0 ? &out.pixels : nullptr);
      if (!e) return e.error();
      sums[k] += e.value();
    }
  }
  for (double sum : sums) out.psnr.push_back(pooledPsnr(sum, out.pixels));
  return out;
}

// BakeSettings::choosePathRule: each rule's exact render and the full tree at the image choice's
// views, pooled over their object pixels (the tree's); plan.settings.pathRule becomes the rule kept.
Result<void> choosePathRule(const Scene& scene, BakePlan& plan) {
  const Image& environment = choiceEnvironment();
  plan.begin("choosing the path rule: exact renders of both rules against the full tree");
  const PathRule rules[2] = {PathRule::FirstRefraction, PathRule::HighestEnergy};
  double sums[2] = {0.0, 0.0};
  uint64_t pixels = 0;
  for (const Camera& camera : choiceCameras(scene)) {
    ReferenceOptions ro = choiceView(plan, camera);
    ro.mode = ReferenceMode::FullTree;
    auto tree = renderReference(*plan.tracer, scene, environment, ro);
    if (!tree) return tree.error();
    ro.mode = ReferenceMode::Exact;
    for (int k = 0; k < 2; ++k) {
      ro.pathRule = rules[k];
      auto exact = renderReference(*plan.tracer, scene, environment, ro);
      if (!exact) return exact.error();
      auto e = pooledSquares(exact.value().color, tree.value(), k == 0 ? &pixels : nullptr);
      if (!e) return e.error();
      sums[k] += e.value();
    }
  }
  const double psnr[2] = {pooledPsnr(sums[0], pixels), pooledPsnr(sums[1], pixels)};
  const bool highest = psnr[1] >= psnr[0] + kHighestEnergyGainDb;
  plan.settings.pathRule = highest ? PathRule::HighestEnergy : PathRule::FirstRefraction;
  char figures[160];
  std::snprintf(figures, sizeof figures, "%.2f dB first-refraction, %.2f dB highest-energy; %.2f", psnr[0], psnr[1],
                kHighestEnergyGainDb);
  if (plan.note)
    plan.note(std::string("path rule: chose ") + (highest ? "highest-energy" : "first-refraction") +
              " (exact renders against the full tree, " + std::to_string(kChoiceViews) + " views, " +
              std::to_string(pixels) + " object pixels: " + figures +
              " dB closer keeps highest-energy)");
  return {};
}

// The Volume encoding's grid for `plan`'s scene at settings.volumeSize.
Result<FieldVolume> buildVolume(const Scene& scene, const BakePlan& plan, const BakeSettings& settings) {
  const uint32_t n = settings.volumeSize;
  plan.begin("building the " + std::to_string(n) + "x" + std::to_string(n) + "x" + std::to_string(n) +
             " distance volume");
  return buildDistanceVolume(scene, *plan.tracer, n, settings.threads);
}

// The Volume encoding traces no paths per sample: the layout's frames, the grid (buildVolume), and
// its check on the traced views (printed as a note, in the measures the default's choice reads;
// `measured`, when given, receives it).
Result<Field> bakeVolumeField(const BakePlan& plan, BakeSettings settings, uint32_t channels, FieldVolume volume,
                              const FrameChoiceViews& views, Clock::time_point start, ViewsError* measured = nullptr) {
  settings.encoding = Encoding::Volume;
  settings.order = settings.tableSize = settings.components = settings.clusters = 0;
  settings.shFit = ShFit::LeastSquares;
  settings.exitFrame = ExitFrame::Object;  // the decode's exits are in object space
  settings.directionSampling = DirectionSampling::Grid;
  settings.jumpDistance = false;
  const uint32_t n = settings.volumeSize;
  Field field = fieldLayout(plan, settings, shapeOf(settings, channels), {});
  field.channels = channels;
  field.volume = std::move(volume);
  field.volume.convex = meshIsConvex(field.mesh);
  field.media = plan.media;
  field.settings = settings;
  plan.begin("checking the volume's paths against traced ones");
  const ViewsError e = fieldViewsError(field, plan.atlas, views, settings.threads);
  if (measured) *measured = e;
  if (plan.note)
    plan.note("volume " + std::to_string(n) + "^3: to " + std::to_string(views.views.directions.size()) +
              " traced views, colours in the built-in environment " + std::to_string(e.colourPsnr) +
              " dB; mean angle, clipped at " + std::to_string(int(kFrameChoiceClipDegrees)) + " deg, " +
              std::to_string(e.clippedMean) + " deg");
  BakeStatistics& st = field.statistics;
  // The encoding has no grid it is fitted to: the fit figures are those of the views.
  st.heldOutRmsDegrees = st.fitRmsDegrees = static_cast<float>(e.rms);
  st.heldOutMaxDegrees = st.fitMaxDegrees = static_cast<float>(e.max);
  st.paths = views.views.directions.size();
  st.uniqueSamples = plan.atlas.samples.size();
  st.samples = sampleTexelCount(plan.atlas);
  st.bakeSeconds = st.fitSeconds = secondsSince(start);
  st.peakMemoryBytes = peakResidentBytes();
  if (auto valid = validateField(field); !valid)
    return makeError(ErrorCode::CorruptData, "bake produced an invalid field: " + valid.error().message);
  return field;
}

// BakeSettings::volumeDensify: a Volume field whose texels predict the paths between them worse
// than kVolumeDensifyBelowDb (volumeSpatialPsnr) is laid out again at kVolumeDensifyFactor times
// the sample budget; its samples store nothing, only their frames (48 bytes a texel) grow. The
// bunny's image gains 1.43 dB (21.97 -> 23.40), the cube's volume 2.59; the sphere's would gain
// nothing and keeps its samples (docs/encodings.md, "Volume").
Result<Field> densifiedVolume(const Scene& scene, const BakePlan& plan, Field field, Clock::time_point start) {
  const BakeSettings& s = plan.settings;
  if (!s.volumeDensify || s.samplesPerUnitArea > 0.0f) return field;
  plan.begin("checking the volume's texels between them");
  const double psnr = volumeSpatialPsnr(field, s.threads);
  const uint64_t budget = s.sampleBudget ? s.sampleBudget : kDefaultSampleBudget;
  const bool denser = psnr < kVolumeDensifyBelowDb;
  if (plan.note)
    plan.note("volume samples: paths between neighbouring texels seen " + std::to_string(psnr) + " dB (" +
              (denser ? "below " : "not below ") + std::to_string(int(kVolumeDensifyBelowDb)) + "): " +
              (denser ? "laid out again at " + std::to_string(budget * kVolumeDensifyFactor) + " samples"
                      : "kept at " + std::to_string(budget) + " samples"));
  if (!denser) return field;
  BakeOptions options;
  options.settings = bakeSettingsOf(field.settings);
  options.settings.sampleBudget = budget * kVolumeDensifyFactor;
  options.settings.volumeDensify = false;
  options.note = plan.note;
  options.stage = plan.stage;
  auto dense = planBake(scene, options, false);
  if (!dense) return dense.error();
  // The grid depends on the scene and its size only: the denser layout keeps it.
  auto out = bakeVolumeField(dense.value(), dense->settings, field.channels, std::move(field.volume),
                             traceFrameChoiceViews(dense.value()), start);
  if (out) out->settings.tryVolume = field.settings.tryVolume;  // the dense plan's settings are a Volume bake's
  return out;
}

// The grid sizes keepVolumeWhereCloser draws: the one asked for, or kDefaultVolumeSize and twice
// that (kept where it fits the paper's budget over the field's samples: finerFits).
std::vector<uint32_t> volumeSizesToTry(const BakePlan& plan) {
  const uint32_t asked = plan.settings.volumeSize, finer = 2 * kDefaultVolumeSize;
  if (asked) return {asked};
  if (finer > kMaxVolumeSize) return {kDefaultVolumeSize};
  return {kDefaultVolumeSize, finer};
}

// Whether the finer default grid fits the budget over the field's samples; `skipped` says why not.
bool finerFits(const BakePlan& plan, const FieldVolume& grid, std::string* skipped) {
  const uint64_t samples = sampleTexelCount(plan.atlas), bytes = volumeGridBytes(grid);
  if (volumeFitsDefaultBudget(bytes, samples)) return true;
  *skipped = " (" + std::to_string(grid.size) + "^3 left out: its " + std::to_string(bytes) + " bytes are over " +
             std::to_string(int(kDefaultBytesPerSampleBudget)) + " bytes a sample of " + std::to_string(samples) + ")";
  return false;
}

// keepVolumeWhereCloser's line: what it kept, every image figure, and the traced views' figures.
std::string volumeChoiceNote(const std::string& kept, const Field& baked, const ImageChoice& images,
                             const std::vector<uint32_t>& sizes, const std::string& skipped, const ViewsError& a,
                             const ViewsError& b) {
  const std::vector<double>& psnr = images.psnr;
  char gain[32];
  std::snprintf(gain, sizeof gain, "%.2f", kFinerVolumeGainDb);
  std::string figures;
  for (size_t k = 0; k < sizes.size(); ++k)
    figures += (k ? ", " : "") + std::to_string(psnr[k + 1]) + " dB with volume " + std::to_string(sizes[k]) + "^3";
  return "encoding: chose " + kept + " (their images against exact renders, " + std::to_string(kChoiceViews) +
         " views, " + std::to_string(images.pixels) + " object pixels: " + std::to_string(psnr[0]) + " dB with " +
         toString(baked.encoding) + " by its texels, " + figures + " traced per fragment" +
         (sizes.size() == 2 ? " (the finer where it gains " + std::string(gain) + " dB)" : skipped) +
         "; the traced views at the samples: " + std::to_string(a.colourPsnr) + " and " +
         std::to_string(b.colourPsnr) + " dB, mean angle clipped at " + std::to_string(int(kFrameChoiceClipDegrees)) +
         " deg " + std::to_string(a.clippedMean) + " and " + std::to_string(b.clippedMean) + " deg)";
}

// BakeSettings::tryVolume: the scene's Volume field beside the baked one; the one whose images come
// closer to exact renders (imagesAgainstExact: the baked field by its texels, the volume traced per
// fragment, as the engine draws each by default) is kept, and the note says which, with the traced
// views' figures at the samples (fieldViewsError) beside them. With no volumeSize asked for, the
// volume's grid is kDefaultVolumeSize per side, or twice that where its grid fits the paper's
// budget over the field's samples (finerFits) and its images gain at least
// kFinerVolumeGainDb by it (bake.h).
Result<Field> keepVolumeWhereCloser(const Scene& scene, const BakePlan& plan, Field baked, Clock::time_point start) {
  const uint32_t channels = baked.decodedChannels();  // without a jump distance channel
  std::string skipped;
  std::vector<uint32_t> sizes = volumeSizesToTry(plan);
  const FrameChoiceViews views = traceFrameChoiceViews(plan);
  std::vector<Field> volumes;
  std::vector<ViewsError> seen;
  for (size_t k = 0; k < sizes.size(); ++k) {
    BakeSettings settings = plan.settings;
    settings.volumeSize = sizes[k];
    auto grid = buildVolume(scene, plan, settings);
    if (!grid) return grid.error();
    if (k == 1 && !finerFits(plan, grid.value(), &skipped)) {
      sizes.pop_back();
      break;
    }
    ViewsError e;
    auto volume = bakeVolumeField(plan, settings, channels, std::move(grid.value()), views, start, &e);
    if (!volume) return volume.error();
    volumes.push_back(std::move(volume.value()));
    seen.push_back(e);
  }
  const ViewsError a = fieldViewsError(baked, plan.atlas, views, plan.settings.threads);
  plan.begin("comparing the fields' images with exact renders");
  std::vector<const Field*> drawn{&baked};
  for (const Field& v : volumes) drawn.push_back(&v);
  auto images = imagesAgainstExact(scene, plan, drawn);
  if (!images) return images.error();
  const std::vector<double>& psnr = images.value().psnr;
  const size_t best = volumes.size() == 2 && psnr[2] >= psnr[1] + kFinerVolumeGainDb ? 1 : 0;
  const bool keep = psnr[best + 1] > psnr[0];
  const std::string kept = keep ? "volume " + std::to_string(sizes[best]) + "^3" : toString(baked.encoding);
  if (plan.note) plan.note(volumeChoiceNote(kept, baked, images.value(), sizes, skipped, a, seen[best]));
  if (!keep) return baked;
  return densifiedVolume(scene, plan, std::move(volumes[best]), start);
}

// finishBake, then the volume tried where the settings ask for it and the scene allows it.
Result<Field> finishWithVolumeChoice(const Scene& scene, const BakePlan& plan, std::vector<BakePart> parts,
                                     Clock::time_point start) {
  auto field = finishBake(plan, std::move(parts));
  if (!field || !plan.settings.tryVolume || !volumeSceneProblem(scene).empty()) return field;
  return keepVolumeWhereCloser(scene, plan, std::move(field.value()), start);
}

}  // namespace

BakeSettings settingsForScene(const Scene& scene, BakeSettings s, std::string* why) {
  if (!s.tryVolume || s.chooseByImages) return s;
  s.tryVolume = s.moreClusters = s.choosePathRule = s.volumeDensify = false;
  const std::string problem = volumeSceneProblem(scene);
  const bool budgetGiven = s.sampleBudget > 0 || s.samplesPerUnitArea > 0.0f;
  if (problem.empty()) {
    s.encoding = Encoding::Volume;
    if (!budgetGiven) s.sampleBudget = kDefaultSampleBudget;
    if (s.volumeSize == 0) s.volumeSize = kDefaultVolumeSize;
    if (why) *why = "one closed medium in air: its distance grid, traced per eye";
    return s;
  }
  s.encoding = Encoding::Pca;
  if (!budgetGiven) s.sampleBudget = kDefaultPerSampleBudget;
  s.volumeSize = 0;
  s.directionSampling = DirectionSampling::Nodes;
  s.tableSize = kDefaultPerSampleTableSize;
  s.components = s.clusters = kDefaultPcaComponents;
  if (s.exitFrame == ExitFrame::Auto) s.exitFrame = ExitFrame::Sample;
  if (why) *why = "not a volume (" + problem + "): paths traced per sample";
  return s;
}

namespace {

// The options with the scene's default settings decided (settingsForScene), said in a note.
BakeOptions decidedOptions(const Scene& scene, const BakeOptions& options) {
  BakeOptions decided = options;
  if (!options.settings.tryVolume || options.settings.chooseByImages) return decided;
  std::string why;
  decided.settings = settingsForScene(scene, options.settings, &why);
  if (options.note) options.note("encoding: " + candidateLabel(decided.settings) + ", " + why);
  return decided;
}

}  // namespace

Result<Field> bakeField(const Scene& scene, const BakeOptions& asked) {
  const BakeOptions options = decidedOptions(scene, asked);

  const auto start = Clock::now();
  auto plan = planBake(scene, options, true);
  if (!plan) return plan.error();
  if (plan->settings.encoding == Encoding::Volume) {
    auto grid = buildVolume(scene, plan.value(), plan->settings);
    if (!grid) return grid.error();
    auto volume = bakeVolumeField(plan.value(), plan->settings, plan->channels, std::move(grid.value()),
                                  traceFrameChoiceViews(plan.value()), start);
    if (!volume) return volume.error();
    return densifiedVolume(scene, plan.value(), std::move(volume.value()), start);
  }
  auto part = tracePart(plan.value(), options, Shard{}, start);
  if (!part) return part.error();
  std::vector<BakePart> parts;
  parts.push_back(std::move(part.value()));
  return finishWithVolumeChoice(scene, plan.value(), std::move(parts), start);
}

uint64_t shardSampleCount(uint64_t sampleCount, Shard shard) {
  return shard.index < sampleCount ? (sampleCount - shard.index + shard.count - 1) / shard.count : 0;
}

Result<BakePart> bakePart(const Scene& scene, const BakeOptions& asked, Shard shard) {
  const auto start = Clock::now();
  const BakeOptions options = decidedOptions(scene, asked);
  if (shard.count < 1 || shard.count > kMaxShards || shard.index >= shard.count)
    return makeError(ErrorCode::InvalidArgument, "shard " + std::to_string(shard.index) + "/" +
                                                     std::to_string(shard.count) + " is out of range");
  if (options.settings.encoding == Encoding::Volume)
    return makeError(ErrorCode::InvalidArgument,
                     "the volume encoding traces no paths per sample, so it has no shards: bake it in one process");
  auto plan = planBake(scene, options, true);
  if (!plan) return plan.error();
  return tracePart(plan.value(), options, shard, start);
}

Result<Field> mergeParts(const Scene& scene, std::vector<BakePart> parts,
                         const std::function<void(const std::string&)>& stage,
                         const std::function<void(const std::string&)>& note) {
  if (auto ok = checkParts(parts); !ok) return ok.error();
  BakeOptions options;
  options.settings = parts.front().settings;
  options.stage = stage;
  options.note = note;
  options.heldOutDirections = parts.front().heldOutDirections;
  auto plan = planBake(scene, options, false);
  if (!plan) return plan.error();
  auto encoder = SampleEncoder::create(plan->grid, plan->settings, plan->channels);
  if (!encoder) return encoder.error();
  const BakePart& first = parts.front();
  if (plan->sceneHash != first.sceneHash || plan->atlas.samples.size() != first.sampleCount ||
      plan->channels != first.channels || plan->grid.directions.size() != first.directions ||
      encoder->stride() != first.stride)
    return makeError(ErrorCode::InvalidArgument,
                     first.name + ": baked from another scene than " + first.settings.source +
                         " is now (its layout or media differ: the scene changed, or the part came from a build "
                         "whose floating point differs, e.g. other compiler flags; trace and merge with one build)");
  return finishWithVolumeChoice(scene, plan.value(), std::move(parts), Clock::now());
}

}  // namespace shrefract::bake
