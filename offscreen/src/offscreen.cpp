#include "offscreen/offscreen.h"

#include <shrefract/assets/image.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <string>

#include <glm/glm.hpp>

namespace shrefract::offscreen {

Session::~Session() {
  // The engine's objects must go before the device they borrow.
  if (harness && context) {
    context->releaseDeferred();
  }
  context.reset();
  harness.reset();
}

uint32_t endSession(std::unique_ptr<Session> session) {
  if (!session || !session->harness) return 0;
  const auto log = session->harness->messageLog();
  session.reset();
  return log->count();
}

Result<std::unique_ptr<Session>> createSession(const harness::HarnessOptions& options,
                                               harness::HarnessFailure* failure) {
  auto h = harness::Harness::create(options, failure);
  if (!h) return h.error();
  auto session = std::make_unique<Session>();
  session->harness = std::move(h).value();
  auto context = harness::createContext(*session->harness);
  if (!context) return context.error();
  session->context = std::move(context).value();
  return session;
}

Result<bake::Image> loadEnvironmentImage(const std::string& spec, uint32_t builtinWidth) {
  if (spec.empty() || spec == "builtin") return bake::proceduralEnvironment(builtinWidth);
  return bake::loadEnvironment(spec);
}

Result<std::unique_ptr<Environment>> uploadEnvironment(Session& session, const bake::Image& image, bool cube,
                                                       uint32_t faceSize) {
  std::unique_ptr<Environment> env;
  auto uploaded = session.context->uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
    LatLongEnvironmentDesc desc{image.width, image.height, image.rgba.data()};
    auto created = cube ? Environment::createCubeFromLatLong(*session.context, desc, faceSize, cmd)
                        : Environment::createLatLong(*session.context, desc, cmd);
    if (!created) return created.error();
    env = std::move(created).value();
    return {};
  });
  if (!uploaded) return uploaded.error();
  return env;
}

Result<std::vector<std::unique_ptr<Object>>> uploadScene(Session& session, const bake::Scene& scene) {
  std::vector<std::unique_ptr<Object>> objects;
  auto uploaded = session.context->uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
    for (const bake::Surface& s : scene.surfaces) {
      MeshDesc mesh;
      mesh.positions = &s.positions[0].x;
      mesh.normals = &s.normals[0].x;
      mesh.fieldUvs = s.uvs.empty() ? nullptr : &s.uvs[0].x;
      mesh.vertexCount = static_cast<uint32_t>(s.positions.size());
      mesh.indices = s.indices.data();
      mesh.indexCount = static_cast<uint32_t>(s.indices.size());
      auto object = Object::create(*session.context, mesh, cmd);
      if (!object) return object.error();
      const float inner = scene.media[s.innerMedium].ior;
      const float outer = scene.media[s.outerMedium].ior;
      object.value()->shading.ior = inner / outer;
      const glm::vec3 c = scene.media[s.innerMedium].color;
      object.value()->shading.tint = {c.x, c.y, c.z};
      objects.push_back(std::move(object).value());
    }
    return {};
  });
  if (!uploaded) return uploaded.error();
  return objects;
}

Result<std::unique_ptr<Object>> uploadField(Session& session, const Field& field) {
  return harness::uploadField(*session.context, field);
}

Camera defaultCamera(const bake::Scene& scene, float verticalFovDegrees) {
  const bake::Bounds b = bake::bounds(scene);
  return frameBounds({b.min.x, b.min.y, b.min.z}, {b.max.x, b.max.y, b.max.z}, verticalFovDegrees);
}

void meshBounds(const FieldMesh& mesh, std::array<float, 3>& min, std::array<float, 3>& max) {
  min = {0.0f, 0.0f, 0.0f};
  max = {0.0f, 0.0f, 0.0f};
  for (size_t v = 0; v + 2 < mesh.positions.size(); v += 3)
    for (size_t k = 0; k < 3; ++k) {
      const float p = mesh.positions[v + k];
      min[k] = v == 0 ? p : std::min(min[k], p);
      max[k] = v == 0 ? p : std::max(max[k], p);
    }
}

