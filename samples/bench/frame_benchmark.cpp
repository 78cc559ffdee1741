// Frame benchmark: what a host's frame costs (decompression + raster) at 1920x1080, with N
// instances of one field side by side, two frames in flight, and the ratios that matter measured in
// the same run. Links only the engine, the headless harness and Vulkan, so that it runs on any
// machine with a Vulkan driver (no Embree, no OpenImageIO); the exact-reference comparison, which
// needs the bake, is shrefract_reference_benchmark.
//
//   shrefract_frame_benchmark [FIELD.shrf ...] [--instances N] [--size WxH] [--frames N] [--cube-env]
//                             [--shading field|exit-direction|single-interface]
//                             [--format rgba16f|rgba8|rgba32f] [--env-taps N[,N...]] [--msaa N]
//                             [--per-fragment [--no-volume-refine]] [--validation]
//
// Scenes: each FIELD.shrf (read with readField), or without one a synthetic field (bench_support:
// order 8, u8, 4 channels, a 256x256 atlas of samples on a flat square). The environment is
// procedural (a sky gradient with a bright grid and a sun), so no image file is read. The N
// instances share one upload (Object::createInstance) and stand in a row along x; the camera frames
// the whole row in every series, so that "1 instance" is the same view with only the middle one.
// Series of F frames each (after two warm-up frames), recorded into two command buffers with a
// fence each, as a host with two frames in flight does:
//  - moving eye, N instances: the eye swings about the row by 0.2 degrees per frame (between -30
//    and +30 degrees), so every instance is decompressed every frame (the worst case);
//  - moving eye, 1 instance: the same with the middle instance only;
//  - still eye, N instances: after the first frame the Decompressor skips every instance (its
//    image already holds this eye's decompression), so the frame is the raster pass alone.
// Wall is the series' elapsed time divided by F (with frames in flight the frames overlap, so this
// is the frame rate a host sees, not one frame's latency); CPU is the process CPU time per frame,
// which on a software device (lavapipe) is the work itself whatever else competes for the cores.
// GPU timestamps (where the queue has them) split each frame into decompression and raster;
// medians over the frames. --env-taps runs every series once per tap count of the filtered
// environment lookups (RendererCreateInfo::environmentTapsPerAxis, default the engine's) and prints
// each count's raster time against the first count's, measured in the same run: the cost of the
// filtering on this device (docs/technique.md, "Cost"). --msaa N (2, 4 or 8) runs everything
// twice, into single-sample attachments and into N-sample ones resolved at the end of rendering
// (the host's MSAA, RendererCreateInfo::sampleCount), and prints the raster time at N samples
// against one sample, series by series, measured in the same run. A volume field prints the work of
// its paths (CPU mirror: samples traced, distance reads a path); with --per-fragment it runs again
// traced per fragment (Object::setTracesVolumePerFragment), each series' time against its texels'
// printed, then with the other setting of RendererCreateInfo::refineVolumePaths (--no-volume-refine
// starts with it off). With several fields, each one's series against the first's. Exit code 0 with
// "SKIPPED:" when there is no Vulkan device; 2 with one line for bad arguments or a FIELD.shrf that
// does not exist.
#include <shrefract/field_decode.h>
#include <shrefract/decompressor.h>
#include <shrefract/environment.h>
#include <shrefract/renderer.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "bench/bench_support.h"
#include "cli/args.h"

