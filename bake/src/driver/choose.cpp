// The choices made by images: the path rule, and the volume beside the baked field (its grid, its
// field, densified where its texels predict the paths between them poorly).
#include "driver/bake_driver.h"

#include "parallel.h"
#include "splitmix.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <span>
#include <string>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

namespace shrefract::bake::detail {

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

namespace {

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
    e.colourPsnr = psnrFromMeanSquaredError(e.colourPsnr / count);
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
  return psnrFromMeanSquaredError(mean);
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
  return psnrFromMeanSquaredError(sum / double(std::max<uint64_t>(1, pixels)));
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

}  // namespace

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
                              const FrameChoiceViews& views, Clock::time_point start, ViewsError* measured) {
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

namespace {

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

}  // namespace

// finishBake, then the volume tried where the settings ask for it and the scene allows it.
Result<Field> finishWithVolumeChoice(const Scene& scene, const BakePlan& plan, std::vector<BakePart> parts,
                                     Clock::time_point start) {
  auto field = finishBake(plan, std::move(parts));
  if (!field || !plan.settings.tryVolume || !volumeSceneProblem(scene).empty()) return field;
  return keepVolumeWhereCloser(scene, plan, std::move(field.value()), start);
}

}  // namespace shrefract::bake::detail
