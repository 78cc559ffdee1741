// Environment lookup. Lat-long convention (docs/technique.md): +Y up,
// u = 0.5 + atan(x, -z) / (2 pi), v = acos(y) / pi; v = 0 is the top row; (0.5, 0.5) looks toward -Z.
#ifndef SHREFRACT_ENVIRONMENT_GLSL
#define SHREFRACT_ENVIRONMENT_GLSL

#include "shrefract/gpu_layout.h"

const float kShrPi = 3.14159265358979323846;

vec2 latLongUv(vec3 dir) {
  vec3 d = normalize(dir);
  float u = 0.5 + atan(d.x, -d.z) * (0.5 / kShrPi);
  float v = acos(clamp(d.y, -1.0, 1.0)) * (1.0 / kShrPi);
  return vec2(u, v);
}

// Filtered lookups (docs/technique.md). The environment has a level chain (a 2x2 box per level,
// built at upload); the level is chosen from the angle a lookup direction spans across the pixel,
// not from the sampler's own uv derivatives: those jump by a whole turn at the lat-long seam and
// know nothing of how the glass bends the rays. Mirrored by engine/reference/src/environment_lookup.cpp
// (directionFootprint, environmentLevel) and tested against it (tests/engine/environment_level_test).

// Angle (radians) spanned across the pixel by a unit direction with screen derivatives ddx, ddy:
// the larger chord, converted to its arc (a chord of 2 is a half turn). Isotropic on purpose: one
// level for both axes (textureLod), the blur of the longer axis, so that nothing aliases; the
// taps of lookupEnvironmentOverPixel (environment_select.glsl) follow each axis.
float directionFootprint(vec3 ddx, vec3 ddy) {
  float chord = max(length(ddx), length(ddy));
  return 2.0 * asin(min(0.5 * chord, 1.0));
}

// The level for a footprint of `footprint` radians, for a level 0 texel of `texelAngle` radians:
// the level whose texels span it, plus kEnvironmentLevelBias (gpu_layout.h), clamped to
// [0, maxLevel]; a footprint below one texel (or zero) is level 0.
float environmentLevel(float footprint, float texelAngle, float maxLevel) {
  return clamp(log2(max(footprint, 1e-30) / texelAngle) + kEnvironmentLevelBias, 0.0, maxLevel);
}

// Radians per level 0 texel: lat-long at the equator (2 pi / width; texels narrow toward the poles,
// where the level is then coarser than the texels need in u and right in v), a cube face on
// average (a face spans pi / 2 over its size).
float latLongTexelAngle(float width) { return 2.0 * kShrPi / width; }
float cubeTexelAngle(float faceSize) { return 0.5 * kShrPi / faceSize; }

// Lat-long lookup for a footprint of `footprint` radians (0: level 0, the sharpest).
vec3 sampleEnvironment(sampler2D env, vec3 dir, float footprint) {
  float level = environmentLevel(footprint, latLongTexelAngle(float(textureSize(env, 0).x)),
                                 float(textureQueryLevels(env) - 1));
  return textureLod(env, latLongUv(dir), level).rgb;
}

// Schlick is not enough near TIR for dense media; this is the exact unpolarized Fresnel
// reflectance for a dielectric interface, eta = n_incident / n_transmitted.
float fresnelDielectric(float cosI, float eta) {
  cosI = clamp(cosI, 0.0, 1.0);
  float sin2T = eta * eta * max(0.0, 1.0 - cosI * cosI);
  if (sin2T >= 1.0) return 1.0;
  float cosT = sqrt(1.0 - sin2T);
  float rs = (eta * cosI - cosT) / (eta * cosI + cosT);
  float rp = (cosI - eta * cosT) / (cosI + eta * cosT);
  return 0.5 * (rs * rs + rp * rp);
}

#endif
