// The Pca basis: learned from every sample's table, in the exit frame chosen on traced views
// (ExitFrame::Auto), with the clusters' means kept where they come closer (bake_driver.h:
// learnBasisInItsFrame).
#include "driver/bake_driver.h"

#include <algorithm>
#include <limits>
#include <optional>
#include <string>

namespace shrefract::bake::detail {

namespace {

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

size_t frameChoiceStep(size_t n) { return std::max<size_t>(1, n / kFrameChoiceSamples); }

}  // namespace

FrameChoiceViews traceFrameChoiceViews(const BakePlan& plan) {
  FrameChoiceViews v;
  const size_t n = plan.atlas.samples.size(), step = frameChoiceStep(n);
  for (size_t s = 0; s < n; s += step) v.samples.push_back(s);
  v.views = traceCosineViews(plan.atlas, *plan.tracer, traceSettingsOf(plan.settings), v.samples, kFrameChoiceViews,
                             0x4652414d45ull, false, plan.settings.threads);
  return v;
}

namespace {

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

}  // namespace

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

}  // namespace shrefract::bake::detail
