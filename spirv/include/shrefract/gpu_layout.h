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

// Decompression compute pass, descriptor set 0 (one set per field object). Only sample texels are
// stored and decompressed: sample s (0 <= s < sampleCount, in increasing texel order) is texel
// sampleTexels[s]. Empty texels of the distortion image stay as createFromField cleared them (zero);
// gutter texels are written by the gutter pass.
//
// Coefficients: one invocation decompresses kDecompressSamplesPerInvocation = 4 consecutive
// samples and reads, per basis function i and channel c, one word (U8: that channel's byte of its
// 4 samples) or two (F16: the halves). The values form planes, one per (i, c) at p = i * channels +
// c (3 channels: x, y, z; 4: and tau), each holding paddedSamples = sampleCount rounded up to a
// multiple of 4 values (padding zero): value (p, s) is number p * paddedSamples + s. Consecutive
// invocations read consecutive words of a plane, and nothing is stored for channels a field does
// not have. (Measured on llvmpipe, docs/performance.md: faster than one invocation per sample
// reading its own 3 or 4 bytes, and than blocks holding a workgroup's planes contiguously.) Values
// are bytes (U8: value = bias + scale * q / 255) or binary16 (F16), read as uint words
// (little-endian) through an R32_UINT texel buffer view (a storage buffer when the words exceed the
// device's maxTexelBufferElements, kSpecCoefficientsStorage: on llvmpipe a texel fetch is one
// vector gather, a storage-buffer read one load per lane).
SHR_CONST(kBindingCoefficients, 0u)     // usamplerBuffer (R32_UINT): the planes above
SHR_CONST(kBindingScaleBias, 1u)        // uniform: vec4 scaleBias[2 * basisCount]: [2i] scale / 255, [2i+1] bias
SHR_CONST(kBindingFrames, 2u)           // vec4 frames[3 * sampleCount]: rows of M_s, sample s at 3s..3s+2
SHR_CONST(kBindingSampleTexels, 3u)     // uint sampleTexels[sampleCount]: texel index y * width + x
SHR_CONST(kBindingDistortionOut, 4u)    // image2D rgba16f: xyz = exit direction, w = tau
SHR_CONST(kBindingGutters, 5u)          // uvec4 gutters[]: (target, a, b, c) texel indices
SHR_CONST(kBindingScaleBiasStorage, 6u) // the scale/bias table as a storage buffer (tables too big for a UBO)
SHR_CONST(kBindingCoefficientsStorage, 7u) // uint coefficients[]: the planes as a storage buffer

// Specialization constants of the decompression shader: the SH order L (bands 0..L evaluated),
// the stored channels (3: no optical depth, nothing of it read or summed; 4), the quantization,
// and where the scale/bias table is read from (false: the uniform buffer, when its 32 bytes per
// basis function fit in kMaxUniformScaleBiasBytes, orders up to 21; true: the storage buffer).
SHR_CONST(kSpecShOrder, 0u)
SHR_CONST(kSpecChannels, 1u)
SHR_CONST(kSpecQuantization, 2u)
SHR_CONST(kSpecScaleBiasStorage, 3u)
SHR_CONST(kSpecCoefficientsStorage, 4u)  // true: read the coefficients from the storage buffer
// Largest scale/bias table read as a uniform buffer: the maxUniformBufferRange every device offers,
// so that the choice (and the code path) is the same on every device.
SHR_CONST(kMaxUniformScaleBiasBytes, 16384u)
SHR_CONST(kQuantizationU8, 0u)   // field.h Quantization::U8
SHR_CONST(kQuantizationF16, 1u)  // field.h Quantization::F16
// Workgroup sizes: the decompression pass runs one invocation per 4 samples, 64 to a workgroup
// (whole subgroups on every device: 8 x 8 SIMD lanes on llvmpipe, 2 x 32 on NVIDIA, 1 x 64 on AMD);
// the gutter pass runs one invocation per rule.
SHR_CONST(kDecompressSamplesPerInvocation, 4u)
SHR_CONST(kDecompressLocalSize, 64u)
SHR_CONST(kGutterLocalSize, 64u)
// Both passes dispatch at most this many workgroups in x (the limit every device offers is 65535)
// and the rest as further rows in y; the shaders number invocations row after row.
SHR_CONST(kMaxDispatchGroupsX, 32768u)

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
  uvec4 size;     // x: atlas width, y: atlas height, z: number of gutter rules, w: sample count
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