Camera frameBounds(const std::array<float, 3>& boundsMin, const std::array<float, 3>& boundsMax,
                   float verticalFovDegrees) {
  const glm::vec3 bmin(boundsMin[0], boundsMin[1], boundsMin[2]), bmax(boundsMax[0], boundsMax[1], boundsMax[2]);
  const glm::vec3 center = 0.5f * (bmin + bmax);
  const float radius = std::max(0.5f * glm::length(bmax - bmin), 1e-6f);
  const float distance = radius / std::sin(glm::radians(0.5f * verticalFovDegrees)) * 1.15f;
  const glm::vec3 dir = glm::normalize(glm::vec3(0.25f, 0.35f, 1.0f));
  const glm::vec3 eye = center + dir * distance;
  Camera camera;
  camera.eye = {eye.x, eye.y, eye.z};
  camera.target = {center.x, center.y, center.z};
  camera.verticalFovDegrees = verticalFovDegrees;
  camera.nearPlane = distance * 1e-3f;
  camera.farPlane = distance * 10.0f;
  return camera;
}

namespace {

// Timestamp queries of one frame: decompression start/end, raster start/end.
constexpr uint32_t kTimestampCount = 4;

constexpr VkFormat kColorFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

Result<void> checkFrameSize(const harness::Harness& h, const FrameSettings& settings) {
  const uint32_t samples = settings.samplesPerAxis;
  if (samples < 1 || samples > bake::kMaxSamplesPerAxis)
    return makeError(ErrorCode::InvalidArgument, "renderFrame: samples per axis " + std::to_string(samples) +
                                                     " is outside 1.." + std::to_string(bake::kMaxSamplesPerAxis));
  const uint64_t maxSide = h.properties().limits.maxImageDimension2D;
  if (uint64_t(settings.width) * samples > maxSide || uint64_t(settings.height) * samples > maxSide)
    return makeError(ErrorCode::InvalidArgument,
                     "renderFrame: " + std::to_string(settings.width) + "x" + std::to_string(settings.height) + " at " +
                         std::to_string(samples) + "x" + std::to_string(samples) +
                         " samples per pixel needs an image beyond the device's largest (" + std::to_string(maxSide) +
                         " per side)");
  return {};
}

Result<std::unique_ptr<Renderer>> createFrameRenderer(Session& session, const FrameSettings& settings) {
  RendererCreateInfo rci;
  rci.colorFormat = kColorFormat;
  rci.depthFormat = kDepthFormat;
  rci.exposure = settings.exposure;
  rci.frustumCulling = settings.skipWork;
  rci.environmentTapsPerAxis = settings.environmentTapsPerAxis;
  rci.silhouetteCoverage = settings.silhouetteCoverage;
  rci.refineVolumePaths = settings.refineVolumePaths;
  rci.sampleCount = settings.msaaSamples;
  return Renderer::create(*session.context, rci);
}

// Null when the frame decompresses nothing: no field object, or a mode that does not read fields.
Result<std::unique_ptr<Decompressor>> createFrameDecompressor(Session& session, const std::vector<Object*>& objects,
                                                              const FrameSettings& settings) {
  bool anyField = false;
  for (const Object* o : objects) anyField = anyField || (o && o->hasField());
  if (!(settings.mode == ShadingMode::Field || settings.mode == ShadingMode::FieldExitDirection) || !anyField)
    return std::unique_ptr<Decompressor>{};
  auto created = Decompressor::create(*session.context);
  if (!created) return created.error();
  std::unique_ptr<Decompressor> decompressor = std::move(created).value();
  decompressor->setSkipUnchanged(settings.skipWork);
  // Pipelines now, so that the first frame's timings measure the work and not the compiler.
  for (const Object* o : objects)
    if (o && o->hasField())
      if (auto prepared = decompressor->prepare(*o); !prepared) return prepared.error();
  return decompressor;
}

// Null without timings or where the queue has no timestamps.
Result<VkQueryPool> createTimestampQueries(const harness::Harness& h, const FrameTimings* timings) {
  if (!timings || !h.hasTimestamps()) return VkQueryPool{VK_NULL_HANDLE};
  VkQueryPool queries = VK_NULL_HANDLE;
  VkQueryPoolCreateInfo qpci{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  qpci.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qpci.queryCount = kTimestampCount;
  if (VkResult r = vkCreateQueryPool(h.device(), &qpci, nullptr, &queries); r != VK_SUCCESS)
    return makeError(ErrorCode::Vulkan, "vkCreateQueryPool failed", r);
  return queries;
}

// resolve has no image unless the frame is multisampled.
struct FrameTargets {
  harness::Harness::Image color, depth, resolve;
};

Result<FrameTargets> createFrameTargets(harness::Harness& h, uint32_t width, uint32_t height,
                                        VkSampleCountFlagBits samples) {
  const bool msaa = samples != VK_SAMPLE_COUNT_1_BIT;
  const VkImageUsageFlags colorUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  auto color = h.createImage(width, height, kColorFormat, colorUsage, VK_IMAGE_ASPECT_COLOR_BIT, samples);
  auto depth = h.createImage(width, height, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                             VK_IMAGE_ASPECT_DEPTH_BIT, samples);
  // Multisampled: the colour is resolved into a single-sample image, which is read back.
  auto resolve = msaa ? h.createImage(width, height, kColorFormat, colorUsage, VK_IMAGE_ASPECT_COLOR_BIT)
                      : Result<harness::Harness::Image>(harness::Harness::Image{});
  if (!color || !depth || !resolve) {
    const Error error = !color ? color.error() : !depth ? depth.error() : resolve.error();
    for (auto* image : {&color, &depth, &resolve})
      if (*image && image->value().image) h.destroyImage(image->value());
    return error;
  }
  return FrameTargets{color.value(), depth.value(), resolve.value()};
}

void destroyFrameTargets(harness::Harness& h, FrameTargets& targets) {
  h.destroyImage(targets.color);
  h.destroyImage(targets.depth);
  if (targets.resolve.image) h.destroyImage(targets.resolve);
}

// What every frame of renderFrame records and where its timings go.
struct FramePass {
  Session& session;
  Renderer& renderer;
  Decompressor* decompressor;  // null: nothing to decompress
  const Environment& environment;
  const std::vector<Object*>& objects;
  const FrameSettings& settings;
  VkQueryPool queries;  // null: no timestamps
  FrameTargets& targets;
  VkExtent2D extent;
  FrameTimings* timings;
};

// Returns the decompressor's recording result (the rest is recorded whatever it is).
Result<void> recordFrame(VkCommandBuffer cmd, const FramePass& pass) {
  const VkQueryPool queries = pass.queries;
  const FrameSettings& settings = pass.settings;
  const bool msaa = settings.msaaSamples != VK_SAMPLE_COUNT_1_BIT;
  Result<void> recorded{};
  if (queries) {
    vkCmdResetQueryPool(cmd, queries, 0, kTimestampCount);
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT, queries, 0);
  }
  if (pass.decompressor)
    recorded = settings.skipWork ? pass.decompressor->record(cmd, settings.camera, pass.extent, pass.objects)
                                 : pass.decompressor->record(cmd, settings.camera.eye, pass.objects);
  if (queries) {
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries, 1);
  }