namespace shrefract::bench {
namespace {

constexpr uint32_t kInFlight = 2;
constexpr uint32_t kWarmUp = kInFlight;  // first use of each command buffer and of the attachments
// Timestamp marks of a frame: 0 start, 1 after decompression, 2 after the raster pass.
constexpr uint32_t kMarks = 3;

struct Options {
  std::vector<std::string> fields;  // empty: the synthetic field
  uint32_t instances = 4;
  uint32_t width = 1920, height = 1080;
  uint32_t frames = 30;
  bool cube = false;
  ShadingMode shading = ShadingMode::Field;
  VkFormat colorFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
  std::vector<uint32_t> environmentTaps{RendererCreateInfo{}.environmentTapsPerAxis};
  VkSampleCountFlagBits msaa = VK_SAMPLE_COUNT_1_BIT;  // > 1: also run with this many samples
  bool validation = false;
  bool refineVolumePaths = RendererCreateInfo{}.refineVolumePaths;  // --no-volume-refine: false
  bool perFragment = false;  // --per-fragment: a volume field also traced per fragment
};

// Bad arguments: one line naming the flag or file, exit 2. --help: the synopsis, exit 0.
int usage(const std::string& message) {
  std::fprintf(stderr, "shrefract_frame_benchmark: %s (--help for usage)\n", message.c_str());
  return 2;
}

int help() {
  std::printf("usage: shrefract_frame_benchmark [FIELD.shrf ...] [--instances N] [--size WxH] [--frames N]\n"
              "                                 [--cube-env] [--shading field|exit-direction|single-interface]\n"
              "                                 [--format rgba16f|rgba8|rgba32f] [--env-taps N[,N...]] [--msaa N]\n"
              "                                 [--per-fragment [--no-volume-refine]] [--validation]\n");
  return 0;
}

// Prints a run-time failure (one line) and returns exit code 1.
int fail(const std::string& message) {
  std::fprintf(stderr, "%s\n", message.c_str());
  return 1;
}

// The procedural environment: lat-long, row 0 = zenith (environment.h). A blue sky over a dark
// ground, a bright grid every 15 degrees and a sun, so that refracted lookups land on structure
// (as with a photographed map) rather than on a constant colour the texture cache would flatter.
std::vector<float> proceduralSky(uint32_t width, uint32_t height) {
  std::vector<float> rgba(size_t(width) * height * 4);
  constexpr float pi = std::numbers::pi_v<float>;
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      const float theta = pi * (float(y) + 0.5f) / float(height);   // from the zenith
      const float phi = 2.0f * pi * (float(x) + 0.5f) / float(width);
      const float up = std::cos(theta);
      std::array<float, 3> c = up > 0.0f ? std::array<float, 3>{0.3f + 0.3f * (1 - up), 0.5f + 0.2f * (1 - up), 0.9f}
                                         : std::array<float, 3>{0.25f, 0.2f, 0.15f};
      const float gridDegrees = 15.0f * pi / 180.0f;
      const bool line = std::fmod(theta, gridDegrees) < 0.02f || std::fmod(phi, gridDegrees) < 0.02f;
      const float sun = std::abs(theta - 0.25f * pi) < 0.05f && std::abs(phi - 0.5f * pi) < 0.05f ? 20.0f : 0.0f;
      float* p = &rgba[(size_t(y) * width + x) * 4];
      for (int k = 0; k < 3; ++k) p[k] = c[size_t(k)] + (line ? 1.5f : 0.0f) + sun;
      p[3] = 1.0f;
    }
  return rgba;
}

struct Scene {
  std::string name;
  Field field;
  std::vector<std::unique_ptr<Object>> objects;  // objects[0] the upload, the others its instances
  Camera camera;
};

// Object-space bounds of the field's render mesh.
void meshBounds(const Field& field, std::array<float, 3>& lo, std::array<float, 3>& hi) {
  lo = {1e30f, 1e30f, 1e30f};
  hi = {-1e30f, -1e30f, -1e30f};
  for (size_t i = 0; i + 2 < field.mesh.positions.size(); i += 3)
    for (size_t k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], field.mesh.positions[i + k]);
      hi[k] = std::max(hi[k], field.mesh.positions[i + k]);
    }
}

// Uploads the field once and makes instances-1 more instances of it, in a row along x with a
// quarter of the object's width between neighbours, centred on the object's own centre; the camera
// looks at the row from +z (the synthetic square faces +z), a little above, far enough back that
// the whole row fits the vertical field of view and the wider horizontal one.
Result<void> placeInstances(Context& context, Scene& scene, uint32_t instances) {
  std::array<float, 3> lo{}, hi{};
  meshBounds(scene.field, lo, hi);
  const float spacing = 1.25f * std::max(hi[0] - lo[0], 1e-3f);
  auto uploaded = context.uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
    auto source = Object::createFromField(context, scene.field, cmd);
    if (!source) return source.error();
    scene.objects.push_back(std::move(source).value());
    for (uint32_t k = 1; k < instances; ++k) {
      auto instance = Object::createInstance(context, *scene.objects[0], cmd);
      if (!instance) return instance.error();
      scene.objects.push_back(std::move(instance).value());
    }
    return {};
  });
  if (!uploaded) return uploaded.error();
  for (uint32_t k = 0; k < instances; ++k)
    scene.objects[k]->worldFromObject.translation = {(float(k) - 0.5f * float(instances - 1)) * spacing, 0.0f, 0.0f};
  const std::array<float, 3> centre{0.5f * (lo[0] + hi[0]), 0.5f * (lo[1] + hi[1]), 0.5f * (lo[2] + hi[2])};
  const float dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
  const float radius = 0.5f * std::sqrt(dx * dx + dy * dy + dz * dz) + 0.5f * float(instances - 1) * spacing;
  Camera& camera = scene.camera;
  camera.verticalFovDegrees = 40.0f;
  const float distance = 1.1f * radius / std::sin(0.5f * camera.verticalFovDegrees * std::numbers::pi_v<float> / 180.0f);
  camera.target = centre;
  camera.eye = {centre[0], centre[1] + 0.25f * distance, centre[2] + 0.97f * distance};
  camera.nearPlane = 0.01f * distance;
  camera.farPlane = 10.0f * distance;
  return {};
}

