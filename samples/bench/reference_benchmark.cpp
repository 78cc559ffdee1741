// Reference benchmark: the SH path (decompression + raster) at 1280x720 against the exact CPU
// reference (Embree, the baked scene rebuilt from the field's recorded source) at the same size and
// camera, in the same run. Target, on lavapipe with 2 cores: the bunny at order 8 at 30
// frames per second or more, and at least 10x faster than the exact reference. It links the bake
// library (Embree, OpenImageIO) to rebuild the scene, so it runs only where those are installed;
// shrefract_frame_benchmark is the engine-only frame benchmark that runs on any Vulkan machine.
//
//   shrefract_reference_benchmark FIELD.shrf [--size WxH] [--frames N] [--env builtin|FILE] [--cube-env]
//                                 [--shading field|exit-direction|single-interface]
//                                 [--format rgba16f|rgba8|rgba32f] [--threads T] [--no-reference]
//                                 [--validation]
//
// Run it from the directory the field was baked in when the field's source is a relative path
// (shrefract info FIELD.shrf shows it). Three series of N frames, each frame recorded, submitted and
// waited for on its own (no frames in flight: the wall time is the whole frame):
//  - moving: the eye orbits by 0.2 degrees per frame, so every frame decompresses (the worst case);
//  - static: the eye stays; after the first frame the decompression is skipped (Decompressor);
//  - raster only: no field decompression recorded at all, for the split of the frame;
//  - background only: the environment pass alone.
// CPU is the process CPU time per frame: on a software device (llvmpipe) that is the work itself,
// whatever else competes for the cores, while wall and GPU timestamps include the waiting.
// Each frame draws the objects first and the background after them (renderer.h allows either
// order), into a colour target of --format (default RGBA16F) and a D32 depth target. --shading and
// --format exist to take the frame apart (what the fragment shading or the target format costs).
// The exact reference uses the camera and environment of the SH frames and every hardware thread
// (--threads to change).
// GPU timestamps give the decompression and raster parts; medians over the frames. Exit code 0
// with "SKIPPED:" when there is no Vulkan device or FIELD.shrf is missing.
#include <shrefract/trace/reference_render.h>
#include <shrefract/trace/tracer.h>
#include <shrefract/decompressor.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "bench/bench_support.h"
#include "cli/args.h"
#include "cli/scene_source.h"
#include "offscreen/offscreen.h"