  // Timestamp 2 before the attachments' barriers: the raster time includes them (cheap).
  if (queries) vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries, 2);
  harness::beginRendering(cmd, pass.targets.color, pass.targets.depth, msaa ? &pass.targets.resolve : nullptr);
  pass.renderer.recordBackground(cmd, pass.environment, settings.camera, pass.extent);
  pass.renderer.recordObjects(cmd, pass.environment, settings.camera, pass.extent, pass.objects, settings.mode);
  vkCmdEndRendering(cmd);
  if (queries) vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, queries, 3);
  if (pass.timings) {
    pass.timings->decompress = pass.decompressor ? pass.decompressor->lastStats() : DecompressStats{};
    pass.timings->draw = pass.renderer.lastDrawStats();
  }
  return recorded;
}

void readTimestamps(const harness::Harness& h, VkQueryPool queries, bool decompressed, FrameTimings& timings) {
  std::array<uint64_t, kTimestampCount> ticks{};
  const VkResult r = vkGetQueryPoolResults(h.device(), queries, 0, kTimestampCount, sizeof(ticks), ticks.data(),
                                           sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT);
  if (r == VK_SUCCESS) {
    const double period = double(h.properties().limits.timestampPeriod) * 1e-6;  // ns -> ms
    timings.gpuTimestamps = true;
    timings.decompressionMs = decompressed ? double(ticks[1] - ticks[0]) * period : 0.0;
    timings.rasterMs = double(ticks[3] - ticks[2]) * period;
    timings.gpuDecompressionMs.push_back(timings.decompressionMs);
    timings.gpuRasterMs.push_back(timings.rasterMs);
  }
}

