// An environment map on the GPU: the distant surroundings that refracted and reflected rays see.
//
// Two encodings, both RGBA16F with a level chain (environmentLevelCount levels, each the 2x2 box of
// the one above, built on the GPU at upload with linear blits), sampled trilinearly at the level
// that the angle a looked-up direction spans across the pixel calls for (docs/technique.md):
//  - lat-long (equirectangular, 2:1), +Y up, docs/technique.md and spirv/include/shrefract/
//    environment.glsl: u = 0.5 + atan2(x, -z) / (2 pi), v = acos(y) / pi, row 0 = zenith; wraps in
//    u, clamps in v;
//  - cube map: six square faces in Vulkan's order and orientation (+X, -X, +Y, -Y, +Z, -Z; see
//    CubeEnvironmentDesc), looked up with the world-space direction; seamless across faces.
// The raster pass picks its pipeline variant from the encoding; both work in every mode.
#pragma once

#include <shrefract/context.h>

#include <array>
#include <cstdint>
#include <memory>

namespace shrefract {

struct EnvironmentImpl;

struct LatLongEnvironmentDesc {
  uint32_t width = 0;            // 2:1 lat-long (equirectangular); see docs/technique.md
  uint32_t height = 0;
  const float* rgba = nullptr;   // width*height*4 linear floats, row 0 = zenith; finite, >= 0
};

// Six faces of a cube map, each faceSize x faceSize texels of 4 linear floats (finite, >= 0), in
// Vulkan's face order +X, -X, +Y, -Y, +Z, -Z. Texel (i, j) of a face (row j) has its centre at
// s = (i + 0.5) / faceSize, t = (j + 0.5) / faceSize and looks in the world direction, with
// a = 2s - 1, b = 2t - 1:
//   +X: ( 1, -b, -a)   -X: (-1, -b,  a)   +Y: ( a,  1,  b)
//   -Y: ( a, -1, -b)   +Z: ( a, -b,  1)   -Z: (-a, -b, -1)
// (the Vulkan specification's cube map face selection table, inverted).
struct CubeEnvironmentDesc {
  uint32_t faceSize = 0;
  std::array<const float*, 6> faces{};
};

enum class EnvironmentEncoding : uint32_t { LatLong = 0, Cube = 1 };

// Levels in the chain of an environment whose level 0 (a cube: each face) is width x height: down
// to 1 x 1, level l being max(1, width >> l) x max(1, height >> l).
inline uint32_t environmentLevelCount(uint32_t width, uint32_t height) {
  uint32_t levels = 1;
  for (uint32_t size = width > height ? width : height; size > 1; size >>= 1) ++levels;
  return levels;
}

class Environment {
 public:
  // Creates the image and records its upload into `cmd` (a host command buffer in the recording
  // state, on the context's queue family). The image is ready for sampling once `cmd` has executed;
  // the staging buffer is retired through the context's deferred destruction.
  // On return the image is in SHADER_READ_ONLY_OPTIMAL (after `cmd` executes).
  static Result<std::unique_ptr<Environment>> createLatLong(Context& context, const LatLongEnvironmentDesc& desc,
                                                            VkCommandBuffer cmd);
  // Creates a cube map from six faces; otherwise as createLatLong.
  static Result<std::unique_ptr<Environment>> createCube(Context& context, const CubeEnvironmentDesc& desc,
                                                         VkCommandBuffer cmd);
  // Converts a lat-long map to a cube map on the CPU (each face texel takes the bilinear lat-long
  // sample in its centre direction, wrapping in u and clamping in v as the GPU does), then
  // createCube. faceSize 0 picks height / 2, which keeps about the lat-long's resolution at the
  // equator.
  static Result<std::unique_ptr<Environment>> createCubeFromLatLong(Context& context,
                                                                    const LatLongEnvironmentDesc& desc,
                                                                    uint32_t faceSize, VkCommandBuffer cmd);
  ~Environment();  // retires its resources through the context's deferred destruction

  EnvironmentEncoding encoding() const;
  Environment(const Environment&) = delete;
  Environment& operator=(const Environment&) = delete;

 private:
  friend struct EnvironmentAccess;  // the engine's passes (engine/src)
  explicit Environment(std::unique_ptr<EnvironmentImpl> impl);
  std::unique_ptr<EnvironmentImpl> impl_;
};

}  // namespace shrefract