// The eye of frame i of a moving series: it swings about the vertical axis through the target,
// 0.2 degrees per frame between -30 and +30 degrees, so that every frame has a new eye (every
// instance is decompressed) however many frames run, and a one-sided object (the synthetic
// square) never turns its back to the camera, which would leave only the background to draw.
float swingDegrees(uint32_t frame) {
  const float p = std::fmod(0.2f * float(frame), 120.0f);
  return p < 60.0f ? p - 30.0f : 90.0f - p;
}

// The camera turned about the vertical axis through its target.
Camera orbit(const Camera& base, float degrees) {
  const float a = degrees * std::numbers::pi_v<float> / 180.0f;
  const float dx = base.eye[0] - base.target[0], dz = base.eye[2] - base.target[2];
  Camera c = base;
  c.eye[0] = base.target[0] + std::cos(a) * dx + std::sin(a) * dz;
  c.eye[2] = base.target[2] - std::sin(a) * dx + std::cos(a) * dz;
  return c;
}

// Attachments, command buffers and fences of the frame loop, shared by every series.
struct Frames {
  harness::Harness& h;
  VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT;
  harness::Harness::Image color{}, depth{};
  harness::Harness::Image resolve{};  // multisampled frames only: the single-sample target
  VkCommandPool pool = VK_NULL_HANDLE;
  std::array<VkCommandBuffer, kInFlight> cmd{};
  std::array<VkFence, kInFlight> fence{};
  std::vector<std::unique_ptr<GpuTimer>> timers;  // one per slot: read after its fence
  explicit Frames(harness::Harness& harness) : h(harness) {}
  ~Frames();
};

Frames::~Frames() {
  vkDeviceWaitIdle(h.device());
  for (VkFence f : fence)
    if (f) vkDestroyFence(h.device(), f, nullptr);
  if (pool) vkDestroyCommandPool(h.device(), pool, nullptr);
  timers.clear();
  if (color.image) h.destroyImage(color);
  if (depth.image) h.destroyImage(depth);
  if (resolve.image) h.destroyImage(resolve);
}

Result<void> createFrames(Frames& f, const Options& o, VkSampleCountFlagBits samples) {
  f.samples = samples;
  auto color = f.h.createImage(o.width, o.height, o.colorFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT,
                               VK_IMAGE_ASPECT_COLOR_BIT, samples);
  if (!color) return color.error();
  f.color = color.value();
  auto depth = f.h.createImage(o.width, o.height, VK_FORMAT_D32_SFLOAT, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                               VK_IMAGE_ASPECT_DEPTH_BIT, samples);
  if (!depth) return depth.error();
  f.depth = depth.value();
  if (samples != VK_SAMPLE_COUNT_1_BIT) {
    auto resolve = f.h.createImage(o.width, o.height, o.colorFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT,
                                   VK_IMAGE_ASPECT_COLOR_BIT);
    if (!resolve) return resolve.error();
    f.resolve = resolve.value();
  }
  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = f.h.queueFamily();
  if (vkCreateCommandPool(f.h.device(), &pci, nullptr, &f.pool) != VK_SUCCESS)
    return makeError(ErrorCode::Vulkan, "vkCreateCommandPool failed");
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = f.pool;
  ai.commandBufferCount = kInFlight;
  if (vkAllocateCommandBuffers(f.h.device(), &ai, f.cmd.data()) != VK_SUCCESS)
    return makeError(ErrorCode::Vulkan, "vkAllocateCommandBuffers failed");
  for (VkFence& fence : f.fence) {
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    fci.flags = VK_FENCE_CREATE_SIGNALED_BIT;
    if (vkCreateFence(f.h.device(), &fci, nullptr, &fence) != VK_SUCCESS)
      return makeError(ErrorCode::Vulkan, "vkCreateFence failed");
    f.timers.push_back(std::make_unique<GpuTimer>(f.h, kMarks));
  }
  return {};
}

struct Pass {
  Renderer& renderer;
  Decompressor& decompressor;
  const Environment& environment;
  ShadingMode shading;
};

// Objects first, then the background at the far plane: the depth test rejects the background
// where an object covers it before its fragment shader runs (renderer.h allows either order).
void recordRaster(VkCommandBuffer cmd, const Frames& f, const Pass& pass, const Camera& camera, VkExtent2D extent,
                  const std::vector<Object*>& objects) {
  harness::beginRendering(cmd, f.color, f.depth, f.resolve.image ? &f.resolve : nullptr);
  pass.renderer.recordObjects(cmd, pass.environment, camera, extent, objects, pass.shading);
  pass.renderer.recordBackground(cmd, pass.environment, camera, extent);
  vkCmdEndRendering(cmd);
}

struct SeriesResult {
  double wallMs = 0.0, cpuMs = 0.0;          // per frame: series total / frames
  double decompressMs = 0.0, rasterMs = 0.0;  // GPU timestamps, medians
  double decompressionsPerFrame = 0.0;        // objects decompressed, mean over the frames
  uint32_t drawn = 0;                         // draw calls of the last frame
};

