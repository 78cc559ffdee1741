// Offscreen rendering through the headless harness: the path the `shrefract` tool and the image
// tests share. It plays the host engine: it owns the render targets and command buffers and
// records shrefract's passes into them.
#pragma once

#include <shrefract/assets/image.h>
#include <shrefract/assets/scene.h>
#include <shrefract/context.h>
#include <shrefract/decompressor.h>
#include <shrefract/environment.h>
#include <shrefract/field.h>
#include <shrefract/harness/harness.h>
#include <shrefract/renderer.h>

#include <array>
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

// Destroys the session (its engine objects, then the device and instance) and returns the number
// of validation messages over its whole life, teardown included (leaked objects are reported while
// the device goes). The engine objects created on it must be gone already.
uint32_t endSession(std::unique_ptr<Session> session);

// "builtin" gives the procedural environment; anything else is a lat-long image file.
Result<bake::Image> loadEnvironmentImage(const std::string& spec, uint32_t builtinWidth = 1024);

// Uploads a lat-long image as a lat-long environment, or converted to a cube map (faceSize 0:
// height / 2) when `cube` is set.
Result<std::unique_ptr<Environment>> uploadEnvironment(Session& session, const bake::Image& image, bool cube = false,
                                                       uint32_t faceSize = 0);

// One engine Object for a refraction field (Object::createFromField), default shading.
Result<std::unique_ptr<Object>> uploadField(Session& session, const Field& field);

// One engine Object per surface of the scene. Shading IOR: inner over outer medium.
Result<std::vector<std::unique_ptr<Object>>> uploadScene(Session& session, const bake::Scene& scene);

// A camera that frames the scene's bounds from slightly above, looking at their centre.
Camera defaultCamera(const bake::Scene& scene, float verticalFovDegrees = 40.0f);
// The same for an axis-aligned box (e.g. the bounds of a field's mesh).
Camera frameBounds(const std::array<float, 3>& min, const std::array<float, 3>& max, float verticalFovDegrees = 40.0f);
// Bounds of a field's render mesh.
void meshBounds(const FieldMesh& mesh, std::array<float, 3>& min, std::array<float, 3>& max);

struct FrameSettings {
  uint32_t width = 640;
  uint32_t height = 480;
  Camera camera;
  ShadingMode mode = ShadingMode::SingleInterface;
  float exposure = 1.0f;
  uint32_t frames = 1;  // frames rendered (the image is the last one's); for timings
  // S: the frame is rendered at S x the size and every S x S block averaged (bake::boxFilter), the
  // stratified supersampling of bake/reference_render.h (sub-sample (i, j) of pixel (x, y) is the
  // centre of pixel (S x + i, S y + j)). Timings are those of the big frame. 1..8.
  uint32_t samplesPerAxis = 1;
  // false: every field object is decompressed every frame and every object is drawn (timings of
  // the whole pass). true: what a host gets by default: the Decompressor leaves out objects whose
  // eye has not changed and objects outside the view (Decompressor's camera overload).
  bool skipWork = false;
  uint32_t environmentTapsPerAxis = RendererCreateInfo{}.environmentTapsPerAxis;
  bool silhouetteCoverage = RendererCreateInfo{}.silhouetteCoverage;  // at msaaSamples 1 only
  bool refineVolumePaths = RendererCreateInfo{}.refineVolumePaths;
  // The host's multisampling (RendererCreateInfo::sampleCount): colour and depth attachments of
  // this many samples, resolved (averaged) into the image that is read back. It covers the
  // silhouettes that one shading sample per pixel steps on (docs/technique.md, "Silhouettes and
  // MSAA"), at every sub-sample of samplesPerAxis alike. A count the device lacks is refused by
  // Renderer::create (Unsupported).
  VkSampleCountFlagBits msaaSamples = VK_SAMPLE_COUNT_1_BIT;
};

// GPU timestamps of the last frame and host wall time of every frame.
struct FrameTimings {
  bool gpuTimestamps = false;   // false when the queue does not support timestamps
  double decompressionMs = 0.0; // the Decompressor's dispatches and barriers (0 without field objects)
  double rasterMs = 0.0;        // background + objects, inside dynamic rendering
  std::vector<double> wallMs;   // per frame: record, submit, wait for the fence
  std::vector<double> gpuDecompressionMs, gpuRasterMs;  // per frame, when gpuTimestamps
  DecompressStats decompress;   // what the last frame's decompression recorded
  DrawStats draw;               // what the last frame's raster pass drew
};

// Renders the environment and the objects into a float image and reads it back. In Field mode the
// field objects are decompressed for the camera's eye before the raster pass, every frame.
// FieldExitDirection images are averaged like colours (not renormalized). Errors include a
// supersampled size beyond the device's largest image.
Result<bake::Image> renderFrame(Session& session, const Environment& environment,
                                const std::vector<Object*>& objects, const FrameSettings& settings,
                                FrameTimings* timings = nullptr);

}  // namespace shrefract::offscreen
