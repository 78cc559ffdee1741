// Internal to the bake driver (bake.cpp and driver/*.cpp): what its stages share. Each stage's
// file keeps its own helpers; a function's comment is at its definition.
#pragma once

#include <shrefract/bake/bake.h>
#include <shrefract/bake/distance_volume.h>
#include <shrefract/bake/fit.h>
#include <shrefract/assets/image.h>
#include <shrefract/trace/image_metrics.h>
#include <shrefract/bake/jump_distance.h>
#include <shrefract/bake/layout.h>
#include <shrefract/trace/reference_render.h>
#include <shrefract/bake/sample_frame.h>
#include <shrefract/bake/shard.h>
#include <shrefract/bake/table_fit.h>
#include <shrefract/trace/tracer.h>
#include <shrefract/gpu_layout.h>
#include <shrefract/sh.h>
#include <shrefract/cpu_reference.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace shrefract::bake::detail {

using Clock = std::chrono::steady_clock;

// ---- common.cpp -------------------------------------------------------------------------------

double secondsSince(Clock::time_point t);
uint64_t peakResidentBytes();
bool storesJumpDistance(const BakeSettings& s);
bool tracesInSampleFrame(const BakeSettings& s);
EncodingShape shapeOf(const BakeSettings& s, uint32_t channels);
size_t strideOf(const EncodingShape& shape);
size_t tableValues(const EncodingShape& shape);
std::array<float, 12> sampleRows(const SurfacePoint& p);
void decodeFloat(const EncodingShape& shape, const std::vector<float>& basis, const float* coeffs,
                 const SurfacePoint& point, glm::vec3 w, float* out);
double angleDegrees(glm::vec3 a, glm::vec3 b);
TraceSettings traceSettingsOf(const BakeSettings& s);
glm::vec3 storedExit(bool sampleFrame, const LocalFrame& frame, glm::vec3 exit);
Result<HemisphereFit> shFitOf(const DirectionGrid& grid, uint32_t order, const BakeSettings& s);
std::string candidateLabel(const BakeSettings& s);

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
                             uint32_t threads);

// Fits one sample's traced grid values into the floats the field stores for it (Pca: into its
// table; the weights come once the whole field has been traced).
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

// ---- plan.cpp, budget.cpp -----------------------------------------------------------------------

Result<BakePlan> planBake(const Scene& scene, const BakeOptions& options, bool choose);
Result<BakeSettings> selectForBudget(const SampleAtlas& atlas, const Tracer& tracer, const BakeSettings& s,
                                     uint32_t channels, uint32_t threads,
                                     const std::function<void(const std::string&)>& note);
void bakeChoiceAtItsShape(BakeSettings& chosen, const BakeSettings& requested,
                          const std::function<void(const std::string&)>& note);

// ---- trace.cpp ----------------------------------------------------------------------------------

Result<BakePart> tracePart(const BakePlan& plan, const BakeOptions& options, Shard shard, Clock::time_point start);

// The parts' per-sample results in sample order, as one process would have them; each part's
// arrays are freed once copied.
struct Gathered {
  std::vector<float> coeffs;  // samples x stride
  TracedChecks checks;
};
Gathered gatherParts(std::vector<BakePart>& parts, size_t stride, uint32_t nd, uint32_t held);

// ---- basis.cpp ----------------------------------------------------------------------------------

// A Pca basis of a field's tables and their weights.
struct LearnedBasis {
  std::vector<float> basis, weights;
};

// Traced views the exit frame and the basis (keepClusters) are chosen on: kFrameChoiceViews
// cosine-weighted directions at every (n / kFrameChoiceSamples)-th sample (all of a field under 2
// kFrameChoiceSamples samples, otherwise between kFrameChoiceSamples and twice as many), traced for
// the choice alone (so it does not depend on --held-out), with a fixed sequence per sample.
inline constexpr size_t kFrameChoiceSamples = 2048;
inline constexpr uint32_t kFrameChoiceViews = 8;
struct FrameChoiceViews {
  std::vector<size_t> samples;
  TracedViews views;  // exits in object space
};
// The clip of meanClippedDegrees' angles (basis.cpp says why), also fieldViewsError's (choose.cpp).
inline constexpr double kFrameChoiceClipDegrees = 5.0;

FrameChoiceViews traceFrameChoiceViews(const BakePlan& plan);
Result<void> learnBasisInItsFrame(const BakePlan& plan, EncodingShape& shape, std::vector<float>& coeffs,
                                  std::vector<float>& basis);

// ---- encode.cpp ---------------------------------------------------------------------------------

std::vector<uint64_t> firstTexels(const SampleAtlas& atlas);
uint64_t sampleTexelCount(const SampleAtlas& atlas);
Field fieldLayout(const BakePlan& plan, const BakeSettings& settings, const EncodingShape& shape,
                  const std::vector<float>& basis);
Result<Field> finishBake(const BakePlan& plan, std::vector<BakePart> parts);

// ---- choose.cpp ---------------------------------------------------------------------------------

struct ViewsError;
Result<void> choosePathRule(const Scene& scene, BakePlan& plan);
Result<FieldVolume> buildVolume(const Scene& scene, const BakePlan& plan, const BakeSettings& settings);
Result<Field> bakeVolumeField(const BakePlan& plan, BakeSettings settings, uint32_t channels, FieldVolume volume,
                              const FrameChoiceViews& views, Clock::time_point start, ViewsError* measured = nullptr);
Result<Field> densifiedVolume(const Scene& scene, const BakePlan& plan, Field field, Clock::time_point start);
Result<Field> finishWithVolumeChoice(const Scene& scene, const BakePlan& plan, std::vector<BakePart> parts,
                                     Clock::time_point start);

}  // namespace shrefract::bake::detail