struct Samples {
  std::vector<double> decompress, raster;
  uint64_t decompressions = 0;
};

// Records, submits and (with the fence of the frame two back) paces one frame in `slot`; the
// slot's timestamps, from the frame it held before, go to `samples` when that frame was measured.
Result<void> frame(Frames& f, uint32_t slot, bool readPrevious, Context& context, const Pass& pass,
                   const Camera& camera, VkExtent2D extent, const std::vector<Object*>& objects, Samples& samples,
                   bool measured) {
  VkDevice device = f.h.device();
  if (vkWaitForFences(device, 1, &f.fence[slot], VK_TRUE, UINT64_MAX) != VK_SUCCESS)
    return makeError(ErrorCode::Vulkan, "vkWaitForFences failed");
  GpuTimer& timer = *f.timers[slot];
  if (readPrevious && timer.available()) {
    samples.decompress.push_back(timer.elapsedMs(0, 1));
    samples.raster.push_back(timer.elapsedMs(1, 2));
  }
  context.beginFrame();  // this slot's previous frame is done: release what it retired
  vkResetFences(device, 1, &f.fence[slot]);
  VkCommandBuffer cmd = f.cmd[slot];
  vkResetCommandBuffer(cmd, 0);
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vkBeginCommandBuffer(cmd, &bi);
  timer.begin(cmd);
  timer.mark(cmd, 0);
  auto recorded = pass.decompressor.record(cmd, camera, extent, objects);
  if (measured) samples.decompressions += pass.decompressor.lastStats().decompressed;
  timer.mark(cmd, 1);
  recordRaster(cmd, f, pass, camera, extent, objects);
  timer.mark(cmd, 2);
  vkEndCommandBuffer(cmd);
  // Submitted even when the decompression failed: the Decompressor then recorded nothing, and an
  // unsubmitted buffer would leave the fence unsignalled for the next wait.
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd;
  if (vkQueueSubmit(f.h.queue(), 1, &si, f.fence[slot]) != VK_SUCCESS)
    return makeError(ErrorCode::Vulkan, "vkQueueSubmit failed");
  if (!recorded) return recorded.error();
  return {};
}

Result<SeriesResult> runSeries(Frames& f, Context& context, const Pass& pass, const Camera& camera,
                               const std::vector<Object*>& objects, bool movingEye, uint32_t frames) {
  const VkExtent2D extent{f.color.width, f.color.height};
  Samples samples;
  std::array<bool, kInFlight> measuredInSlot{};
  std::chrono::steady_clock::time_point start;
  double cpuStart = 0.0;
  for (uint32_t i = 0; i < kWarmUp + frames; ++i) {
    if (i == kWarmUp) {  // the warm-up frames finish first: their work is not the series'
      vkWaitForFences(f.h.device(), kInFlight, f.fence.data(), VK_TRUE, UINT64_MAX);
      start = std::chrono::steady_clock::now();
      cpuStart = processCpuMs();
    }
    const uint32_t slot = i % kInFlight;
    const bool measured = i >= kWarmUp;
    const Camera cam = movingEye ? orbit(camera, swingDegrees(i)) : camera;
    auto done = frame(f, slot, measuredInSlot[slot], context, pass, cam, extent, objects, samples, measured);
    if (!done) return done.error();
    measuredInSlot[slot] = measured;
  }
  for (uint32_t slot = 0; slot < kInFlight; ++slot) {  // the last frames: wait, then read
    vkWaitForFences(f.h.device(), 1, &f.fence[slot], VK_TRUE, UINT64_MAX);
    if (measuredInSlot[slot] && f.timers[slot]->available()) {
      samples.decompress.push_back(f.timers[slot]->elapsedMs(0, 1));
      samples.raster.push_back(f.timers[slot]->elapsedMs(1, 2));
    }
  }
  SeriesResult r;
  r.wallMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count() / frames;
  r.cpuMs = (processCpuMs() - cpuStart) / frames;
  r.decompressMs = median(samples.decompress);
  r.rasterMs = median(samples.raster);
  r.decompressionsPerFrame = double(samples.decompressions) / frames;
  r.drawn = pass.renderer.lastDrawStats().drawn;
  return r;
}

void printSeries(const char* name, const SeriesResult& r, bool timestamps) {
  std::printf("  %-28s wall %8.2f ms (%6.1f fps)  CPU %8.2f ms", name, r.wallMs, 1000.0 / r.wallMs, r.cpuMs);
  if (timestamps) std::printf("  GPU decompression %7.2f ms  raster %7.2f ms", r.decompressMs, r.rasterMs);
  std::printf("  [%.1f decompressions per frame, %u drawn]\n", r.decompressionsPerFrame, r.drawn);
}

