// --max-bytes-per-sample: the encoding with the lowest error within a byte budget, measured on a
// probe of traced samples (bake_driver.h: selectForBudget, bakeChoiceAtItsShape).
#include "driver/bake_driver.h"

#include "parallel.h"
#include "splitmix.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace shrefract::bake::detail {

namespace {

constexpr uint32_t kBudgetPcaTableSize = 16;  // N of the basis tables when the budget picks Pca

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

}  // namespace

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

}  // namespace shrefract::bake::detail
