#include <shrefract/bake/bake.h>
#include <shrefract/bake/shard.h>

#include "driver/bake_driver.h"

#include <string>
#include <vector>

namespace shrefract::bake {

// The stages (driver/): plan.cpp, budget.cpp, trace.cpp, basis.cpp, encode.cpp, choose.cpp.
using namespace detail;

namespace {

// The scene's surfaces as one mesh, for meshIsConvex.
bool sceneIsConvex(const Scene& scene) {
  FieldMesh mesh;
  for (const Surface& surface : scene.surfaces) {
    const auto base = uint32_t(mesh.positions.size() / 3);
    for (size_t v = 0; v < surface.positions.size(); ++v)
      for (int c = 0; c < 3; ++c) {
        mesh.positions.push_back(surface.positions[v][c]);
        mesh.normals.push_back(surface.normals[v][c]);
      }
    for (uint32_t i : surface.indices) mesh.indices.push_back(base + i);
  }
  return meshIsConvex(mesh);
}

}  // namespace

BakeSettings settingsForScene(const Scene& scene, BakeSettings s, std::string* why) {
  if (!s.tryVolume || s.chooseByImages) return s;
  s.tryVolume = s.moreClusters = s.choosePathRule = s.volumeDensify = false;
  const std::string problem = volumeSceneProblem(scene);
  const bool budgetGiven = s.sampleBudget > 0 || s.samplesPerUnitArea > 0.0f;
  if (problem.empty()) {
    s.encoding = Encoding::Volume;
    // A convex grid traces one segment a path, so more texels stay cheap at the frame: it is
    // densified where its texels miss the paths between them. A concave one traces several a path
    // and keeps fewer texels (bake.h kDefaultConcaveVolumeBudget).
    const bool convex = sceneIsConvex(scene);
    if (!budgetGiven) s.sampleBudget = convex ? kDefaultSampleBudget : kDefaultConcaveVolumeBudget;
    s.volumeDensify = !budgetGiven && convex;
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
