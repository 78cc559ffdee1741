// `shrefract render`: draws a refraction field (FIELD.shrf, decompressed on the GPU every frame)
// or a scene (built-in or glTF; single-interface glass) over its environment through the engine's
// passes, or traces either on the CPU (exact, full tree).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include <shrefract/bake/bake.h>
#include <shrefract/trace/reference_render.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/progress.h"
#include "cli/scene_source.h"
#include "offscreen/offscreen.h"

namespace shrefract::cli {
namespace {

using K = ValueKind;

// --help lists the flags a user renders with, one short line each (docs/technique.md has the
// details); the reference renders' switches, timings and device choices are developer options
// (--dev KEY=VALUE, listed by --help-dev).
std::vector<FlagSpec> renderFlags() {
  const auto dev = developerOption;
  return sceneCommandFlags({
      {"output", true, "the image to write, .png or .exr (also -o)"},
      {"mode", true, "field (default for a .shrf), single-interface (default for a scene), exact or full-tree"},
      {"env", true, "environment: builtin (default) or a lat-long image file"},
      {"eye", true, "camera position x,y,z (default: framing the scene)"},
      {"target", true, "point looked at x,y,z (default: the scene's centre)"},
      {"up", true, "up vector x,y,z (default 0,1,0)"},
      {"fov", true, "vertical field of view in degrees (default 40)", K::Real, {0, 180, true, true}},
      {"size", true, "image size WxH (default 640x480)", K::Size, {1, 16384}, {1, 16384}},
      {"spp", true, "samples per pixel, a perfect square (default 1)", K::Integer, {1, 64}},
      {"msaa", true, "GPU modes: the multisample count, 1, 2, 4 or 8 (default 1)", K::Integer, {1, 8}},
      {"exposure", true, "linear scale applied before writing (default 1)", K::Real, {0, kUnbounded, true}},
      {"absorption", true, "absorption scale k in exp(-tau * k) (default 1)", K::Real, {0, kUnbounded}},
      {"volume-per-fragment", false, "volume fields: trace each fragment's own paths (sharper, slower)"},
      {"path-rule", true, "exact mode: highest-energy or first-refraction (default: the field's own)"},
      {"threads", true, "CPU modes: worker threads (default: all cores)", K::Integer, {1, 1024}},
      // Developer options: the reference renders' switches, timings, device choices.
      dev({"scene", true, "exact and full-tree of a field: the baked scene file where it moved to"}),
      dev({"max-bounces", true, "exact mode: cap on interactions (default 16)", K::Integer,
           {1, double(bake::kMaxBakeBounces)}}),
      dev({"throughput", false, "exact mode: weight the light by the path's Fresnel throughput"}),
      dev({"tree-depth", true, "full-tree mode: depth of the Fresnel tree (default 8)", K::Integer, {1, 16}}),
      dev({"filtered", false, "exact and full-tree: filter the environment lookups as the engine does"}),
      dev({"no-refine", false, "full-tree with --dev filtered: keep one filtered sample a pixel"}),
      dev({"env-taps", true, "taps per axis of each filtered environment lookup (default 4)", K::Integer,
           {1, kMaxEnvironmentTapsPerAxis}}),
      dev({"env-level-bias", true, "CPU modes with --dev filtered: levels added to each tap's (default -1)", K::Real,
           {-double(bake::kMaxEnvironmentLevelBias), double(bake::kMaxEnvironmentLevelBias)}}),
      dev({"no-volume-refine", false, "with --volume-per-fragment: keep 2x2 paths a pixel where they disagree"}),
      dev({"cube-env", false, "look the environment up through a cube map made from the lat-long"}),
      dev({"frames", true, "frames rendered, for timings (default 1)", K::Integer, {1, 100000}}),
      dev({"device", true, "Vulkan device index (default: the first)", K::Integer, {0, 1024}}),
      dev({"no-validation", false, "do not enable the Vulkan validation layer"}),
      }, false, "print a JSON summary with timings on stdout");
}

int fail(const Error& e, int code = 1) {
  std::fprintf(stderr, "%s\n", e.message.c_str());
  return e.code == ErrorCode::NoDevice ? kExitNoDevice : code;
}

// A finite float as JSON ("%g").
std::string jsonNumber(float value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%g", static_cast<double>(value));
  return buffer;
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


// The command line, read and checked: usage errors only, nothing loaded yet.
struct Request {
  std::string input, output, mode, env;
  bool scene = false;  // a scene (builtin: or glTF), not a field
  std::optional<std::array<float, 3>> eye, target, up;
  float fov = 40.0f;
  std::optional<std::array<uint32_t, 2>> size;
  std::optional<float> exposure, absorption;
  uint32_t samplesPerAxis = 1, frames = 1;
  uint32_t msaa = 1;  // --msaa: a power of two in 1..8
  bool volumePerFragment = false;  // --volume-per-fragment
  bool refineVolumePaths = true;  // not --dev no-volume-refine
  std::optional<uint32_t> environmentTaps;  // --dev env-taps; each mode has its own default
  std::optional<float> environmentLevelBias;  // --dev env-level-bias (CPU references only)
  std::optional<uint32_t> maxBounces, treeDepth, threads;
  int device = -1;
  PathRule pathRule = PathRule::HighestEnergy;
  SceneOverrides overrides;
  std::optional<std::string> scenePath;  // --dev scene
};

Error usage(const std::string& message) { return makeError(ErrorCode::InvalidArgument, message); }

template <class T>
std::optional<T> narrow(const std::optional<int64_t>& v) {
  return v ? std::optional<T>(static_cast<T>(*v)) : std::nullopt;
}

// --spp N -> S with S * S = N (the parser checked 1..64).
Result<uint32_t> samplesPerAxisOf(const Args& args) {
  auto spp = args.integer("spp");
  if (!spp) return spp.error();
  if (!spp.value()) return 1u;
  const int64_t n = *spp.value();
  uint32_t s = 1;
  while (int64_t(s + 1) * (s + 1) <= n) ++s;
  if (int64_t(s) * s != n)
    return usage("shrefract render: --spp must be a perfect square in 1..64 (1, 4, 9, 16, 25, 36, 49, 64), got " +
                 std::to_string(n));
  return s;
}

// Flags that apply to some inputs or modes only.
Result<void> checkApplicability(const Args& args, const Request& r) {
  const bool cpu = r.mode == "exact" || r.mode == "full-tree";
  if (r.mode != "exact" && (args.has("path-rule") || args.has("throughput")))
    return usage(std::string("shrefract render: ") + (args.has("path-rule") ? "--path-rule" : "--dev throughput") +
                 " applies to --mode exact only");
  if (!cpu && args.has("filtered"))
    return usage("shrefract render: --dev filtered applies to --mode exact and full-tree only (the GPU modes "
                 "always filter)");
  if (cpu && !args.has("filtered") && args.has("env-taps"))
    return usage("shrefract render: --dev env-taps applies to --mode exact and full-tree with --dev filtered only");
  if (cpu && args.has("msaa"))
    return usage("shrefract render: --msaa applies to the GPU modes (field, single-interface) only; the CPU modes "
                 "supersample with --spp");
  if (args.has("volume-per-fragment") && (r.scene || r.mode != "field"))
    return usage("shrefract render: --volume-per-fragment applies to --mode field of a volume field only");
  if (args.has("no-volume-refine") && (r.scene || r.mode != "field" || !args.has("volume-per-fragment")))
    return usage("shrefract render: --dev no-volume-refine applies with --volume-per-fragment only");
  if (args.has("no-refine") && !(r.mode == "full-tree" && args.has("filtered")))
    return usage("shrefract render: --dev no-refine applies to --mode full-tree with --dev filtered only");
  if (args.has("env-level-bias") && !(cpu && args.has("filtered")))
    return usage("shrefract render: --dev env-level-bias applies to --mode exact and full-tree with --dev filtered "
                 "only");
  if (r.scene && r.mode == "field")
    return usage("shrefract render: " + r.input + " is a scene and --mode " + args.get("mode").value_or("field") +
                 " needs a refraction field; bake one "
                 "(shrefract bake " + r.input + " -o FIELD.shrf) and render FIELD.shrf, or use --mode "
                 "single-interface, exact or full-tree");
  if (!r.scene && (args.has("ior") || args.has("tessellation") || args.has("allow-open")))
    return usage("shrefract render: --ior, --tessellation and --allow-open apply to scenes only; a field's "
                 "geometry and media are baked");
  if (r.scene && args.has("tessellation") && r.input.rfind("builtin:", 0) != 0)
    return usage("shrefract render: --tessellation applies to built-in scenes only, not " + r.input);
  if (args.has("scene") && (r.scene || !cpu))
    return usage("shrefract render: --dev scene applies to --mode exact or full-tree of a field");
  if (r.size && (uint64_t((*r.size)[0]) * r.samplesPerAxis > 16384 || uint64_t((*r.size)[1]) * r.samplesPerAxis > 16384))
    return usage("shrefract render: --size " + std::to_string((*r.size)[0]) + "x" + std::to_string((*r.size)[1]) +
                 " with --spp " + std::to_string(r.samplesPerAxis * r.samplesPerAxis) +
                 " needs more than 16384 samples per axis");
  return {};
}

Result<Request> readRequest(const Args& args) {
  Request r;
  if (args.positional().size() != 1)
    return usage("shrefract render: expected exactly one FIELD.shrf or SCENE argument");
  const auto output = args.get("output");
  if (!output) return usage("shrefract render: missing -o OUT.png|exr");
  if (!hasExtension(*output, ".png") && !hasExtension(*output, ".exr"))
    return usage(*output + ": output must end in .png or .exr");
  r.input = args.positional()[0];
  r.output = *output;
  r.scene = isSceneInput(r.input);
  r.env = args.get("env").value_or("builtin");
  auto eye = args.vec3("eye"), target = args.vec3("target"), up = args.vec3("up");
  for (const auto* v : {&eye, &target, &up})
    if (!*v) return v->error();
  r.eye = eye.value();
  r.target = target.value();
  r.up = up.value();
  // Kinds and ranges were checked by Args::parse.
  if (auto v = args.number("fov").value()) r.fov = static_cast<float>(*v);
  r.size = args.size("size").value();
  if (auto v = args.number("exposure").value()) r.exposure = static_cast<float>(*v);
  if (auto v = args.number("absorption").value()) r.absorption = static_cast<float>(*v);
  r.frames = narrow<uint32_t>(args.integer("frames").value()).value_or(1u);
  r.maxBounces = narrow<uint32_t>(args.integer("max-bounces").value());
  r.treeDepth = narrow<uint32_t>(args.integer("tree-depth").value());
  r.threads = narrow<uint32_t>(args.integer("threads").value());
  r.device = narrow<int>(args.integer("device").value()).value_or(-1);
  r.environmentTaps = narrow<uint32_t>(args.integer("env-taps").value());
  r.msaa = narrow<uint32_t>(args.integer("msaa").value()).value_or(1u);
  r.volumePerFragment = args.has("volume-per-fragment");
  r.refineVolumePaths = !args.has("no-volume-refine");
  if (r.msaa & (r.msaa - 1))
    return usage("shrefract render: --msaa must be 1, 2, 4 or 8, got " + std::to_string(r.msaa));
  if (auto v = args.number("env-level-bias").value()) r.environmentLevelBias = static_cast<float>(*v);
  auto spa = samplesPerAxisOf(args);
  if (!spa) return spa.error();
  r.samplesPerAxis = spa.value();
  // A field renders by its own encoding (sh, table or pca): "field" names the mode, "sh" is kept
  // for the command lines written before fields had other encodings.
  r.mode = args.get("mode").value_or(r.scene ? "single-interface" : "field");
  if (r.mode == "sh") r.mode = "field";
  if (r.mode != "single-interface" && r.mode != "field" && r.mode != "exact" && r.mode != "full-tree")
    return usage("shrefract render: unknown --mode '" + r.mode +
                 "' (available: field, single-interface, exact, full-tree)");
  if (const auto rule = args.get("path-rule")) {
    if (*rule == "first-refraction") r.pathRule = PathRule::FirstRefraction;
    else if (*rule != "highest-energy")
      return usage("shrefract render: unknown --path-rule '" + *rule + "' (available: highest-energy, first-refraction)");
  }
  r.overrides = sceneOverridesFrom(args, false);
  r.scenePath = args.get("scene");
  if (auto ok = checkApplicability(args, r); !ok) return ok.error();
  return r;
}

std::string vecText(const std::array<float, 3>& v) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%g,%g,%g", double(v[0]), double(v[1]), double(v[2]));
  return buf;
}

// A camera that can look: the eye is not the target, the up vector is not along the view, and
// every number stays finite. Named after the flags given (the defaults otherwise).
Result<void> checkCamera(const Camera& c, const Request& r) {
  const glm::vec3 eye(c.eye[0], c.eye[1], c.eye[2]), target(c.target[0], c.target[1], c.target[2]);
  const glm::vec3 up(c.up[0], c.up[1], c.up[2]);
  const glm::vec3 view = target - eye;
  const std::string eyeName = r.eye ? "--eye " + vecText(c.eye) : "the default eye " + vecText(c.eye);
  const std::string targetName = r.target ? "--target " + vecText(c.target) : "the default target " + vecText(c.target);
  if (!std::isfinite(glm::length(view)))
    return usage("shrefract render: " + eyeName + " and " + targetName + " are too far apart to render");
  if (glm::length(view) <= 1e-6f * std::max({1.0f, glm::length(eye), glm::length(target)}))
    return usage("shrefract render: " + eyeName + " is the same point as " + targetName +
                 "; the camera has no view direction");
  const float sine = glm::length(glm::cross(glm::normalize(view), up)) / std::max(glm::length(up), 1e-30f);
  if (!(glm::length(up) > 0.0f) || !(sine > 1e-4f))
    return usage("shrefract render: " + (r.up ? "--up " + vecText(c.up) : "the default up 0,1,0") +
                 " is parallel to the view from " + eyeName + " to " + targetName + "; give another --up");
  return {};
}

// What the render reads from disk, all before any long work.
struct Inputs {
  std::optional<bake::Scene> scene;  // the scene drawn or traced
  std::optional<Field> field;
  bake::Image environment;
};

// The scene of a scene input, or (CPU modes of a field) the scene the field was baked from.
Result<bake::Scene> loadTracedScene(const Request& r, const std::optional<Field>& field) {
  std::string spec = r.input;
  if (field) {
    auto resolved = bakedSceneSpec(r.input, field->settings.source, r.scenePath);
    if (!resolved) return resolved.error();
    spec = resolved.value();
  }
  std::vector<std::string> warnings;
  auto scene = loadScene(spec, r.overrides, &warnings);
  if (!scene) {
    if (!field) return scene.error();
    return makeError(scene.error().code, r.input + ": cannot rebuild the baked scene: " + scene.error().message);
  }
  for (const auto& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  return scene;
}

Result<Inputs> loadInputs(const Request& r) {
  Inputs in;
  if (!r.scene) {
    auto read = readField(r.input);
    if (!read) return read.error();
    in.field = std::move(read).value();
  }
  if (r.scene || r.mode == "exact" || r.mode == "full-tree") {
    auto scene = loadTracedScene(r, in.field);
    if (!scene) return scene.error();
    in.scene = std::move(scene).value();
  }
  auto env = offscreen::loadEnvironmentImage(r.env);
  if (!env) return env.error();
  in.environment = std::move(env).value();
  return in;
}

// The default view frames what is drawn (a field's mesh, or the scene), then the flags apply.
Camera cameraFor(const Request& r, const Inputs& in) {
  Camera camera;
  if (in.field) {
    std::array<float, 3> lo{}, hi{};
    offscreen::meshBounds(in.field->mesh, lo, hi);
    camera = offscreen::frameBounds(lo, hi, r.fov);
  } else {
    camera = offscreen::defaultCamera(*in.scene, r.fov);
  }
  if (r.eye) camera.eye = *r.eye;
  if (r.target) camera.target = *r.target;
  if (r.up) camera.up = *r.up;
  return camera;
}

// Exact and full-tree: CPU references traced with Embree, with progress on stderr.
int renderCpu(const Args& args, const Request& r, const Inputs& in, const Camera& camera) {
  auto tracer = bake::Tracer::create(*in.scene);
  if (!tracer) return fail(makeError(tracer.error().code, r.input + ": " + tracer.error().message));
  bake::ReferenceOptions ro;
  ro.mode = r.mode == "exact" ? bake::ReferenceMode::Exact : bake::ReferenceMode::FullTree;
  ro.camera = camera;
  if (r.size) {
    ro.width = (*r.size)[0];
    ro.height = (*r.size)[1];
  }
  ro.exposure = r.exposure.value_or(ro.exposure);
  ro.absorptionScale = r.absorption.value_or(ro.absorptionScale);
  ro.maxBounces = r.maxBounces.value_or(ro.maxBounces);
  ro.treeDepth = r.treeDepth.value_or(ro.treeDepth);
  ro.threads = r.threads.value_or(0u);
  // A field's exact render follows the rule the field was baked with unless --path-rule says
  // otherwise: "the exact render of the same path rule" is its ceiling.
  ro.pathRule = in.field && !args.get("path-rule") ? in.field->settings.pathRule : r.pathRule;
  ro.throughput = args.has("throughput");
  ro.filtered = args.has("filtered");
  ro.environmentTapsPerAxis = r.environmentTaps.value_or(ro.environmentTapsPerAxis);
  ro.environmentLevelBias = r.environmentLevelBias.value_or(ro.environmentLevelBias);
  ro.refine = !args.has("no-refine");
  ro.samplesPerAxis = r.samplesPerAxis;
  Progress progress("render " + r.mode, stderr);
  ro.progress = [&](const bake::ReferenceProgress& p) {
    progress.update(p.rowsDone, p.rowsTotal, p.seconds, p.seconds > 0 ? double(p.rays) / p.seconds : 0.0, "rays/s");
  };
  auto image = bake::renderReference(*tracer.value(), *in.scene, in.environment, ro);
  progress.finish();
  if (!image) return fail(image.error());
  if (auto written = bake::writeImage(r.output, image.value().color); !written) return fail(written.error());
  const auto& result = image.value();
  if (args.has("json"))
    std::printf("{\"output\": %s, \"scene\": %s, \"mode\": %s, \"width\": %u, \"height\": %u, "
                "\"spp\": %u, \"path_rule\": %s, \"throughput\": %s, \"filtered\": %s, \"env_taps\": %s, "
                "\"env_level_bias\": %s, \"refined\": %llu, \"rays\": %llu, \"cpu_seconds\": %.4f}\n",
                jsonString(r.output).c_str(), jsonString(r.input).c_str(), jsonString(r.mode).c_str(), ro.width,
                ro.height, r.samplesPerAxis * r.samplesPerAxis, jsonString(toString(ro.pathRule)).c_str(),
                ro.throughput ? "true" : "false", ro.filtered ? "true" : "false",
                ro.filtered ? std::to_string(ro.environmentTapsPerAxis).c_str() : "null",  // unfiltered: no taps
                ro.filtered ? jsonNumber(ro.environmentLevelBias).c_str() : "null",
                static_cast<unsigned long long>(result.refined), static_cast<unsigned long long>(result.rays),
                result.seconds);
  else
    std::printf("rendered %s (%ux%u, %u spp, %s, CPU) in %.2f s, %.3g rays (%.3g rays/s)%s -> %s\n", r.input.c_str(),
                ro.width, ro.height, r.samplesPerAxis * r.samplesPerAxis, r.mode.c_str(), result.seconds,
                double(result.rays), result.seconds > 0 ? double(result.rays) / result.seconds : 0.0,
                result.refined ? (", " + std::to_string(result.refined) + " sub-samples refined").c_str() : "",
                r.output.c_str());
  return 0;
}

void printGpuSummary(const Args& args, const Request& r, const Inputs& in, const offscreen::FrameSettings& frame,
                     const offscreen::FrameTimings& timings, const std::string& deviceName, double seconds) {
  std::vector<double> wall = timings.wallMs;
  std::sort(wall.begin(), wall.end());
  const double wallMedian = wall.empty() ? 0.0 : wall[wall.size() / 2];
  double wallMean = 0.0;
  for (double w : wall) wallMean += w / double(wall.size());
  if (!args.has("json")) {
    const std::string mode = in.field && r.mode == "field" ? "field, " + std::string(toString(in.field->encoding)) : r.mode;
    std::printf("rendered %s (%ux%u, %s, %s) in %.2f s -> %s\n", r.input.c_str(), frame.width, frame.height,
                mode.c_str(), deviceName.c_str(), seconds, r.output.c_str());
    return;
  }
  std::printf("{\"output\": %s, \"scene\": %s, \"mode\": %s, \"environment\": %s, \"width\": %u, "
              "\"height\": %u, \"spp\": %u, \"msaa\": %u, \"env_taps\": %u, \"volume_refine\": %s, \"device\": %s, "
              "\"frames\": %zu, ",
              jsonString(r.output).c_str(), jsonString(r.input).c_str(), jsonString(r.mode).c_str(),
              jsonString(args.has("cube-env") ? "cube" : "lat-long").c_str(), frame.width, frame.height,
              r.samplesPerAxis * r.samplesPerAxis, r.msaa, frame.environmentTapsPerAxis,
              frame.refineVolumePaths ? "true" : "false", jsonString(deviceName).c_str(), timings.wallMs.size());
  if (in.field)
    std::printf("\"field\": {\"encoding\": %s, \"order\": %u, \"table_size\": %u, \"components\": %u, "
                "\"width\": %u, \"height\": %u, \"quantization\": %s, \"triangles\": %zu}, ",
                jsonString(toString(in.field->encoding)).c_str(), in.field->order, in.field->tableSize,
                in.field->components, in.field->width, in.field->height,
                jsonString(toString(in.field->quantization)).c_str(), in.field->mesh.indices.size() / 3);
  if (timings.gpuTimestamps)
    std::printf("\"gpu_ms\": {\"decompression\": %.4f, \"raster\": %.4f}, ", timings.decompressionMs,
                timings.rasterMs);
  else
    std::printf("\"gpu_ms\": null, ");
  std::printf("\"wall_ms\": {\"mean\": %.4f, \"median\": %.4f, \"min\": %.4f, \"max\": %.4f}, "
              "\"seconds\": %.4f}\n",
              wallMean, wallMedian, wall.empty() ? 0.0 : wall.front(), wall.empty() ? 0.0 : wall.back(), seconds);
}

// A session that could not be created; exits 2 when the --dev device option is to blame.
int sessionFailure(const Request& r, const Error& error) {
  // A device index the machine does not have is a usage error naming the option.
  if (r.device >= 0 && error.code == ErrorCode::InvalidArgument)
    return fail(usage("shrefract render: --dev device=" + std::to_string(r.device) + ": " + error.message), 2);
  return fail(error);
}

// The field, or the scene's objects, on the device, with --absorption applied.
Result<std::vector<std::unique_ptr<Object>>> uploadObjects(offscreen::Session& s, const Request& r, const Inputs& in) {
  std::vector<std::unique_ptr<Object>> objects;
  if (in.field) {
    auto uploaded = offscreen::uploadField(s, *in.field);
    if (!uploaded) return makeError(uploaded.error().code, r.input + ": " + uploaded.error().message);
    objects.push_back(std::move(uploaded).value());
    if (r.volumePerFragment)
      if (auto set = objects.back()->setTracesVolumePerFragment(true); !set) return set.error();
  } else {
    auto uploaded = offscreen::uploadScene(s, *in.scene);
    if (!uploaded) return uploaded.error();
    objects = std::move(uploaded).value();
  }
  for (auto& o : objects)
    if (r.absorption) o->shading.absorptionScale = *r.absorption;
  return objects;
}

offscreen::FrameSettings frameSettingsFor(const Request& r, const Camera& camera) {
  offscreen::FrameSettings frame;
  frame.camera = camera;
  if (r.size) {
    frame.width = (*r.size)[0];
    frame.height = (*r.size)[1];
  }
  frame.exposure = r.exposure.value_or(frame.exposure);
  frame.mode = r.mode == "field" ? ShadingMode::Field : ShadingMode::SingleInterface;
  frame.frames = r.frames;
  frame.samplesPerAxis = r.samplesPerAxis;
  frame.environmentTapsPerAxis = r.environmentTaps.value_or(frame.environmentTapsPerAxis);
  frame.refineVolumePaths = r.refineVolumePaths;
  frame.msaaSamples = static_cast<VkSampleCountFlagBits>(r.msaa);  // 1, 2, 4, 8 are the flag bits
  return frame;
}

// A frame that could not be rendered; exits 2 when the --msaa flag is to blame.
int frameFailure(const Request& r, const Error& error) {
  // A sample count the device does not offer is the flag's fault: name it.
  if (r.msaa > 1 && error.code == ErrorCode::Unsupported)
    return fail(usage("shrefract render: --msaa " + std::to_string(r.msaa) + ": " + error.message), 2);
  return fail(error);
}

// SH field and single-interface modes: the engine's passes on the GPU.
int renderGpu(const Args& args, const Request& r, const Inputs& in, const Camera& camera) {
  const auto start = std::chrono::steady_clock::now();
  harness::HarnessOptions options;
  options.enableValidation = !args.has("no-validation");
  options.deviceIndex = r.device;
  auto session = offscreen::createSession(options);
  if (!session) return sessionFailure(r, session.error());
  offscreen::Session& s = *session.value();
  auto env = offscreen::uploadEnvironment(s, in.environment, args.has("cube-env"));
  if (!env) return fail(env.error());
  auto uploaded = uploadObjects(s, r, in);
  if (!uploaded) return fail(uploaded.error());
  std::vector<std::unique_ptr<Object>> objects = std::move(uploaded).value();

  const offscreen::FrameSettings frame = frameSettingsFor(r, camera);
  std::vector<Object*> drawList;
  for (auto& o : objects) drawList.push_back(o.get());
  offscreen::FrameTimings timings;
  auto image = offscreen::renderFrame(s, *env.value(), drawList, frame, &timings);
  if (!image) return frameFailure(r, image.error());
  objects.clear();
  env.value().reset();

  // Counted through the teardown too: a leak is reported only while the device goes.
  const std::string deviceName = s.harness->deviceName();
  const uint32_t messages = offscreen::endSession(std::move(session).value());
  if (messages != 0)
    return fail(makeError(ErrorCode::Vulkan, "shrefract render: " + std::to_string(messages) +
                                                 " Vulkan validation message(s); no image written"));
  if (auto written = bake::writeImage(r.output, image.value()); !written) return fail(written.error());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  printGpuSummary(args, r, in, frame, timings, deviceName, seconds);
  return 0;
}

}  // namespace

int renderCommand(int argc, char** argv) {
  const std::vector<FlagSpec> flags = renderFlags();
  auto parsed = Args::parse("render", argc, argv, 2, flags);
  if (!parsed) return fail(parsed.error(), 2);
  const Args& args = parsed.value();
  if (args.has("help")) {
    std::printf("usage: shrefract render FIELD.shrf|SCENE -o OUT.png|exr [flags]\n"
                "  FIELD.shrf: a baked refraction field (shrefract bake): every mode\n"
                "  SCENE: builtin:NAME (sphere, cube, torus, glass-of-water) or a .gltf/.glb file: the modes that\n"
                "         need no field (single-interface, exact, full-tree)\n%s"
                "developer options (--dev KEY=VALUE): shrefract render --help-dev\n",
                usageLines(flags).c_str());
    return 0;
  }
  if (args.has("help-dev")) {
    std::printf("usage: shrefract render FIELD.shrf|SCENE -o OUT.png|exr [flags] [--dev KEY[=VALUE]]...\n"
                "developer options: reference-render switches, timings and devices; they may change\n%s",
                developerUsageLines(flags).c_str());
    return 0;
  }
  auto request = readRequest(args);
  if (!request) return fail(request.error(), 2);
  const Request& r = request.value();
  // The output first: an unwritable path fails before any loading or rendering.
  if (auto writable = checkOutputPath(r.output); !writable) return fail(writable.error());
  auto inputs = loadInputs(r);
  if (!inputs) return fail(inputs.error());
  for (const auto& [given, flag] : {std::pair{r.volumePerFragment, "--volume-per-fragment"},
                                    std::pair{!r.refineVolumePaths, "--dev no-volume-refine"}})
    if (given && inputs.value().field->encoding != Encoding::Volume)
      return fail(usage(std::string("shrefract render: ") + flag + " applies to a volume field; " + r.input + " is " +
                        toString(inputs.value().field->encoding)),
                  2);
  const Camera camera = cameraFor(r, inputs.value());
  if (auto ok = checkCamera(camera, r); !ok) return fail(ok.error(), 2);
  if (r.mode == "exact" || r.mode == "full-tree") return renderCpu(args, r, inputs.value(), camera);
  return renderGpu(args, r, inputs.value(), camera);
}

}  // namespace shrefract::cli
