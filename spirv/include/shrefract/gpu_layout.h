// Shared by GLSL and C++: descriptor binding numbers, push-constant layouts and constants.
// Nothing here is declared twice: shaders include this file, and so does the engine.
//
// Layout rules: push-constant blocks use std430 (the default for push constants); members are
// vec4/mat4 only, so C++ and GLSL agree on offsets without padding rules.
#ifndef SHREFRACT_GPU_LAYOUT_H
#define SHREFRACT_GPU_LAYOUT_H

#ifdef __cplusplus
#include <cstdint>
namespace shrefract::gpu {
struct vec4 { float x, y, z, w; };
struct uvec4 { uint32_t x, y, z, w; };
struct mat4 { float m[16]; };  // column-major, as in GLSL
#define SHR_CONST(name, value) inline constexpr uint32_t name = value;
#define SHR_CONSTF(name, value) inline constexpr float name = value;
#else
#define SHR_CONST(name, value) const uint name = value;
#define SHR_CONSTF(name, value) const float name = value;
#endif

// Descriptor set 0 of the raster pipelines: the environment (a sampler2D for a lat-long map, a
// samplerCube for a cube map; the shader variant is chosen by the environment's encoding).
SHR_CONST(kBindingEnvironment, 0u)
// Descriptor set 1 of the field raster pipeline: the object's distortion image (RGBA16F,
// bilinear, clamp to edge), sampled at the mesh's field texture coordinates.
SHR_CONST(kBindingDistortion, 0u)

// Environment encodings.
SHR_CONST(kEnvironmentLatLong, 0u)
SHR_CONST(kEnvironmentCube, 1u)

// Shading modes of the object pass (ObjectPushConstants.params.z).
SHR_CONST(kModeSingleInterface, 0u)
SHR_CONST(kModeField, 1u)
SHR_CONST(kModeFieldExitDirection, 2u)  // writes (exit direction, tau) instead of a colour

// Decompression compute pass, descriptor set 0 (one set per field object).
SHR_CONST(kBindingCoefficients, 0u)   // sampler2DArray: layer i = basis function i, texel (x, y)
SHR_CONST(kBindingScaleBias, 1u)      // vec4 scaleBias[2 * basisCount]: [2i] scale, [2i+1] bias
SHR_CONST(kBindingFrames, 2u)         // vec4 frames[3 * texels]: rows of M_s, texel t at 3t..3t+2
SHR_CONST(kBindingTexelKinds, 3u)     // uint kinds[(texels + 3) / 4]: byte t % 4 of word t / 4
SHR_CONST(kBindingDistortionOut, 4u)  // image2D rgba16f: xyz = exit direction, w = tau
SHR_CONST(kBindingGutters, 5u)        // uvec4 gutters[]: (target, a, b, c) texel indices

// Specialization constant of the decompression shader: the SH order L (bands 0..L evaluated).
SHR_CONST(kSpecShOrder, 0u)
// Workgroup sizes: the decompression pass covers the atlas in 8x8 tiles; the gutter pass runs one
// invocation per rule.
SHR_CONST(kDecompressLocalSize, 8u)
SHR_CONST(kGutterLocalSize, 64u)

// A decoded SH sum (or a bilinear sample of decoded directions) whose squared length is at most
// this has no direction: decompression writes the zero vector, and the raster pass then looks
// straight through the surface (the view direction).
SHR_CONSTF(kMinDirectionLength2, 1e-20f)
// Optical depth is clamped to the finite range of the RGBA16F distortion image.
SHR_CONSTF(kMaxOpticalDepth, 65504.0f)

// Texel roles as stored in the kinds buffer (the values of field.h's kTexel* constants).
SHR_CONST(kGpuTexelEmpty, 0u)
SHR_CONST(kGpuTexelSample, 1u)
SHR_CONST(kGpuTexelGutter, 2u)

// Background pass: the environment seen through the camera.
struct BackgroundPushConstants {
  mat4 worldDirFromClip;  // maps clip-space (x, y, 1, 1) to an unnormalized world direction
};

// Object pass. Vertex positions are in world space (fields are baked in world space).
struct ObjectPushConstants {
  mat4 clipFromWorld;
  vec4 eyeWorld;  // xyz: eye position; w unused
  vec4 medium;    // x: IOR of the object where the mesh has no per-vertex frontIor (0),
                  // y: absorption scale k, z: reflection on (1) or off (0)
  vec4 tint;      // rgb: attenuation colour; a unused
  vec4 params;    // x: exposure, y unused, z: shading mode, w unused
};

// Decompression and gutter passes.
struct DecompressPushConstants {
  vec4 eyeWorld;  // xyz: eye position in world space; w unused
  uvec4 size;     // x: atlas width, y: atlas height, z: number of gutter rules, w unused
};

#ifdef __cplusplus
static_assert(sizeof(BackgroundPushConstants) == 64);
static_assert(sizeof(ObjectPushConstants) <= 128, "within the 128 bytes every device offers");
static_assert(sizeof(DecompressPushConstants) == 32);
}  // namespace shrefract::gpu
#endif
#undef SHR_CONST
#undef SHR_CONSTF
#endif  // SHREFRACT_GPU_LAYOUT_H