std::string instancesLabel(uint32_t n) { return n == 1 ? "1 instance" : std::to_string(n) + " instances"; }

// The same-run ratios: what N instances cost against one (moving1 is null when N is 1), what
// moving the eye costs against the still eye (whose decompression the Decompressor skips), and
// decompression against raster.
void printRatios(const SeriesResult& movingN, const SeriesResult* moving1, const SeriesResult& stillN,
                 uint32_t instances, bool timestamps) {
  const std::string n = instancesLabel(instances);
  std::printf("ratios (same run):\n");
  if (moving1) {
    std::printf("  moving eye, %s / 1 instance: wall %.2fx, CPU %.2fx", n.c_str(), movingN.wallMs / moving1->wallMs,
                movingN.cpuMs / moving1->cpuMs);
    if (timestamps)
      std::printf(", GPU decompression %.2fx, raster %.2fx", movingN.decompressMs / moving1->decompressMs,
                  movingN.rasterMs / moving1->rasterMs);
    std::printf("\n");
  }
  std::printf("  moving eye / still eye (%s): wall %.2fx, CPU %.2fx\n", n.c_str(), movingN.wallMs / stillN.wallMs,
              movingN.cpuMs / stillN.cpuMs);
  if (timestamps)
    std::printf("  decompression / raster (moving eye, %s, GPU): %.2f\n", n.c_str(),
                movingN.decompressMs / movingN.rasterMs);
  else
    std::printf("  decompression / raster: no GPU timestamps on this queue; (moving - still) / still wall: %.2f\n",
                (movingN.wallMs - stillN.wallMs) / stillN.wallMs);
}

struct Named {
  std::string name;
  std::vector<Object*> objects;
  bool moving = false;
  SeriesResult result;
};

// The series of a scene: moving eye with all instances, with the middle one alone (only when
// there are several: with one it would measure the same thing twice), still eye with all.
std::vector<Named> seriesOf(const Scene& scene, uint32_t instances) {
  std::vector<Object*> all;
  for (const auto& object : scene.objects) all.push_back(object.get());
  const std::string n = instancesLabel(instances);
  std::vector<Named> series{{"moving eye, " + n, all, true, {}}};
  if (instances > 1) series.push_back({"moving eye, 1 instance", {scene.objects[instances / 2].get()}, true, {}});
  series.push_back({"still eye, " + n, all, false, {}});
  return series;
}

// Every series of the scene rendered by a renderer with `taps` taps per axis; prints each series and
// the same-run ratios between them.
Result<std::vector<Named>> runTapCount(Gpu& gpu, Frames& frames, Decompressor& decompressor,
                                       const Environment& environment, const Scene& scene, const Options& o,
                                       uint32_t taps) {
  RendererCreateInfo info{o.colorFormat, VK_FORMAT_D32_SFLOAT};
  info.environmentTapsPerAxis = taps;
  info.sampleCount = frames.samples;
  info.refineVolumePaths = o.refineVolumePaths;
  auto renderer = Renderer::create(*gpu.context, info);
  if (!renderer) return renderer.error();
  if (o.environmentTaps.size() > 1) std::printf("environment taps per axis: %u\n", taps);
  const Pass pass{*renderer.value(), decompressor, environment, o.shading};
  const bool timestamps = frames.timers[0]->available();
  std::vector<Named> series = seriesOf(scene, o.instances);
  for (Named& n : series) {
    auto r = runSeries(frames, *gpu.context, pass, scene.camera, n.objects, n.moving, o.frames);
    if (!r) return r.error();
    n.result = r.value();
    printSeries(n.name.c_str(), n.result, timestamps);
  }
  const SeriesResult* moving1 = series.size() == 3 ? &series[1].result : nullptr;
  printRatios(series.front().result, moving1, series.back().result, o.instances, timestamps);
  vkDeviceWaitIdle(gpu.harness->device());  // the renderer is destroyed on return
  return series;
}

// What each further tap count costs against the first, series by series: the raster pass's GPU
// time where the queue has timestamps (the decompression does not depend on the taps), else wall.
void printTapRatios(const Options& o, const std::vector<std::vector<Named>>& byCount, bool timestamps) {
  std::printf("environment taps, ratios to %u taps per axis (same run, %s):\n", o.environmentTaps[0],
              timestamps ? "GPU raster" : "wall");
  for (size_t k = 1; k < byCount.size(); ++k)
    for (size_t s = 0; s < byCount[k].size(); ++s) {
      const SeriesResult& a = byCount[0][s].result;
      const SeriesResult& b = byCount[k][s].result;
      const double before = timestamps ? a.rasterMs : a.wallMs, after = timestamps ? b.rasterMs : b.wallMs;
      std::printf("  %u / %u taps, %-28s %8.3f -> %8.3f ms  %.2fx\n", o.environmentTaps[k], o.environmentTaps[0],
                  byCount[k][s].name.c_str(), before, after, after / before);
    }
}

