// `shrefract render`: draws a refraction field (FIELD.shrf, decompressed on the GPU every frame)
// or a built-in scene (single-interface glass) over its environment through the engine's passes.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/scene_source.h"
#include <shrefract/bake/reference_render.h>
#include "offscreen/offscreen.h"

namespace shrefract::cli {
namespace {

const std::vector<FlagSpec> kFlags = {
    {"output", true, "output image (.png or .exr); also -o"},
    {"env", true, "environment: 'builtin' (default) or a lat-long image file"},
    {"cube-env", false, "look the environment up through a cube map converted from the lat-long"},
    {"eye", true, "camera position x,y,z (default: frames the scene)"},
    {"target", true, "point looked at x,y,z (default: the scene's centre)"},
    {"up", true, "up vector x,y,z (default 0,1,0)"},
    {"fov", true, "vertical field of view in degrees (default 40)"},
    {"size", true, "image size WxH (default 640x480)"},
    {"mode", true, "sh (default for .shrf; also 'field'), single-interface (default for builtin:), "
                   "exact or full-tree (CPU references traced with Embree)"},
    {"max-bounces", true, "exact mode: cap on interactions (default 16)"},
    {"path-rule", true, "exact mode: branch a path follows at every interface: highest-energy (default) or "
                        "first-refraction (refract unless totally reflected)"},
    {"throughput", false, "exact mode: weight the transmitted light by the path's Fresnel throughput"},
    {"tree-depth", true, "full-tree mode: depth of the Fresnel tree (default 8)"},
    {"spp", true, "samples per pixel N, a perfect square 1..64: sqrt(N) x sqrt(N) stratified samples, averaged "
                  "(default 1; every mode)"},
    {"threads", true, "CPU modes: worker threads (default: all cores)"},
    {"absorption", true, "absorption scale k in exp2(-tau * k) (default 1)"},
    {"exposure", true, "linear scale applied before writing (default 1)"},
    {"ior", true, "override the glass IOR of a built-in scene"},
    {"tessellation", true, "tessellation level of a built-in scene (0..7, default 3)"},
    {"frames", true, "frames rendered, for timings (default 1; the image is the last frame)"},
    {"device", true, "Vulkan device index (default: first; ctest uses lavapipe)"},
    {"no-validation", false, "do not enable the Vulkan validation layer"},
    {"json", false, "print a JSON summary with GPU and wall timings on stdout"},
    {"help", false, "this text"},
};

int fail(const Error& e, int code = 1) {
  std::fprintf(stderr, "%s\n", e.message.c_str());
  return code;
}

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (char ch : text) {
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += ch;
    } else if (static_cast<unsigned char>(ch) < 0x20) {
      char buffer[8];
      std::snprintf(buffer, sizeof(buffer), "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(ch)));
      out += buffer;
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

}  // namespace

int renderCommand(int argc, char** argv) {
  auto parsed = Args::parse("render", argc, argv, 2, kFlags);
  if (!parsed) return fail(parsed.error(), 2);
  const Args& args = parsed.value();
  if (args.has("help")) {
    std::printf("usage: shrefract render FIELD.shrf|SCENE -o OUT.png|exr [flags]\n"
                "  FIELD.shrf: a baked refraction field (shrefract bake)\n"
                "  SCENE: builtin:NAME (sphere, cube, torus, glass-of-water), single-interface shading\n%s",
                usageLines(kFlags).c_str());
    return 0;
  }
  if (args.positional().size() != 1)
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: expected exactly one FIELD.shrf or SCENE argument"), 2);
  const auto output = args.get("output");
  if (!output) return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: missing -o OUT.png|exr"), 2);
  if (!hasExtension(*output, ".png") && !hasExtension(*output, ".exr"))
    return fail(makeError(ErrorCode::InvalidArgument, *output + ": output must end in .png or .exr"), 2);

  if (auto writable = checkOutputPath(*output); !writable) return fail(writable.error());

  auto eye = args.vec3("eye");
  auto target = args.vec3("target");
  auto up = args.vec3("up");
  auto fov = args.number("fov");
  auto size = args.size("size");
  auto exposure = args.number("exposure");
  auto absorption = args.number("absorption");
  auto ior = args.number("ior");
  auto tess = args.integer("tessellation");
  auto frameCount = args.integer("frames");
  auto device = args.integer("device");
  for (const Error* e : {eye.ok() ? nullptr : &eye.error(), target.ok() ? nullptr : &target.error(),
                         up.ok() ? nullptr : &up.error(), fov.ok() ? nullptr : &fov.error(),
                         size.ok() ? nullptr : &size.error(), exposure.ok() ? nullptr : &exposure.error(),
                         absorption.ok() ? nullptr : &absorption.error(), ior.ok() ? nullptr : &ior.error(),
                         tess.ok() ? nullptr : &tess.error(), frameCount.ok() ? nullptr : &frameCount.error(),
                         device.ok() ? nullptr : &device.error()})
    if (e) return fail(*e, 2);
  if (fov.value() && (*fov.value() <= 0.0 || *fov.value() >= 180.0))
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: --fov must be in (0, 180)"), 2);
  if (absorption.value() && !(std::isfinite(*absorption.value()) && *absorption.value() >= 0.0))
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: --absorption must be finite and >= 0"), 2);
  if (frameCount.value() && (*frameCount.value() < 1 || *frameCount.value() > 100000))
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: --frames must be in 1..100000"), 2);

  const std::string sceneSpec = args.positional()[0];
  const bool builtin = sceneSpec.rfind("builtin:", 0) == 0;
  std::string mode = args.get("mode").value_or(builtin ? "single-interface" : "sh");
  if (mode == "field") mode = "sh";
  if (mode != "single-interface" && mode != "sh" && mode != "exact" && mode != "full-tree")
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: unknown --mode '" + mode +
                                                          "' (available: sh, single-interface, exact, full-tree)"), 2);
  auto maxBounces = args.integer("max-bounces");
  auto treeDepth = args.integer("tree-depth");
  auto threads = args.integer("threads");
  for (const Error* e : {maxBounces.ok() ? nullptr : &maxBounces.error(), treeDepth.ok() ? nullptr : &treeDepth.error(),
                         threads.ok() ? nullptr : &threads.error()})
    if (e) return fail(*e, 2);
  if (maxBounces.value() && (*maxBounces.value() < 1 || *maxBounces.value() > 1024))
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: --max-bounces must be 1..1024"), 2);
  if (treeDepth.value() && (*treeDepth.value() < 1 || *treeDepth.value() > 16))
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: --tree-depth must be 1..16"), 2);
  if (threads.value() && (*threads.value() < 1 || *threads.value() > 1024))
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: --threads must be 1..1024"), 2);
  auto spp = args.integer("spp");
  if (!spp) return fail(spp.error(), 2);
  uint32_t samplesPerAxis = 1;
  if (spp.value()) {
    const int64_t n = *spp.value();
    while (n <= 64 && int64_t(samplesPerAxis + 1) * (samplesPerAxis + 1) <= n) ++samplesPerAxis;
    if (n < 1 || n > 64 || int64_t(samplesPerAxis) * samplesPerAxis != n)
      return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: --spp must be a perfect square in 1..64 "
                                                        "(1, 4, 9, 16, 25, 36, 49, 64), got " + std::to_string(n)), 2);
  }
  PathRule pathRule = PathRule::HighestEnergy;
  if (const auto rule = args.get("path-rule")) {
    if (*rule == "first-refraction") pathRule = PathRule::FirstRefraction;
    else if (*rule != "highest-energy")
      return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: unknown --path-rule '" + *rule +
                                                            "' (available: highest-energy, first-refraction)"), 2);
  }
  if (mode != "exact" && (args.has("path-rule") || args.has("throughput")))
    return fail(makeError(ErrorCode::InvalidArgument, std::string("shrefract render: ") +
                                                          (args.has("path-rule") ? "--path-rule" : "--throughput") +
                                                          " applies to --mode exact only"), 2);
  if (size.value()) {
    // Checked here, before any work: the reference renderers' limit on the sub-sample grid.
    const auto wh = *size.value();
    if (uint64_t(wh[0]) * samplesPerAxis > 16384 || uint64_t(wh[1]) * samplesPerAxis > 16384)
      return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: --size " + std::to_string(wh[0]) + "x" +
                                                            std::to_string(wh[1]) + " with --spp " +
                                                            std::to_string(samplesPerAxis * samplesPerAxis) +
                                                            " needs more than 16384 samples per axis"), 2);
  }
  if (builtin && mode == "sh")
    return fail(makeError(ErrorCode::InvalidArgument,
                          "shrefract render: " + sceneSpec + " has no refraction field; bake one first "
                          "(shrefract bake " + sceneSpec + " -o FIELD.shrf) and render FIELD.shrf"), 2);
  if (!builtin && (ior.value() || tess.value()))
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: --ior and --tessellation apply to built-in "
                                                      "scenes only; a field's geometry and media are baked"), 2);

  // Load everything from disk before touching the GPU, so that input errors come first.
  std::optional<bake::Scene> scene;
  std::optional<Field> field;
  if (builtin) {
    bake::BuiltinSceneOptions sceneOptions;
    if (tess.value()) sceneOptions.tessellation = static_cast<int>(*tess.value());
    if (ior.value()) sceneOptions.iorOverride = static_cast<float>(*ior.value());
    auto made = bake::makeBuiltinScene(sceneSpec.substr(8), sceneOptions);
    if (!made) return fail(makeError(made.error().code, sceneSpec + ": " + made.error().message));
    scene = std::move(made).value();
  } else {
    auto read = readField(sceneSpec);
    if (!read) return fail(read.error());
    field = std::move(read).value();
  }
  auto envImage = offscreen::loadEnvironmentImage(args.get("env").value_or("builtin"));
  if (!envImage) return fail(envImage.error());

  if (mode == "exact" || mode == "full-tree") {
    // CPU references: the true paths through the baked (or built-in) scene, same camera.
    std::optional<bake::Scene> traced = scene;
    if (!traced) {
      auto rebuilt = loadScene(field->settings.source, {}, nullptr);
      if (!rebuilt)
        return fail(makeError(rebuilt.error().code, sceneSpec + ": cannot rebuild the baked scene: " +
                                                        rebuilt.error().message));
      traced = std::move(rebuilt).value();
    }
    auto tracer = bake::Tracer::create(*traced);
    if (!tracer) return fail(makeError(tracer.error().code, sceneSpec + ": " + tracer.error().message));
    bake::ReferenceOptions ro;
    ro.mode = mode == "exact" ? bake::ReferenceMode::Exact : bake::ReferenceMode::FullTree;
    const float fovDegrees = fov.value() ? static_cast<float>(*fov.value()) : 40.0f;
    if (field) {
      std::array<float, 3> lo{}, hi{};
      offscreen::meshBounds(field->mesh, lo, hi);
      ro.camera = offscreen::frameBounds(lo, hi, fovDegrees);
    } else {
      ro.camera = offscreen::defaultCamera(*traced, fovDegrees);
    }
    if (eye.value()) ro.camera.eye = *eye.value();
    if (target.value()) ro.camera.target = *target.value();
    if (up.value()) ro.camera.up = *up.value();
    if (size.value()) {
      ro.width = (*size.value())[0];
      ro.height = (*size.value())[1];
    }
    if (exposure.value()) ro.exposure = static_cast<float>(*exposure.value());
    if (absorption.value()) ro.absorptionScale = static_cast<float>(*absorption.value());
    if (maxBounces.value()) ro.maxBounces = static_cast<uint32_t>(*maxBounces.value());
    if (treeDepth.value()) ro.treeDepth = static_cast<uint32_t>(*treeDepth.value());
    if (threads.value()) ro.threads = static_cast<uint32_t>(*threads.value());
    ro.pathRule = pathRule;
    ro.throughput = args.has("throughput");
    ro.samplesPerAxis = samplesPerAxis;
    auto image = bake::renderReference(*tracer.value(), *traced, envImage.value(), ro);
    if (!image) return fail(image.error());
    if (auto written = bake::writeImage(*output, image.value().color); !written) return fail(written.error());
    if (args.has("json"))
      std::printf("{\"output\": %s, \"scene\": %s, \"mode\": %s, \"width\": %u, \"height\": %u, "
                  "\"spp\": %u, \"path_rule\": %s, \"throughput\": %s, \"rays\": %llu, \"cpu_seconds\": %.4f}\n",
                  jsonString(*output).c_str(), jsonString(sceneSpec).c_str(), jsonString(mode).c_str(), ro.width,
                  ro.height, samplesPerAxis * samplesPerAxis, jsonString(toString(pathRule)).c_str(),
                  ro.throughput ? "true" : "false", static_cast<unsigned long long>(image.value().rays),
                  image.value().seconds);
    else
      std::printf("rendered %s (%ux%u, %s, CPU) in %.2f s -> %s\n", sceneSpec.c_str(), ro.width, ro.height,
                  mode.c_str(), image.value().seconds, output->c_str());
    return 0;
  }

  const auto start = std::chrono::steady_clock::now();
  harness::HarnessOptions options;
  options.enableValidation = !args.has("no-validation");
  options.deviceIndex = device.value() ? static_cast<int>(*device.value()) : -1;
  auto session = offscreen::createSession(options);
  if (!session) return fail(session.error());
  offscreen::Session& s = *session.value();
  auto env = offscreen::uploadEnvironment(s, envImage.value(), args.has("cube-env"));
  if (!env) return fail(env.error());
  std::vector<std::unique_ptr<Object>> objects;
  if (scene) {
    auto uploaded = offscreen::uploadScene(s, *scene);
    if (!uploaded) return fail(uploaded.error());
    objects = std::move(uploaded).value();
  } else {
    auto uploaded = offscreen::uploadField(s, *field);
    if (!uploaded) return fail(makeError(uploaded.error().code, sceneSpec + ": " + uploaded.error().message));
    objects.push_back(std::move(uploaded).value());
  }
  for (auto& o : objects)
    if (absorption.value()) o->shading.absorptionScale = static_cast<float>(*absorption.value());

  offscreen::FrameSettings frame;
  const float fovDegrees = fov.value() ? static_cast<float>(*fov.value()) : 40.0f;
  if (scene) {
    frame.camera = offscreen::defaultCamera(*scene, fovDegrees);
  } else {
    std::array<float, 3> lo{}, hi{};
    offscreen::meshBounds(field->mesh, lo, hi);
    frame.camera = offscreen::frameBounds(lo, hi, fovDegrees);
  }
  if (eye.value()) frame.camera.eye = *eye.value();
  if (target.value()) frame.camera.target = *target.value();
  if (up.value()) frame.camera.up = *up.value();
  if (size.value()) {
    frame.width = (*size.value())[0];
    frame.height = (*size.value())[1];
  }
  if (exposure.value()) frame.exposure = static_cast<float>(*exposure.value());
  frame.mode = mode == "sh" ? ShadingMode::Field : ShadingMode::SingleInterface;
  frame.frames = frameCount.value() ? static_cast<uint32_t>(*frameCount.value()) : 1u;
  frame.samplesPerAxis = samplesPerAxis;
  std::vector<Object*> drawList;
  for (auto& o : objects) drawList.push_back(o.get());
  offscreen::FrameTimings timings;
  auto image = offscreen::renderFrame(s, *env.value(), drawList, frame, &timings);
  if (!image) return fail(image.error());
  objects.clear();
  env.value().reset();

  const uint32_t messages = s.harness->messageCount();
  if (messages != 0)
    return fail(makeError(ErrorCode::Vulkan, "shrefract render: " + std::to_string(messages) +
                                                 " Vulkan validation message(s); no image written"));
  if (auto written = bake::writeImage(*output, image.value()); !written) return fail(written.error());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::vector<double> wall = timings.wallMs;
  std::sort(wall.begin(), wall.end());
  const double wallMedian = wall.empty() ? 0.0 : wall[wall.size() / 2];
  double wallMean = 0.0;
  for (double w : wall) wallMean += w / double(wall.size());
  if (args.has("json")) {
    std::printf("{\"output\": %s, \"scene\": %s, \"mode\": %s, \"environment\": %s, \"width\": %u, "
                "\"height\": %u, \"spp\": %u, \"device\": %s, \"frames\": %zu, ",
                jsonString(*output).c_str(), jsonString(sceneSpec).c_str(), jsonString(mode).c_str(),
                jsonString(args.has("cube-env") ? "cube" : "lat-long").c_str(), frame.width, frame.height,
                samplesPerAxis * samplesPerAxis,
                jsonString(s.harness->deviceName()).c_str(), timings.wallMs.size());
    if (field)
      std::printf("\"field\": {\"order\": %u, \"width\": %u, \"height\": %u, \"quantization\": %s, "
                  "\"triangles\": %zu}, ",
                  field->order, field->width, field->height, jsonString(toString(field->quantization)).c_str(),
                  field->mesh.indices.size() / 3);
    if (timings.gpuTimestamps)
      std::printf("\"gpu_ms\": {\"decompression\": %.4f, \"raster\": %.4f}, ", timings.decompressionMs,
                  timings.rasterMs);
    else
      std::printf("\"gpu_ms\": null, ");
    std::printf("\"wall_ms\": {\"mean\": %.4f, \"median\": %.4f, \"min\": %.4f, \"max\": %.4f}, "
                "\"seconds\": %.4f}\n",
                wallMean, wallMedian, wall.empty() ? 0.0 : wall.front(), wall.empty() ? 0.0 : wall.back(), seconds);
  } else {
    std::printf("rendered %s (%ux%u, %s, %s) in %.2f s -> %s\n", sceneSpec.c_str(), frame.width, frame.height,
                mode.c_str(), s.harness->deviceName().c_str(), seconds, output->c_str());
  }
  return 0;
}

}  // namespace shrefract::cli
