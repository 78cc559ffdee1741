// The environment binding of the raster pipelines, in the encoding chosen at compile time:
// SHR_ENV_CUBE defined gives a samplerCube (world directions, Vulkan face convention), otherwise a
// lat-long sampler2D (shrefract/environment.glsl). Both have a level chain; lookupEnvironment takes
// the footprint in radians of the direction across the pixel (directionFootprint; 0 reads level 0).
#ifndef SHREFRACT_ENVIRONMENT_SELECT_GLSL
#define SHREFRACT_ENVIRONMENT_SELECT_GLSL

#include "shrefract/environment.glsl"

#ifdef SHR_ENV_CUBE
layout(set = 0, binding = kBindingEnvironment) uniform samplerCube environmentMap;
vec3 lookupEnvironment(vec3 dir, float footprint) {
  float level = environmentLevel(footprint, cubeTexelAngle(float(textureSize(environmentMap, 0).x)),
                                 float(textureQueryLevels(environmentMap) - 1));
  return textureLod(environmentMap, dir, level).rgb;
}
#else
layout(set = 0, binding = kBindingEnvironment) uniform sampler2D environmentMap;
vec3 lookupEnvironment(vec3 dir, float footprint) { return sampleEnvironment(environmentMap, dir, footprint); }
#endif

// The footprint of a world direction across this pixel: fine derivatives (each 2x2 quad's own row
// and column differences), which the CPU reference mirrors by shading the quad neighbours. Call in
// uniform control flow.
float pixelFootprint(vec3 dir) { return directionFootprint(dFdxFine(dir), dFdyFine(dir)); }

// v rotated by the unit quaternion q (x, y, z, w): object-space directions to world space.
vec3 rotateByQuaternion(vec4 q, vec3 v) { return v + 2.0 * cross(q.xyz, cross(q.xyz, v) + q.w * v); }

#endif