// What N samples per pixel cost against one, series by series and tap count by tap count: the
// raster pass's GPU time (or wall without timestamps), both measured in this run.
void printMsaaRatios(const Options& o, const std::vector<std::vector<Named>>& single,
                     const std::vector<std::vector<Named>>& multi, bool timestamps) {
  std::printf("MSAA, %ux against 1 sample per pixel (same run, %s):\n", uint32_t(o.msaa),
              timestamps ? "GPU raster" : "wall");
  for (size_t k = 0; k < single.size() && k < multi.size(); ++k)
    for (size_t s = 0; s < single[k].size() && s < multi[k].size(); ++s) {
      const SeriesResult& a = single[k][s].result;
      const SeriesResult& b = multi[k][s].result;
      const double before = timestamps ? a.rasterMs : a.wallMs, after = timestamps ? b.rasterMs : b.wallMs;
      std::printf("  %u taps, %-28s %8.3f -> %8.3f ms  %.2fx\n", o.environmentTaps[k], single[k][s].name.c_str(),
                  before, after, after / before);
    }
}

// Two runs of the same scene, series by series (`before` then `after`, labelled so): the frame's GPU
// time (decompression + raster; wall without timestamps), both measured in this run.
void printPairRatios(const Options& o, const char* heading, const char* beforeLabel, const char* afterLabel,
                     const std::vector<std::vector<Named>>& before, const std::vector<std::vector<Named>>& after,
                     bool timestamps) {
  std::printf("%s (same run, %s):\n", heading, timestamps ? "GPU decompression + raster" : "wall");
  for (size_t k = 0; k < before.size() && k < after.size(); ++k)
    for (size_t s = 0; s < before[k].size() && s < after[k].size(); ++s) {
      const SeriesResult& a = before[k][s].result;
      const SeriesResult& b = after[k][s].result;
      const double msA = timestamps ? a.decompressMs + a.rasterMs : a.wallMs;
      const double msB = timestamps ? b.decompressMs + b.rasterMs : b.wallMs;
      std::printf("  %u taps, %-28s %s %8.3f, %s %8.3f ms  %.2fx\n", o.environmentTaps[k], before[k][s].name.c_str(),
                  beforeLabel, msA, afterLabel, msB, msB / msA);
    }
}

// Every tap count's series of the scene into `frames`; prints them, and the tap ratios.
Result<std::vector<std::vector<Named>>> benchmarkScene(Gpu& gpu, Frames& frames, const Environment& environment,
                                                       Scene& scene, const Options& o) {
  auto decompressor = Decompressor::create(*gpu.context);
  if (!decompressor) return decompressor.error();
  if (auto prepared = decompressor.value()->prepare(*scene.objects[0]); !prepared) return prepared.error();
  const Field& f = scene.field;
  std::printf("field: %s, %s, %s, %u channels, %ux%u atlas, %zu triangles; %s; %u sample(s) per pixel\n",
              scene.name.c_str(), encodingLabel(f).c_str(), toString(f.quantization), f.channels, f.width, f.height,
              f.mesh.indices.size() / 3, instancesLabel(o.instances).c_str(), uint32_t(frames.samples));
  std::vector<std::vector<Named>> byCount;
  for (uint32_t taps : o.environmentTaps) {
    auto series = runTapCount(gpu, frames, *decompressor.value(), environment, scene, o, taps);
    if (!series) return series.error();
    byCount.push_back(std::move(series).value());
  }
  if (byCount.size() > 1) printTapRatios(o, byCount, frames.timers[0]->available());
  vkDeviceWaitIdle(gpu.harness->device());
  return byCount;
}

// Each field's series against the first field's, measured in this run (process CPU time per frame,
// the work on a software device, and wall): the default field's cost against an SH field's.
void printAgainstFirst(const std::vector<std::string>& names, const std::vector<std::vector<Named>>& firstTaps) {
  if (names.size() < 2) return;
  std::printf("against the first field, %s (same run, first environment tap count):\n", names[0].c_str());
  for (size_t i = 1; i < names.size(); ++i) {
    const std::vector<Named>& a = firstTaps[0];
    const std::vector<Named>& b = firstTaps[i];
    for (size_t s = 0; s < a.size() && s < b.size(); ++s)
      std::printf("  %-40s %-28s CPU %8.2f / %8.2f ms  %.2fx   wall %.2fx\n", names[i].c_str(), b[s].name.c_str(),
                  b[s].result.cpuMs, a[s].result.cpuMs, b[s].result.cpuMs / a[s].result.cpuMs,
                  b[s].result.wallMs / a[s].result.wallMs);
  }
}

