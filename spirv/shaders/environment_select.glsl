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

// Taps per axis of lookupEnvironmentOverPixel, chosen per renderer (RendererCreateInfo).
layout(constant_id = kSpecEnvironmentTaps) const uint ENVIRONMENT_TAPS = kEnvironmentTapsPerAxis;

// Where tap i of n sits along one of the pixel's axes, in (-1/2, 1/2): the centre of its cell.
float tapOffset(uint i, float n) { return (float(i) + 0.5) / n - 0.5; }

// The environment averaged over the pixel for a direction `dir` with screen derivatives ddx, ddy
// (fine: each 2x2 quad's own row and column differences, which the CPU reference mirrors by
// shading the quad neighbours; take them in uniform control flow): ENVIRONMENT_TAPS^2 taps at the
// centres of the cells of the parallelogram dir + a ddx + b ddy, a and b in (-1/2, 1/2), each read
// at the level of one cell's footprint (one tap: the whole footprint, kOneTapFootprintScale
// finer). A tap that cancels to zero (derivatives as long as a half turn) reads dir. Zero
// derivatives read level 0 once.
vec3 lookupEnvironmentOverPixel(vec3 dir, vec3 ddx, vec3 ddy) {
  if (ddx == vec3(0.0) && ddy == vec3(0.0)) return lookupEnvironment(dir, 0.0);
  float n = float(ENVIRONMENT_TAPS);
  float footprint = directionFootprint(ddx / n, ddy / n);
  if (ENVIRONMENT_TAPS == 1u) return lookupEnvironment(dir, footprint * kOneTapFootprintScale);
  vec3 sum = vec3(0.0);
  for (uint j = 0u; j < ENVIRONMENT_TAPS; ++j) {
    for (uint i = 0u; i < ENVIRONMENT_TAPS; ++i) {
      float a = tapOffset(i, n), b = tapOffset(j, n);
      vec3 tap = dir + a * ddx + b * ddy;
      sum += lookupEnvironment(dot(tap, tap) > 1e-12 ? tap : dir, footprint);
    }
  }
  return sum / (n * n);
}

// v rotated by the unit quaternion q (x, y, z, w): object-space directions to world space.
vec3 rotateByQuaternion(vec4 q, vec3 v) { return v + 2.0 * cross(q.xyz, cross(q.xyz, v) + q.w * v); }

#endif