// settings.frames frames (at least one), up to the first failure: a failed submission's error
// before a failed recording's.
Result<void> renderFrames(const FramePass& pass) {
  harness::Harness& h = *pass.session.harness;
  Result<void> submitted{};
  Result<void> recorded{};
  const uint32_t frames = std::max(1u, pass.settings.frames);
  for (uint32_t frame = 0; frame < frames && submitted.ok() && recorded.ok(); ++frame) {
    pass.session.context->beginFrame();
    const auto start = std::chrono::steady_clock::now();
    submitted = h.submitAndWait([&](VkCommandBuffer cmd) { recorded = recordFrame(cmd, pass); });
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (pass.timings) pass.timings->wallMs.push_back(ms);
    // The frame has completed (submitAndWait waited on its fence): its timestamps are ready.
    if (submitted.ok() && recorded.ok() && pass.queries)
      readTimestamps(h, pass.queries, pass.decompressor != nullptr, *pass.timings);
  }
  return !submitted.ok() ? submitted : recorded;
}

}  // namespace

Result<bake::Image> renderFrame(Session& session, const Environment& environment, const std::vector<Object*>& objects,
                                const FrameSettings& settings, FrameTimings* timings) {
  harness::Harness& h = *session.harness;
  if (auto checked = checkFrameSize(h, settings); !checked) return checked.error();
  const uint32_t samples = settings.samplesPerAxis;
  const uint32_t width = settings.width * samples, height = settings.height * samples;
  auto renderer = createFrameRenderer(session, settings);
  if (!renderer) return renderer.error();
  auto decompressor = createFrameDecompressor(session, objects, settings);
  if (!decompressor) return decompressor.error();
  auto queries = createTimestampQueries(h, timings);
  if (!queries) return queries.error();

  const bool msaa = settings.msaaSamples != VK_SAMPLE_COUNT_1_BIT;
  auto targets = createFrameTargets(h, width, height, settings.msaaSamples);
  if (!targets) {
    if (queries.value()) vkDestroyQueryPool(h.device(), queries.value(), nullptr);
    return targets.error();
  }
  const FramePass pass{session,         *renderer.value(), decompressor.value().get(), environment,
                       objects,         settings,          queries.value(),             targets.value(),
                       {width, height}, timings};
  const Result<void> rendered = renderFrames(pass);
  if (queries.value()) vkDestroyQueryPool(h.device(), queries.value(), nullptr);
  Result<std::vector<float>> pixels =
      !rendered.ok() ? Result<std::vector<float>>(rendered.error())
                     : h.readbackColor(msaa ? targets.value().resolve : targets.value().color,
                                       VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
  destroyFrameTargets(h, targets.value());
  if (!pixels) return pixels.error();
  bake::Image out;
  out.width = width;
  out.height = height;
  out.rgba = std::move(pixels).value();
  if (samples == 1) return out;
  return bake::boxFilter(out, samples);
}

}  // namespace shrefract::offscreen