// A Volume field's paths for the still eye of the middle instance, through the CPU mirror of the
// decode (traceVolumeSample, which decompress_volume.comp follows): the samples left untraced
// (facing away) and the distance reads a traced sample's path takes (march steps and bisections).
void printVolumePathWork(const Scene& scene) {
  if (scene.field.encoding != Encoding::Volume || scene.objects.empty()) return;
  const Object& middle = *scene.objects[scene.objects.size() / 2];
  const auto& t = middle.worldFromObject.translation;
  const std::array<float, 3> eye{scene.camera.eye[0] - t[0], scene.camera.eye[1] - t[1], scene.camera.eye[2] - t[2]};
  uint64_t samples = 0, traced = 0, reads = 0;
  const Field& f = scene.field;
  for (uint64_t texel = 0; texel < f.texelCount(); ++texel) {
    if (f.texelKinds[texel] != kTexelSample) continue;
    const float* m = &f.frames[texel * 12];
    std::array<float, 3> w{};
    for (int k = 0; k < 3; ++k) w[k] = m[4 * k] * eye[0] + m[4 * k + 1] * eye[1] + m[4 * k + 2] * eye[2] + m[4 * k + 3];
    ++samples;
    float out[5];
    const VolumePath path = traceVolumeSample(f, m, w, out);
    traced += path.traced ? 1 : 0;
    reads += path.steps;
  }
  std::printf("  volume paths (CPU mirror, still eye): %llu of %llu samples traced (the others face away), "
              "%.1f distance reads per traced path (march steps and bisections)\n",
              static_cast<unsigned long long>(traced), static_cast<unsigned long long>(samples),
              traced ? double(reads) / double(traced) : 0.0);
}

// The scenes in order: each FIELD.shrf, or the synthetic field.
Result<Scene> loadScene(const Options& o, size_t index) {
  Scene scene;
  if (o.fields.empty()) {
    scene.name = "synthetic (flat square, bench_support)";
    scene.field = syntheticField({});
    return scene;
  }
  scene.name = o.fields[index];
  auto read = readField(scene.name);
  if (!read) return read.error();  // readField names the file
  scene.field = std::move(read).value();
  return scene;
}

Result<std::unique_ptr<Environment>> createEnvironment(Context& context, bool cube) {
  constexpr uint32_t kWidth = 1024, kHeight = 512;
  const std::vector<float> sky = proceduralSky(kWidth, kHeight);
  std::unique_ptr<Environment> environment;
  auto uploaded = context.uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
    const LatLongEnvironmentDesc desc{kWidth, kHeight, sky.data()};
    auto env = cube ? Environment::createCubeFromLatLong(context, desc, 0, cmd)
                    : Environment::createLatLong(context, desc, cmd);
    if (!env) return env.error();
    environment = std::move(env).value();
    return {};
  });
  if (!uploaded) return uploaded.error();
  return environment;
}

int run(const Options& o) {
  bool noDevice = false;
  std::unique_ptr<Gpu> gpu = createGpu(o.validation, &noDevice);
  if (!gpu) return noDevice ? 0 : 1;
  std::printf("device: %s\n", gpu->harness->deviceName().c_str());
  std::printf("frame: %ux%u, %u frames per series after %u warm-up, %u frames in flight; %s environment\n", o.width,
              o.height, o.frames, kWarmUp, kInFlight, o.cube ? "procedural cube" : "procedural lat-long");
  {
    auto environment = createEnvironment(*gpu->context, o.cube);
    if (!environment) return fail(environment.error().message);
    Frames frames(*gpu->harness), multisampled(*gpu->harness);
    if (auto created = createFrames(frames, o, VK_SAMPLE_COUNT_1_BIT); !created)
      return fail(created.error().message);
    if (o.msaa != VK_SAMPLE_COUNT_1_BIT)
      if (auto created = createFrames(multisampled, o, o.msaa); !created)
        return fail("--msaa " + std::to_string(uint32_t(o.msaa)) + ": " + created.error().message);
    std::vector<std::string> names;
    std::vector<std::vector<Named>> firstTaps;  // each field's series at the first tap count
    for (size_t i = 0; i < std::max<size_t>(1, o.fields.size()); ++i) {
      auto scene = loadScene(o, i);
      if (!scene) return fail(scene.error().message);
      auto placed = placeInstances(*gpu->context, scene.value(), o.instances);
      if (!placed) return fail(scene.value().name + ": " + placed.error().message);
      auto single = benchmarkScene(*gpu, frames, *environment.value(), scene.value(), o);
      if (!single) return fail(single.error().message);
      names.push_back(scene.value().name);
      firstTaps.push_back(single.value()[0]);
      printVolumePathWork(scene.value());
      // A volume field (decoded at its sample texels by default) again traced per fragment, where
      // the device can read its grid in the raster pass, measured in this run.
      bool perFragment = o.perFragment;
      for (auto& object : scene.value().objects)
        perFragment = perFragment && object->setTracesVolumePerFragment(true);
      if (perFragment) {
        auto fragments = benchmarkScene(*gpu, frames, *environment.value(), scene.value(), o);
        if (!fragments) return fail(fragments.error().message);
        const bool timestamps = frames.timers[0]->available();
        printPairRatios(o, "volume traced per fragment against its sample texels", "texels", "per fragment",
                        single.value(), fragments.value(), timestamps);
        // And per fragment without the refined pixels (RendererCreateInfo::refineVolumePaths).
        Options unrefined = o;
        unrefined.refineVolumePaths = !o.refineVolumePaths;
        auto other = benchmarkScene(*gpu, frames, *environment.value(), scene.value(), unrefined);
        if (!other) return fail(other.error().message);
        printPairRatios(o, "volume paths refined where they part against 2x2 paths everywhere", "2x2", "refined",
                        o.refineVolumePaths ? other.value() : fragments.value(),
                        o.refineVolumePaths ? fragments.value() : other.value(), timestamps);
        for (auto& object : scene.value().objects) (void)object->setTracesVolumePerFragment(false);
      }
      if (o.msaa == VK_SAMPLE_COUNT_1_BIT) continue;
      auto multi = benchmarkScene(*gpu, multisampled, *environment.value(), scene.value(), o);
      if (!multi) return fail("--msaa " + std::to_string(uint32_t(o.msaa)) + ": " + multi.error().message);
      printMsaaRatios(o, single.value(), multi.value(), frames.timers[0]->available());
    }
    printAgainstFirst(names, firstTaps);
  }
  if (const uint32_t messages = gpu->harness->messageCount(); messages) {
    std::fprintf(stderr, "%u Vulkan validation message(s)\n", messages);
    return 1;
  }
  return 0;
}

