// `shrefract render`: draws a scene over its environment through the engine's raster pass.
#include <chrono>
#include <cmath>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <string>

#include "cli/args.h"
#include "cli/commands.h"
#include "offscreen/offscreen.h"

namespace shrefract::cli {
namespace {

const std::vector<FlagSpec> kFlags = {
    {"output", true, "output image (.png or .exr); also -o"},
    {"env", true, "environment: 'builtin' (default) or a lat-long image file"},
    {"eye", true, "camera position x,y,z (default: frames the scene)"},
    {"target", true, "point looked at x,y,z (default: the scene's centre)"},
    {"up", true, "up vector x,y,z (default 0,1,0)"},
    {"fov", true, "vertical field of view in degrees (default 40)"},
    {"size", true, "image size WxH (default 640x480)"},
    {"mode", true, "shading: single-interface (default)"},
    {"exposure", true, "linear scale applied before writing (default 1)"},
    {"ior", true, "override the glass IOR of a built-in scene"},
    {"tessellation", true, "tessellation level of a built-in scene (0..7, default 3)"},
    {"device", true, "Vulkan device index (default: first; ctest uses lavapipe)"},
    {"no-validation", false, "do not enable the Vulkan validation layer"},
    {"json", false, "print a JSON summary on stdout"},
    {"help", false, "this text"},
};

bool hasExtension(const std::string& path, const char* ext) {
  const size_t n = std::strlen(ext);
  if (path.size() < n) return false;
  std::string tail = path.substr(path.size() - n);
  for (auto& ch : tail) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return tail == ext;
}

int fail(const Error& e, int code = 1) {
  std::fprintf(stderr, "%s\n", e.message.c_str());
  return code;
}

}  // namespace

int renderCommand(int argc, char** argv) {
  auto parsed = Args::parse("render", argc, argv, 2, kFlags);
  if (!parsed) return fail(parsed.error(), 2);
  const Args& args = parsed.value();
  if (args.has("help")) {
    std::printf("usage: shrefract render SCENE -o OUT.png|exr [flags]\n  SCENE: builtin:NAME (sphere, cube, torus, glass-of-water)\n%s",
                usageLines(kFlags).c_str());
    return 0;
  }
  if (args.positional().size() != 1)
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: expected exactly one SCENE argument"), 2);
  const auto output = args.get("output");
  if (!output) return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: missing -o OUT.png|exr"), 2);
  if (!hasExtension(*output, ".png") && !hasExtension(*output, ".exr"))
    return fail(makeError(ErrorCode::InvalidArgument, *output + ": output must end in .png or .exr"), 2);

  auto eye = args.vec3("eye");
  auto target = args.vec3("target");
  auto up = args.vec3("up");
  auto fov = args.number("fov");
  auto size = args.size("size");
  auto exposure = args.number("exposure");
  auto ior = args.number("ior");
  auto tess = args.integer("tessellation");
  auto device = args.integer("device");
  for (const Error* e : {eye.ok() ? nullptr : &eye.error(), target.ok() ? nullptr : &target.error(),
                         up.ok() ? nullptr : &up.error(), fov.ok() ? nullptr : &fov.error(),
                         size.ok() ? nullptr : &size.error(), exposure.ok() ? nullptr : &exposure.error(),
                         ior.ok() ? nullptr : &ior.error(), tess.ok() ? nullptr : &tess.error(),
                         device.ok() ? nullptr : &device.error()})
    if (e) return fail(*e, 2);
  if (fov.value() && (*fov.value() <= 0.0 || *fov.value() >= 180.0))
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: --fov must be in (0, 180)"), 2);
  const std::string mode = args.get("mode").value_or("single-interface");
  if (mode != "single-interface")
    return fail(makeError(ErrorCode::InvalidArgument, "shrefract render: unknown --mode '" + mode +
                                                          "' (available: single-interface)"), 2);

  const std::string sceneSpec = args.positional()[0];
  if (sceneSpec.rfind("builtin:", 0) != 0)
    return fail(makeError(ErrorCode::Unsupported,
                          sceneSpec + ": only built-in scenes (builtin:NAME) can be rendered by this version"));
  bake::BuiltinSceneOptions sceneOptions;
  if (tess.value()) sceneOptions.tessellation = static_cast<int>(*tess.value());
  if (ior.value()) sceneOptions.iorOverride = static_cast<float>(*ior.value());
  auto scene = bake::makeBuiltinScene(sceneSpec.substr(8), sceneOptions);
  if (!scene) return fail(makeError(scene.error().code, sceneSpec + ": " + scene.error().message));

  auto envImage = offscreen::loadEnvironmentImage(args.get("env").value_or("builtin"));
  if (!envImage) return fail(envImage.error());

  const auto start = std::chrono::steady_clock::now();
  harness::HarnessOptions options;
  options.enableValidation = !args.has("no-validation");
  options.deviceIndex = device.value() ? static_cast<int>(*device.value()) : -1;
  auto session = offscreen::createSession(options);
  if (!session) return fail(session.error());
  offscreen::Session& s = *session.value();
  auto env = offscreen::uploadEnvironment(s, envImage.value());
  if (!env) return fail(env.error());
  auto objects = offscreen::uploadScene(s, scene.value());
  if (!objects) return fail(objects.error());

  offscreen::FrameSettings frame;
  frame.camera = offscreen::defaultCamera(scene.value(), fov.value() ? static_cast<float>(*fov.value()) : 40.0f);
  if (eye.value()) frame.camera.eye = *eye.value();
  if (target.value()) frame.camera.target = *target.value();
  if (up.value()) frame.camera.up = *up.value();
  if (size.value()) {
    frame.width = (*size.value())[0];
    frame.height = (*size.value())[1];
  }
  if (exposure.value()) frame.exposure = static_cast<float>(*exposure.value());
  std::vector<Object*> drawList;
  for (auto& o : objects.value()) drawList.push_back(o.get());
  auto image = offscreen::renderFrame(s, *env.value(), drawList, frame);
  if (!image) return fail(image.error());
  objects.value().clear();
  env.value().reset();

  const uint32_t messages = s.harness->messageCount();
  if (messages != 0)
    return fail(makeError(ErrorCode::Vulkan, "shrefract render: " + std::to_string(messages) +
                                                 " Vulkan validation message(s); no image written"));
  if (auto written = bake::writeImage(*output, image.value()); !written) return fail(written.error());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (args.has("json")) {
    std::printf("{\"output\": \"%s\", \"scene\": \"%s\", \"width\": %u, \"height\": %u, \"device\": \"%s\", "
                "\"seconds\": %.4f}\n",
                output->c_str(), sceneSpec.c_str(), frame.width, frame.height, s.harness->deviceName().c_str(), seconds);
  } else {
    std::printf("rendered %s (%ux%u, %s, %s) in %.2f s -> %s\n", sceneSpec.c_str(), frame.width, frame.height,
                mode.c_str(), s.harness->deviceName().c_str(), seconds, output->c_str());
  }
  return 0;
}

}  // namespace shrefract::cli
