// Environment lookup. Lat-long convention (docs/environment-maps.md): +Y up,
// u = 0.5 + atan(x, -z) / (2 pi), v = acos(y) / pi; v = 0 is the top row; (0.5, 0.5) looks toward -Z.
#ifndef SHREFRACT_ENVIRONMENT_GLSL
#define SHREFRACT_ENVIRONMENT_GLSL

const float kShrPi = 3.14159265358979323846;

vec2 latLongUv(vec3 dir) {
  vec3 d = normalize(dir);
  float u = 0.5 + atan(d.x, -d.z) * (0.5 / kShrPi);
  float v = acos(clamp(d.y, -1.0, 1.0)) * (1.0 / kShrPi);
  return vec2(u, v);
}

// Level 0 always: the lat-long wrap in u would make derivative-based LOD pick the
// smallest mip along the seam.
vec3 sampleEnvironment(sampler2D env, vec3 dir) {
  return textureLod(env, latLongUv(dir), 0.0).rgb;
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