// "2" or "1,2,4": each count within the renderer's range; false (counts untouched) otherwise.
bool parseTapCounts(const std::string& text, std::vector<uint32_t>& counts) {
  std::vector<uint32_t> parsed;
  size_t begin = 0;
  while (begin <= text.size()) {
    const size_t end = std::min(text.find(',', begin), text.size());
    uint32_t n = 0;
    if (!parseCount(text.substr(begin, end - begin).c_str(), 1, kMaxEnvironmentTapsPerAxis, n)) return false;
    parsed.push_back(n);
    begin = end + 1;
  }
  counts = std::move(parsed);
  return true;
}

// Nothing when the arguments are good, else the exit code (2 after one line for bad ones).
std::optional<int> parseArguments(int argc, char** argv, Options& o) {
  const std::vector<cli::FlagSpec> flags = withFrameFlags({
      {"frames", true, "timed frames", cli::ValueKind::Integer, {1, 10000}},
      {"instances", true, "instances of each field", cli::ValueKind::Integer, {1, 256}},
      {"env-taps", true, "environment taps per axis, comma-separated"},
      {"msaa", true, "1, 2, 4 or 8"},
      {"per-fragment", false, "a volume field also traced per fragment"},
      {"no-volume-refine", false, "volume paths not refined"},
  });
  auto parsed = parseCommandLine("shrefract_frame_benchmark", argc, argv, flags, [](const char* error) {
    if (error) std::fprintf(stderr, "%s (--help for usage)\n", error);
    else help();
  });
  if (const int* exitCode = std::get_if<int>(&parsed)) return *exitCode;
  const cli::Args& args = std::get<cli::Args>(parsed);
  args.read("size", o.width, o.height);
  args.read("frames", o.frames);
  args.read("instances", o.instances);
  if (const auto bad = readShadingAndFormat(args, o.shading, o.colorFormat)) return usage(*bad);
  if (std::string v; args.read("env-taps", v) && !parseTapCounts(v, o.environmentTaps))
    return usage("--env-taps expects counts 1.." + std::to_string(kMaxEnvironmentTapsPerAxis) + ", comma-separated");
  if (std::string v; args.read("msaa", v)) {
    uint32_t n = 0;
    if (!parseCount(v.c_str(), 1, 8, n) || (n & (n - 1))) return usage("--msaa expects 1, 2, 4 or 8");
    o.msaa = static_cast<VkSampleCountFlagBits>(n);  // 1, 2, 4, 8 are the flag bits
  }
  o.cube = args.has("cube-env");
  o.perFragment = args.has("per-fragment");
  if (args.has("no-volume-refine")) o.refineVolumePaths = false;
  o.validation = args.has("validation");
  for (const std::string& a : args.positional()) {
    if (!std::filesystem::is_regular_file(a)) return usage(a + ": no such file");
    o.fields.push_back(a);
  }
  return std::nullopt;
}

}  // namespace
}  // namespace shrefract::bench

int main(int argc, char** argv) {
  return shrefract::bench::benchmarkMain(argc, argv, shrefract::bench::parseArguments, shrefract::bench::run);
}
