// Offscreen rendering through the headless harness: the path the `shrefract` tool and the image
// tests share. It plays the host engine: it owns the render targets and command buffers and
// records shrefract's passes into them.
#pragma once

#include <shrefract/bake/image.h>
#include <shrefract/bake/scene.h>
#include <shrefract/context.h>
#include <shrefract/environment.h>
#include <shrefract/harness/harness.h>
#include <shrefract/renderer.h>

#include <memory>
#include <string>
#include <vector>

namespace shrefract::offscreen {

// Everything needed to draw: the borrowed-handle context and the engine objects built on it.
struct Session {
  std::unique_ptr<harness::Harness> harness;
  std::unique_ptr<Context> context;
  ~Session();
};

Result<std::unique_ptr<Session>> createSession(const harness::HarnessOptions& options,
                                               harness::HarnessFailure* failure = nullptr);

// "builtin" gives the procedural environment; anything else is a lat-long image file.
Result<bake::Image> loadEnvironmentImage(const std::string& spec, uint32_t builtinWidth = 1024);

Result<std::unique_ptr<Environment>> uploadEnvironment(Session& session, const bake::Image& image);

// One engine Object per surface of the scene. Shading IOR: inner over outer medium.
Result<std::vector<std::unique_ptr<Object>>> uploadScene(Session& session, const bake::Scene& scene);

// A camera that frames the scene's bounds from slightly above, looking at their centre.
Camera defaultCamera(const bake::Scene& scene, float verticalFovDegrees = 40.0f);

struct FrameSettings {
  uint32_t width = 640;
  uint32_t height = 480;
  Camera camera;
  ShadingMode mode = ShadingMode::SingleInterface;
  float exposure = 1.0f;
};

// Renders the environment and the objects into a float image and reads it back.
Result<bake::Image> renderFrame(Session& session, const Environment& environment,
                                const std::vector<Object*>& objects, const FrameSettings& settings);

}  // namespace shrefract::offscreen
