// The environment binding of the raster pipelines, in the encoding chosen at compile time:
// SHR_ENV_CUBE defined gives a samplerCube (world directions, Vulkan face convention), otherwise a
// lat-long sampler2D (shrefract/environment.glsl). Both are read at level 0.
#ifndef SHREFRACT_ENVIRONMENT_SELECT_GLSL
#define SHREFRACT_ENVIRONMENT_SELECT_GLSL

#include "shrefract/environment.glsl"

#ifdef SHR_ENV_CUBE
layout(set = 0, binding = kBindingEnvironment) uniform samplerCube environmentMap;
vec3 lookupEnvironment(vec3 dir) { return textureLod(environmentMap, dir, 0.0).rgb; }
#else
layout(set = 0, binding = kBindingEnvironment) uniform sampler2D environmentMap;
vec3 lookupEnvironment(vec3 dir) { return sampleEnvironment(environmentMap, dir); }
#endif

// v rotated by the unit quaternion q (x, y, z, w): object-space directions to world space.
vec3 rotateByQuaternion(vec4 q, vec3 v) { return v + 2.0 * cross(q.xyz, cross(q.xyz, v) + q.w * v); }

#endif
