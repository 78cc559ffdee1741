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

const std::vector<FlagSpec> kFlags = {
    {"field2", true, "a second field of the same object (e.g. the charts bake beside the split one); F toggles"},
    {"env", true, "lat-long image file or 'builtin'; repeatable; E cycles through them and builtin"},
    {"size", true, "window size WxH (default 960x640); with --screenshot, the image size"},
    {"fov", true, "vertical field of view in degrees (default 40)"},
    {"exposure", true, "linear scale applied before display (default 1)"},
    {"absorption", true, "initial absorption scale k in exp2(-tau * k) (default 1)"},
    {"order", true, "initial SH order (default: the baked order)"},
    {"mode", true, "initial shading: field (default for fields) or single-interface"},
    {"ior", true, "override the glass IOR of a built-in scene"},
    {"tessellation", true, "tessellation level of a built-in scene (0..7, default 3)"},
    {"frames", true, "render this many frames, then exit (default: until the window closes)"},
    {"screenshot", true, "write the last frame to this .png or .exr at exit"},
    {"keys", true, "apply one key per frame, e.g. ']-em' (the keys below; for tests)"},
    {"device", true, "Vulkan device index (default: first)"},
    {"no-validation", false, "do not enable the Vulkan validation layer"},
    {"no-vsync", false, "present without waiting for vertical blank where the surface allows it"},
    {"help", false, "this text"},
};

int fail(const std::string& message, int code) {
  std::fprintf(stderr, "%s\n", message.c_str());
  return code;
}

bool endsWith(const std::string& text, const char* suffix) {
  const size_t n = std::strlen(suffix);
  if (text.size() < n) return false;
  std::string tail = text.substr(text.size() - n);
  for (auto& ch : tail) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return tail == suffix;
}

bool isScene(const std::string& spec) {
  return spec.rfind("builtin:", 0) == 0 || endsWith(spec, ".gltf") || endsWith(spec, ".glb");
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
  auto parsed = Args::parse("view", static_cast<int>(rest.size()), rest.data(), 2, kFlags);
  if (!parsed) return fail(parsed.error().message, 2);
  const Args& args = parsed.value();
  if (args.has("help")) {
    std::printf("usage: shrefract view FIELD.shrf [FIELD2.shrf] | SCENE [flags]\n"
                "  FIELD.shrf: a baked refraction field (SH and single-interface modes)\n"
                "  SCENE: builtin:NAME or a .gltf/.glb file (single-interface shading only)\n"
                "  The window title shows the frame time and the GPU decompression and raster times.\n%s%s",
                usageLines(kFlags).c_str(), viewer::keyHelp());
    return 0;
  }

  std::vector<std::string> inputs = args.positional();
  if (auto second = args.get("field2")) inputs.push_back(*second);
  if (inputs.empty() || inputs.size() > 2)
    return fail("shrefract view: expected FIELD.shrf [FIELD2.shrf] (or --field2) or one SCENE", 2);
  const bool scene = isScene(inputs[0]);
  if (scene && inputs.size() != 1)
    return fail("shrefract view: a SCENE is shown alone (single-interface); a second field needs a first field", 2);
  if (!scene && inputs.size() == 2 && isScene(inputs[1]))
    return fail("shrefract view: " + inputs[1] + " is a scene; only two fields can be shown together", 2);

  auto size = args.size("size");
  auto fov = args.number("fov");
  auto exposure = args.number("exposure");
  auto absorption = args.number("absorption");
  auto order = args.integer("order");
  auto ior = args.number("ior");
  auto tess = args.integer("tessellation");
  auto frames = args.integer("frames");
  auto device = args.integer("device");
  for (const Error* e : {size.ok() ? nullptr : &size.error(), fov.ok() ? nullptr : &fov.error(),
                         exposure.ok() ? nullptr : &exposure.error(), absorption.ok() ? nullptr : &absorption.error(),
                         order.ok() ? nullptr : &order.error(), ior.ok() ? nullptr : &ior.error(),
                         tess.ok() ? nullptr : &tess.error(), frames.ok() ? nullptr : &frames.error(),
                         device.ok() ? nullptr : &device.error()})
    if (e) return fail(e->message, 2);

  viewer::ViewerOptions options;
  if (size.value()) {
    options.width = (*size.value())[0];
    options.height = (*size.value())[1];
  }
  if (options.width < 1 || options.height < 1 || options.width > 16384 || options.height > 16384)
    return fail("shrefract view: --size must be between 1x1 and 16384x16384", 2);
  if (fov.value()) {
    if (*fov.value() <= 0.0 || *fov.value() >= 180.0) return fail("shrefract view: --fov must be in (0, 180)", 2);
    options.verticalFovDegrees = static_cast<float>(*fov.value());
  }
  if (exposure.value()) {
    if (!(*exposure.value() > 0.0)) return fail("shrefract view: --exposure must be > 0", 2);
    options.exposure = static_cast<float>(*exposure.value());
  }
  if (absorption.value()) {
    if (!(*absorption.value() >= 0.0)) return fail("shrefract view: --absorption must be >= 0", 2);
    options.absorption = static_cast<float>(*absorption.value());
  }
  if (order.value()) {
    if (*order.value() < 0 || *order.value() > 32) return fail("shrefract view: --order must be in 0..32", 2);
    options.order = static_cast<uint32_t>(*order.value());
  }
  if (frames.value()) {
    if (*frames.value() < 1 || *frames.value() > 100000000)
      return fail("shrefract view: --frames must be in 1..100000000", 2);
    options.frames = static_cast<uint32_t>(*frames.value());
  }
  if (args.has("no-vsync")) options.vsync = false;
  if (auto shot = args.get("screenshot")) {
    if (!endsWith(*shot, ".png") && !endsWith(*shot, ".exr"))
      return fail("shrefract view: " + *shot + ": --screenshot must end in .png or .exr", 2);
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
  if (!scene && (ior.value() || tess.value()))
    return fail("shrefract view: --ior and --tessellation apply to scenes only; a field's geometry and media are baked", 2);

  // Load everything from disk before opening a window, so that input errors come first.
  if (scene) {
    SceneOverrides overrides;
    if (ior.value()) overrides.ior = static_cast<float>(*ior.value());
    if (tess.value()) overrides.tessellation = static_cast<int>(*tess.value());
    std::vector<std::string> warnings;
    auto loaded = loadScene(inputs[0], overrides, &warnings);
    for (const auto& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    if (!loaded) return fail(loaded.error().message, 1);
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
