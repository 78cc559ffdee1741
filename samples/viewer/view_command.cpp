// `shrefract view`: command line parsing and loading; the window and frame loop are in viewer.cpp.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/scene_source.h"
#include "offscreen/offscreen.h"
#include "viewer/view_state.h"
#include "viewer/viewer.h"

namespace shrefract::cli {
namespace {

using K = ValueKind;

std::vector<FlagSpec> viewFlags() {
  return sceneCommandFlags({
      {"field2", true, "a second field of the same object (e.g. the charts bake beside the split one); F toggles"},
      {"env", true, "lat-long image file or 'builtin'; repeatable; E cycles through them and builtin"},
      {"size", true, "window size WxH (default 960x640); with --screenshot, the image size", K::Size, {1, 16384},
       {1, 16384}},
      {"fov", true, "vertical field of view in degrees (default 40)", K::Real, {0, 180, true, true}},
      {"exposure", true, "linear scale applied before display (default 1)", K::Real, {0, kUnbounded, true}},
      {"absorption", true, "initial absorption scale k in exp(-tau * k) (default 1: the media as defined)", K::Real, {0, kUnbounded}},
      {"order", true, "SH fields: initial SH order (default: the baked order)", K::Integer, {0, 32}},
      {"env-taps", true, "initial taps per axis of each filtered environment lookup (default 4; T cycles)",
       K::Integer, {1, kMaxEnvironmentTapsPerAxis}},
      {"msaa", true, "the host's multisample count: 1 (default), 2, 4 or 8; silhouettes covered at N samples",
       K::Integer, {1, 8}},
      {"mode", true, "initial shading: field (default for fields) or single-interface (default for scenes)"},
      {"frames", true, "render this many frames, then exit (default: until the window closes)", K::Integer, {1, 1e8}},
      {"screenshot", true, "write the last frame to this .png or .exr at exit"},
      {"keys", true, "apply one key per frame, e.g. ']-em' (the keys below; for tests)"},
      {"device", true, "Vulkan device index (default: first)", K::Integer, {0, 1024}},
      {"no-validation", false, "do not enable the Vulkan validation layer"},
      {"no-vsync", false, "present without waiting for vertical blank where the surface allows it"},
      }, false);
}

int fail(const std::string& message, int code) {
  std::fprintf(stderr, "%s\n", message.c_str());
  return code;
}

// The steps of viewCommand() return the exit code to stop with (its line already printed), or
// nothing to go on.
using Exit = std::optional<int>;

// --env is repeatable, which Args does not support: take every occurrence out first.
Exit takeEnvFlags(int argc, char** argv, std::vector<std::string>& envSpecs, std::vector<char*>& rest) {
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (i >= 2 && a == "--env") {
      if (i + 1 >= argc) return fail("shrefract view: flag --env needs a value", 2);
      envSpecs.push_back(argv[++i]);
    } else if (i >= 2 && a.rfind("--env=", 0) == 0) {
      envSpecs.push_back(a.substr(6));
    } else {
      rest.push_back(argv[i]);
    }
  }
  return std::nullopt;
}

int printHelp(const std::vector<FlagSpec>& flags) {
  std::printf("usage: shrefract view FIELD.shrf [FIELD2.shrf] | SCENE [flags]\n"
              "  FIELD.shrf: a baked refraction field, any encoding (field and single-interface modes)\n"
              "  SCENE: builtin:NAME or a .gltf/.glb file (single-interface shading only; --allow-open as in bake)\n"
              "  The window title shows the frame time and the GPU decompression and raster times.\n%s%s",
              usageLines(flags).c_str(), viewer::keyHelp());
  return 0;
}

// The numeric flags, all checked (--ior and --tessellation too, which scenes read later) before
// any is used.
Exit readNumericFlags(const Args& args, viewer::ViewerOptions& options) {
  auto size = args.size("size");
  auto fov = args.number("fov");
  auto exposure = args.number("exposure");
  auto absorption = args.number("absorption");
  auto order = args.integer("order");
  auto taps = args.integer("env-taps");
  auto msaa = args.integer("msaa");
  auto ior = args.number("ior");
  auto tess = args.integer("tessellation");
  auto frames = args.integer("frames");
  auto device = args.integer("device");
  for (const Error* e : {size.ok() ? nullptr : &size.error(), fov.ok() ? nullptr : &fov.error(),
                         exposure.ok() ? nullptr : &exposure.error(), absorption.ok() ? nullptr : &absorption.error(),
                         order.ok() ? nullptr : &order.error(), taps.ok() ? nullptr : &taps.error(),
                         msaa.ok() ? nullptr : &msaa.error(),
                         ior.ok() ? nullptr : &ior.error(),
                         tess.ok() ? nullptr : &tess.error(), frames.ok() ? nullptr : &frames.error(),
                         device.ok() ? nullptr : &device.error()})
    if (e) return fail(e->message, 2);

  if (size.value()) {
    options.width = (*size.value())[0];
    options.height = (*size.value())[1];
  }
  // Kinds and ranges were checked by Args::parse.
  if (fov.value()) options.verticalFovDegrees = static_cast<float>(*fov.value());
  if (exposure.value()) options.exposure = static_cast<float>(*exposure.value());
  if (absorption.value()) options.absorption = static_cast<float>(*absorption.value());
  if (order.value()) options.order = static_cast<uint32_t>(*order.value());
  if (taps.value()) options.environmentTaps = static_cast<uint32_t>(*taps.value());
  if (msaa.value()) {
    const int64_t n = *msaa.value();
    if (n & (n - 1)) return fail("shrefract view: --msaa must be 1, 2, 4 or 8, got " + std::to_string(n), 2);
    options.msaa = static_cast<VkSampleCountFlagBits>(n);  // 1, 2, 4, 8 are the flag bits
  }
  if (frames.value()) options.frames = static_cast<uint32_t>(*frames.value());
  options.deviceIndex = device.value() ? static_cast<int>(*device.value()) : -1;
  return std::nullopt;
}

// How the run goes: --no-vsync, --screenshot, --keys, --no-validation.
Exit readRunFlags(const Args& args, viewer::ViewerOptions& options) {
  if (args.has("no-vsync")) options.vsync = false;
  if (auto shot = args.get("screenshot")) {
    if (!hasExtension(*shot, ".png") && !hasExtension(*shot, ".exr"))
      return fail("shrefract view: " + *shot + ": --screenshot must end in .png or .exr", 2);
    // Checked now: a missing folder fails before the window opens, not after the frames.
    if (auto writable = checkOutputPath(*shot); !writable) return fail(writable.error().message, 1);
    options.screenshot = *shot;
  }
  options.keys = args.get("keys").value_or("");
  for (char c : options.keys)
    if (!viewer::actionForCharacter(static_cast<char>(std::tolower(static_cast<unsigned char>(c)))))
      return fail(std::string("shrefract view: --keys: '") + c + "' is not a key of the viewer (see --help)", 2);
  for (char& c : options.keys) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  options.validation = !args.has("no-validation");
  return std::nullopt;
}

// --mode, and the flags that apply to one kind of input only. `first` is the first input.
Exit readShading(const Args& args, bool scene, const std::string& first, viewer::ViewerOptions& options) {
  const std::string mode = args.get("mode").value_or(scene ? "single-interface" : "field");
  if (mode != "field" && mode != "single-interface")
    return fail("shrefract view: unknown --mode '" + mode + "' (available: field, single-interface)", 2);
  if (scene && mode == "field")
    return fail("shrefract view: " + first + " has no refraction field; bake one first (shrefract bake " +
                    first + " -o FIELD.shrf) and view FIELD.shrf", 2);
  options.mode = mode == "field" ? ShadingMode::Field : ShadingMode::SingleInterface;
  // The values were checked by readNumericFlags().
  if (!scene && (args.number("ior").value() || args.integer("tessellation").value() || args.has("allow-open")))
    return fail("shrefract view: --ior, --tessellation and --allow-open apply to scenes only; a field's geometry and "
                "media are baked", 2);
  return std::nullopt;
}

Exit loadSceneInput(const Args& args, const std::string& input, viewer::ViewerOptions& options) {
  const SceneOverrides overrides = sceneOverridesFrom(args, false);
  std::vector<std::string> warnings;
  if (args.integer("tessellation").value() && input.rfind("builtin:", 0) != 0)
    return fail("shrefract view: --tessellation applies to built-in scenes only, not " + input, 2);
  auto loaded = loadScene(input, overrides, &warnings);
  // On failure the error alone: one line naming the file (the warnings led up to it).
  if (!loaded) return fail(loaded.error().message, 1);
  for (const auto& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  options.scene = std::move(loaded).value();
  options.sceneName = input;
  return std::nullopt;
}

Exit loadFields(const std::vector<std::string>& inputs, viewer::ViewerOptions& options) {
  for (const std::string& path : inputs) {
    auto field = readField(path);
    if (!field) return fail(field.error().message, 1);
    options.fields.push_back(std::move(field).value());
    options.fieldNames.push_back(path);
  }
  if (options.order && *options.order > options.fields[0].order)
    return fail("shrefract view: --order " + std::to_string(*options.order) + " is above " + inputs[0] +
                    "'s baked order " + std::to_string(options.fields[0].order), 2);
  return std::nullopt;
}

Exit loadEnvironments(std::vector<std::string> envSpecs, viewer::ViewerOptions& options) {
  // The first --env is shown first; the built-in environment is always one of the choices.
  if (std::find(envSpecs.begin(), envSpecs.end(), "builtin") == envSpecs.end()) envSpecs.push_back("builtin");
  for (const std::string& spec : envSpecs) {
    auto image = offscreen::loadEnvironmentImage(spec);
    if (!image) return fail(image.error().message, 1);
    options.environments.push_back(std::move(image).value());
    options.environmentNames.push_back(spec);
  }
  return std::nullopt;
}

}  // namespace

int viewCommand(int argc, char** argv) {
  std::vector<std::string> envSpecs;
  std::vector<char*> rest;
  if (auto exit = takeEnvFlags(argc, argv, envSpecs, rest)) return *exit;
  const std::vector<FlagSpec> kFlags = viewFlags();
  auto parsed = Args::parse("view", static_cast<int>(rest.size()), rest.data(), 2, kFlags);
  if (!parsed) return fail(parsed.error().message, 2);
  const Args& args = parsed.value();
  if (args.has("help")) return printHelp(kFlags);

  std::vector<std::string> inputs = args.positional();
  if (auto second = args.get("field2")) inputs.push_back(*second);
  if (inputs.empty() || inputs.size() > 2)
    return fail("shrefract view: expected FIELD.shrf [FIELD2.shrf] (or --field2) or one SCENE", 2);
  const bool scene = isSceneInput(inputs[0]);
  if (scene && inputs.size() != 1)
    return fail("shrefract view: a SCENE is shown alone (single-interface); a second field needs a first field", 2);
  if (!scene && inputs.size() == 2 && isSceneInput(inputs[1]))
    return fail("shrefract view: " + inputs[1] + " is a scene; only two fields can be shown together", 2);

  viewer::ViewerOptions options;
  if (auto exit = readNumericFlags(args, options)) return *exit;
  if (auto exit = readRunFlags(args, options)) return *exit;
  if (auto exit = readShading(args, scene, inputs[0], options)) return *exit;

  // Load everything from disk before opening a window, so that input errors come first.
  if (auto exit = scene ? loadSceneInput(args, inputs[0], options) : loadFields(inputs, options)) return *exit;
  if (auto exit = loadEnvironments(envSpecs, options)) return *exit;
  return viewer::runViewer(options);
}

}  // namespace shrefract::cli
