// The bake driver's shared helpers: shapes and strides, sample frames and decodes, angles,
// traced views and fits that every stage reads (bake_driver.h).
#include "driver/bake_driver.h"

#include "parallel.h"
#include "splitmix.h"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>

namespace shrefract::bake::detail {

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

// The SH fit the settings ask for, of `order`: one rule for the --max-error choice, the budget's
// candidates and the field.
Result<HemisphereFit> shFitOf(const DirectionGrid& grid, uint32_t order, const BakeSettings& s) {
  const FitMethod method =
      s.shFit == ShFit::Robust ? FitMethod::RobustLeastSquares : FitMethod::RegularizedLeastSquares;
  return HemisphereFit::create(grid, static_cast<int>(order), static_cast<double>(s.regularization), method);
}

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

}  // namespace shrefract::bake::detail