namespace shrefract::bench {
namespace {

struct Options {
  std::string field;
  uint32_t width = 1280, height = 720;
  uint32_t frames = 30;
  std::string environment = "builtin";
  bool cube = false;
  ShadingMode shading = ShadingMode::Field;
  // --format rgba16f (default: what a host renders HDR into), rgba8 (R8G8B8A8_UNORM), rgba32f
  VkFormat colorFormat = VK_FORMAT_R16G16B16A16_SFLOAT;  // --shading: field (default), exit-direction, single-interface
  uint32_t threads = 0;
  bool reference = true;
  bool validation = false;
};

int usage(const char* message) {
  return usageError(message,
                    "usage: shrefract_reference_benchmark FIELD.shrf [--size WxH] [--frames N] [--env builtin|FILE] "
                    "[--cube-env]\n"
                    "                                     [--shading field|exit-direction|single-interface]\n"
                    "                                     [--format rgba16f|rgba8|rgba32f]\n"
                    "                                     [--threads T] [--no-reference] [--validation]\n");
}

enum class Series { Moving, Static, RasterOnly, BackgroundOnly };

struct SeriesResult {
  double wallMs = 0.0, decompressMs = 0.0, rasterMs = 0.0;  // medians
  double cpuMs = 0.0;  // median process CPU time per frame (the work itself on a software device)
  uint32_t decompressedFrames = 0;                          // frames that recorded a decompression
  uint32_t drawn = 0, culled = 0;                           // last frame
};

// Timestamp marks of a frame: 0 start, 1 after decompression, 2 before the attachment barriers and
// rendering (harness::beginRendering), 3 after.
constexpr uint32_t kMarks = 4;

Camera orbit(const Camera& base, float degrees) {
  const glm::vec3 target(base.target[0], base.target[1], base.target[2]);
  const glm::vec3 eye(base.eye[0], base.eye[1], base.eye[2]);
  const float a = glm::radians(degrees);
  const glm::vec3 d = eye - target;
  const glm::vec3 rotated(std::cos(a) * d.x + std::sin(a) * d.z, d.y, -std::sin(a) * d.x + std::cos(a) * d.z);
  Camera c = base;
  const glm::vec3 e = target + rotated;
  c.eye = {e.x, e.y, e.z};
  return c;
}

constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

// The colour and depth targets every frame of a series draws into.
struct Targets {
  harness::Harness::Image color, depth;
};

Result<Targets> createTargets(harness::Harness& h, const Options& options) {
  auto color = h.createImage(options.width, options.height, options.colorFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT,
                             VK_IMAGE_ASPECT_COLOR_BIT);
  if (!color) return color.error();
  auto depth = h.createImage(options.width, options.height, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                             VK_IMAGE_ASPECT_DEPTH_BIT);
  if (!depth) {
    h.destroyImage(color.value());
    return depth.error();
  }
  return Targets{color.value(), depth.value()};
}

// What every frame of a series records with.
struct SeriesFrame {
  GpuTimer& timer;
  Decompressor& decompressor;
  Renderer& renderer;
  const Environment& environment;
  const std::vector<Object*>& objects;
  Targets targets;
  VkExtent2D extent;
  ShadingMode shading;
  Series series;
};

// One frame's commands between the timestamp marks (kMarks).
void recordFrame(VkCommandBuffer cmd, const SeriesFrame& f, const Camera& cam, Result<void>& recorded,
                 bool& decompressed) {
  f.timer.begin(cmd);
  f.timer.mark(cmd, 0);
  if (f.series == Series::Moving || f.series == Series::Static) {
    recorded = f.decompressor.record(cmd, cam, f.extent, f.objects);
    decompressed = f.decompressor.lastStats().decompressed > 0;
  }
  f.timer.mark(cmd, 1);
  f.timer.mark(cmd, 2);
  harness::beginRendering(cmd, f.targets.color, f.targets.depth);
  // Objects first, then the background at the far plane: the depth test rejects the background
  // where an object covers it before its fragment shader runs (renderer.h allows either order).
  if (f.series != Series::BackgroundOnly)
    f.renderer.recordObjects(cmd, f.environment, cam, f.extent, f.objects, f.shading);
  f.renderer.recordBackground(cmd, f.environment, cam, f.extent);
  vkCmdEndRendering(cmd);
  f.timer.mark(cmd, 3);
}

Result<SeriesResult> runSeries(offscreen::Session& session, const Environment& environment, Object& object,
                               const Camera& camera, const Options& options, Series series) {
  harness::Harness& h = *session.harness;
  RendererCreateInfo rci;
  rci.colorFormat = options.colorFormat;
  rci.depthFormat = kDepthFormat;
  auto renderer = Renderer::create(*session.context, rci);
  if (!renderer) return renderer.error();
  auto decompressor = Decompressor::create(*session.context);
  if (!decompressor) return decompressor.error();
  if (auto prepared = decompressor.value()->prepare(object); !prepared) return prepared.error();
  object.invalidateDistortion();  // every series starts from scratch
  auto targets = createTargets(h, options);
  if (!targets) return targets.error();
  GpuTimer timer(h, kMarks);
  const std::vector<Object*> objects{&object};
  SeriesFrame f{timer, *decompressor.value(), *renderer.value(), environment, objects, targets.value(),
                {options.width, options.height}, options.shading, series};
  std::vector<double> wall, decompress, raster, cpu;
  SeriesResult result;
  Result<void> status{};
  // One warm-up frame (first use of the attachments), then the measured frames.
  for (uint32_t frame = 0; frame <= options.frames && status.ok(); ++frame) {
    const Camera cam = series == Series::Moving ? orbit(camera, 0.2f * float(frame)) : camera;
    session.context->beginFrame();
    const auto start = std::chrono::steady_clock::now();
    const double cpuStart = processCpuMs();
    Result<void> recorded{};
    bool decompressed = false;
    auto submitted =
        h.submitAndWait([&](VkCommandBuffer cmd) { recordFrame(cmd, f, cam, recorded, decompressed); });
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    const double cpuMs = processCpuMs() - cpuStart;
    if (!submitted) status = submitted.error();
    else if (!recorded) status = recorded.error();
    if (!status || frame == 0) continue;
    wall.push_back(ms);
    cpu.push_back(cpuMs);
    decompress.push_back(timer.elapsedMs(0, 1));
    raster.push_back(timer.elapsedMs(2, 3));
    result.decompressedFrames += decompressed ? 1u : 0u;
    result.drawn = renderer.value()->lastDrawStats().drawn;
    result.culled = renderer.value()->lastDrawStats().culled;
  }
  h.destroyImage(f.targets.color);
  h.destroyImage(f.targets.depth);
  if (!status) return status.error();
  result.wallMs = median(wall);
  result.decompressMs = median(decompress);
  result.rasterMs = median(raster);
  result.cpuMs = median(cpu);
  return result;
}

// The lines that say what is measured: device, field and frame.
void printHeader(offscreen::Session& session, const Field& field, const Options& options) {
  uint64_t samples = 0;
  for (uint8_t k : field.texelKinds) samples += k == kTexelSample;

  std::printf("device: %s\n", session.harness->deviceName().c_str());
  std::printf("field: %s (%s), order %u, %s, %u channels, %ux%u atlas, %llu samples, %zu triangles\n",
              options.field.c_str(), field.settings.source.c_str(), field.order, toString(field.quantization),
              field.channels, field.width, field.height, static_cast<unsigned long long>(samples),
              field.mesh.indices.size() / 3);
  std::printf("frame: %ux%u, %u frames per series, median per frame (wall: record + submit + wait)\n", options.width,
              options.height, options.frames);
}

struct NamedSeries {
  const char* name;
  Series series;
  SeriesResult result;
};

// Every series in turn, a line each; false after printing the error of one that failed.
bool runAllSeries(offscreen::Session& session, const Environment& environment, Object& object, const Camera& camera,
                  const Options& options, std::array<NamedSeries, 4>& runs) {
  for (NamedSeries& n : runs) {
    auto r = runSeries(session, environment, object, camera, options, n.series);
    if (!r) {
      std::fprintf(stderr, "%s\n", r.error().message.c_str());
      return false;
    }
    n.result = r.value();
    std::printf("  %-38s wall %8.2f ms (%6.1f fps)  GPU decompression %7.2f ms  raster %7.2f ms  CPU %7.2f ms  "
                "[decompressed in %u of %u frames; drawn %u, culled %u]\n",
                n.name, n.result.wallMs, 1000.0 / n.result.wallMs, n.result.decompressMs, n.result.rasterMs,
                n.result.cpuMs, n.result.decompressedFrames, options.frames, n.result.drawn, n.result.culled);
  }
  return true;
}

// The exact CPU reference at the camera of the SH frames, against their wall times. Exit code.
int runReference(const Options& options, const Field& field, const Camera& camera, const bake::Image& envImage,
                 double movingMs, double staticMs) {
  // The recorded scene, found relative to the field file as `render --mode exact` finds it.
  auto spec = cli::bakedSceneSpec(options.field, field.settings.source, std::nullopt);
  auto scene = spec ? cli::loadScene(spec.value(), {}, nullptr) : Result<bake::Scene>(spec.error());
  if (!scene) {
    std::printf("reference: SKIPPED: cannot rebuild the baked scene '%s': %s\n", field.settings.source.c_str(),
                scene.error().message.c_str());
    return 0;
  }
  auto tracer = bake::Tracer::create(scene.value());
  if (!tracer) {
    std::fprintf(stderr, "%s\n", tracer.error().message.c_str());
    return 1;
  }
  bake::ReferenceOptions ro;
  ro.mode = bake::ReferenceMode::Exact;
  ro.width = options.width;
  ro.height = options.height;
  ro.camera = camera;
  ro.threads = options.threads;
  const auto start = std::chrono::steady_clock::now();
  auto reference = bake::renderReference(*tracer.value(), scene.value(), envImage, ro);
  const double referenceMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!reference) {
    std::fprintf(stderr, "%s\n", reference.error().message.c_str());
    return 1;
  }
  std::printf("  %-38s wall %8.2f ms (%6.2f fps), %llu rays\n", "exact reference (CPU, Embree)", referenceMs,
              1000.0 / referenceMs, static_cast<unsigned long long>(reference.value().rays));
  const double ratio = referenceMs / movingMs;
  std::printf("exact reference / SH frame (moving eye): %.1fx (target >= 10: %s); static eye: %.1fx\n", ratio,
              ratio >= 10.0 ? "met" : "NOT met", referenceMs / staticMs);
  return 0;
}

// Everything measured on the session: the SH series, then the exact reference. Exit code.
int runOnSession(offscreen::Session& session, const Options& options, const Field& field,
                 const bake::Image& envImage) {
  auto environment = offscreen::uploadEnvironment(session, envImage, options.cube);
  if (!environment) {
    std::fprintf(stderr, "%s\n", environment.error().message.c_str());
    return 1;
  }
  auto object = offscreen::uploadField(session, field);
  if (!object) {
    std::fprintf(stderr, "%s: %s\n", options.field.c_str(), object.error().message.c_str());
    return 1;
  }
  std::array<float, 3> lo{}, hi{};
  offscreen::meshBounds(field.mesh, lo, hi);
  const Camera camera = offscreen::frameBounds(lo, hi, 40.0f);
  printHeader(session, field, options);
  std::array<NamedSeries, 4> runs{{{"moving eye (decompress every frame)", Series::Moving, {}},
                                   {"static eye (decompression skipped)", Series::Static, {}},
                                   {"raster only (no decompression)", Series::RasterOnly, {}},
                                   {"background only (no object)", Series::BackgroundOnly, {}}}};
  if (!runAllSeries(session, *environment.value(), *object.value(), camera, options, runs)) return 1;
  object.value().reset();
  environment.value().reset();
  if (const uint32_t messages = session.harness->messageCount(); messages) {
    std::fprintf(stderr, "%u Vulkan validation message(s)\n", messages);
    return 1;
  }
  const double moving = runs[0].result.wallMs;
  std::printf("SH path, moving eye: %.1f fps (target >= 30: %s)\n", 1000.0 / moving,
              1000.0 / moving >= 30.0 ? "met" : "NOT met");
  std::printf("SH path, static eye: %.1f fps\n", 1000.0 / runs[1].result.wallMs);

  if (!options.reference) return 0;
  return runReference(options, field, camera, envImage, moving, runs[1].result.wallMs);
}

int run(const Options& options) {
  auto read = benchmarkField(options.field, " (bake it first, see docs/performance.md)");
  if (const int* exitCode = std::get_if<int>(&read)) return *exitCode;
  const Field field = std::get<Field>(std::move(read));
  auto envImage = offscreen::loadEnvironmentImage(options.environment);
  if (!envImage) {
    std::fprintf(stderr, "%s\n", envImage.error().message.c_str());
    return 1;
  }
  harness::HarnessOptions ho;
  ho.enableValidation = options.validation;
  harness::HarnessFailure failure = harness::HarnessFailure::None;
  auto created = offscreen::createSession(ho, &failure);
  if (!created) {
    if (failure == harness::HarnessFailure::NoDevice) {
      std::printf("SKIPPED: no Vulkan device: %s\n", created.error().message.c_str());
      return 0;
    }
    std::fprintf(stderr, "%s\n", created.error().message.c_str());
    return 1;
  }
  return runOnSession(*created.value(), options, field, envImage.value());
}

// The options from the command line, or the exit code to stop with.
std::optional<int> parseArguments(int argc, char** argv, Options& options) {
  const std::vector<cli::FlagSpec> flags = withFrameFlags({
      {"frames", true, "frames a series", cli::ValueKind::Integer, {1, 10000}},
      {"env", true, "builtin or a file"},
      {"threads", true, "CPU reference threads", cli::ValueKind::Integer, {1, 1024}},
      {"no-reference", false, "no CPU reference"},
  });
  auto parsed = parseCommandLine("shrefract_reference_benchmark", argc, argv, flags,
                                 [](const char* error) { usage(error); });
  if (const int* exitCode = std::get_if<int>(&parsed)) return *exitCode;
  const cli::Args& args = std::get<cli::Args>(parsed);
  args.read("size", options.width, options.height);
  args.read("frames", options.frames);
  args.read("env", options.environment);
  args.read("threads", options.threads);
  if (const auto bad = readShadingAndFormat(args, options.shading, options.colorFormat)) return usage(bad->c_str());
  options.cube = args.has("cube-env");
  options.reference = !args.has("no-reference");
  options.validation = args.has("validation");
  if (args.positional().size() > 1) return usage(("unknown argument " + args.positional()[1]).c_str());
  if (args.positional().empty()) return usage("missing FIELD.shrf");
  options.field = args.positional()[0];
  return std::nullopt;
}

}  // namespace
}  // namespace shrefract::bench

int main(int argc, char** argv) {
  return shrefract::bench::benchmarkMain(argc, argv, shrefract::bench::parseArguments, shrefract::bench::run);
}
