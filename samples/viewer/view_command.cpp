// `shrefract view`: command line parsing and loading; the window and frame loop are in viewer.cpp.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
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

// Every flag once: its kind and range are what the parser checks and what --help prints.
std::vector<FlagSpec> viewFlags() {
  std::vector<FlagSpec> flags = {
      {"field2", true, "a second field of the same object (e.g. the charts bake beside the split one); F toggles"},
      {"env", true, "lat-long image file or 'builtin'; repeatable; E cycles through them and builtin"},
      {"size", true, "window size WxH (default 960x640); with --screenshot, the image size", K::Size, {1, 16384},
       {1, 16384}},
      {"fov", true, "vertical field of view in degrees (default 40)", K::Real, {0, 180, true, true}},
      {"exposure", true, "linear scale applied before display (default 1)", K::Real, {0, kUnbounded, true}},
      {"absorption", true, "initial absorption scale k in exp(-tau * k) (default 1: the media as defined)", K::Real, {0, kUnbounded}},
      {"order", true, "initial SH order (default: the baked order)", K::Integer, {0, 32}},
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
  };
  for (auto& f : sceneFlags(false)) flags.push_back(f);
  flags.push_back({"help", false, "this text"});
  return flags;
}

int fail(const std::string& message, int code) {
  std::fprintf(stderr, "%s\n", message.c_str());
  return code;
}

}  // namespace

int viewCommand(int argc, char** argv) {
  // --env is repeatable, which Args does not support: take every occurrence out first.
  std::vector<std::string> envSpecs;
  std::vector<char*> rest;
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
  const std::vector<FlagSpec> kFlags = viewFlags();
  auto parsed = Args::parse("view", static_cast<int>(rest.size()), rest.data(), 2, kFlags);
  if (!parsed) return fail(parsed.error().message, 2);
  const Args& args = parsed.value();
  if (args.has("help")) {
    std::printf("usage: shrefract view FIELD.shrf [FIELD2.shrf] | SCENE [flags]\n"
                "  FIELD.shrf: a baked refraction field (SH and single-interface modes)\n"
                "  SCENE: builtin:NAME or a .gltf/.glb file (single-interface shading only; --allow-open as in bake)\n"
                "  The window title shows the frame time and the GPU decompression and raster times.\n%s%s",
                usageLines(kFlags).c_str(), viewer::keyHelp());
    return 0;
  }

  std::vector<std::string> inputs = args.positional();
  if (auto second = args.get("field2")) inputs.push_back(*second);
  if (inputs.empty() || inputs.size() > 2)
    return fail("shrefract view: expected FIELD.shrf [FIELD2.shrf] (or --field2) or one SCENE", 2);
  const bool scene = isSceneInput(inputs[0]);
  if (scene && inputs.size() != 1)
    return fail("shrefract view: a SCENE is shown alone (single-interface); a second field needs a first field", 2);
  if (!scene && inputs.size() == 2 && isSceneInput(inputs[1]))
    return fail("shrefract view: " + inputs[1] + " is a scene; only two fields can be shown together", 2);

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

  viewer::ViewerOptions options;
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
  options.deviceIndex = device.value() ? static_cast<int>(*device.value()) : -1;
  options.validation = !args.has("no-validation");
  const std::string mode = args.get("mode").value_or(scene ? "single-interface" : "field");
  if (mode != "field" && mode != "single-interface")
    return fail("shrefract view: unknown --mode '" + mode + "' (available: field, single-interface)", 2);
  if (scene && mode == "field")
    return fail("shrefract view: " + inputs[0] + " has no refraction field; bake one first (shrefract bake " +
                    inputs[0] + " -o FIELD.shrf) and view FIELD.shrf", 2);
  options.mode = mode == "field" ? ShadingMode::Field : ShadingMode::SingleInterface;
  if (!scene && (ior.value() || tess.value() || args.has("allow-open")))
    return fail("shrefract view: --ior, --tessellation and --allow-open apply to scenes only; a field's geometry and "
                "media are baked", 2);

  // Load everything from disk before opening a window, so that input errors come first.
  if (scene) {
    const SceneOverrides overrides = sceneOverridesFrom(args, false);
    std::vector<std::string> warnings;
    if (tess.value() && inputs[0].rfind("builtin:", 0) != 0)
      return fail("shrefract view: --tessellation applies to built-in scenes only, not " + inputs[0], 2);
    auto loaded = loadScene(inputs[0], overrides, &warnings);
    // On failure the error alone: one line naming the file (the warnings led up to it).
    if (!loaded) return fail(loaded.error().message, 1);
    for (const auto& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    options.scene = std::move(loaded).value();
    options.sceneName = inputs[0];
  } else {
    for (const std::string& path : inputs) {
      auto field = readField(path);
      if (!field) return fail(field.error().message, 1);
      options.fields.push_back(std::move(field).value());
      options.fieldNames.push_back(path);
    }
    if (options.order && *options.order > options.fields[0].order)
      return fail("shrefract view: --order " + std::to_string(*options.order) + " is above " + inputs[0] +
                      "'s baked order " + std::to_string(options.fields[0].order), 2);
  }
  // The first --env is shown first; the built-in environment is always one of the choices.
  if (std::find(envSpecs.begin(), envSpecs.end(), "builtin") == envSpecs.end()) envSpecs.push_back("builtin");
  for (const std::string& spec : envSpecs) {
    auto image = offscreen::loadEnvironmentImage(spec);
    if (!image) return fail(image.error().message, 1);
    options.environments.push_back(std::move(image).value());
    options.environmentNames.push_back(spec);
  }
  return viewer::runViewer(options);
}

}  // namespace shrefract::cli
