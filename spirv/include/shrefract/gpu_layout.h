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
struct mat4 { float m[16]; };  // column-major, as in GLSL
#define SHR_CONST(name, value) inline constexpr uint32_t name = value;
#else
#define SHR_CONST(name, value) const uint name = value;
#endif

// Descriptor set 0 of the raster pipelines: the environment.
SHR_CONST(kBindingEnvironment, 0u)

// Environment encodings (EnvironmentPush / ObjectPushConstants .params.w).
SHR_CONST(kEnvironmentLatLong, 0u)

// Shading modes of the object pass (ObjectPushConstants.params.z).
SHR_CONST(kModeSingleInterface, 0u)

// Background pass: the environment seen through the camera.
struct BackgroundPushConstants {
  mat4 worldDirFromClip;  // maps clip-space (x, y, 1, 1) to an unnormalized world direction
};

// Object pass. Vertex positions are in world space (fields are baked in world space).
struct ObjectPushConstants {
  mat4 clipFromWorld;
  vec4 eyeWorld;  // xyz: eye position; w unused
  vec4 medium;    // x: IOR of the object, y: absorption scale k, z: reflection on (1) or off (0)
  vec4 tint;      // rgb: attenuation colour; a unused
  vec4 params;    // x: exposure, y, z: shading mode, w unused
};

#ifdef __cplusplus
static_assert(sizeof(BackgroundPushConstants) == 64);
static_assert(sizeof(ObjectPushConstants) <= 128, "within the 128 bytes every device offers");
}  // namespace shrefract::gpu
#endif
#undef SHR_CONST
#endif  // SHREFRACT_GPU_LAYOUT_H
