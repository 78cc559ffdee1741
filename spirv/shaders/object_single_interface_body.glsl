// Single-interface refraction: one Snell bend at the front surface, then the environment. This
// is what engines usually ship as a glass shader, and the baseline the SH field is measured against.
#include "shrefract/gpu_layout.h"
#include "environment_select.glsl"

layout(push_constant) uniform Push { ObjectPushConstants pc; };

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inFieldUv;
layout(location = 3) in float inFrontIor;
layout(location = 0) out vec4 outColor;

void main() {
  vec3 n = normalize(inNormal);
  vec3 v = normalize(inPosition - pc.eyeObject.xyz);
  // Interpolated normals can face away near silhouettes; bend them back toward the viewer.
  float cosI = -dot(v, n);
  if (cosI < 1e-4) {
    n = normalize(n + (1e-4 - cosI) * -v);
    cosI = -dot(v, n);
  }
  float ior = inFrontIor > 0.0 ? inFrontIor : pc.medium.x;
  float eta = 1.0 / ior;
  vec3 reflected = reflect(v, n);
  float fresnel = fresnelDielectric(cosI, eta);
  vec3 refracted = refract(v, n, eta);
  if (dot(refracted, refracted) == 0.0) refracted = reflected;
  // Bent in object space, looked up in world space.
  vec4 q = pc.worldFromObjectRotation;
  vec3 refractedWorld = rotateByQuaternion(q, refracted);
  vec3 reflectedWorld = rotateByQuaternion(q, reflected);
  // Derivatives in uniform control flow (fine): filtered lookups, see the field shader.
  vec3 refractedDx = dFdxFine(refractedWorld), refractedDy = dFdyFine(refractedWorld);
  vec3 reflectedDx = dFdxFine(reflectedWorld), reflectedDy = dFdyFine(reflectedWorld);
  vec3 color = (1.0 - fresnel) * lookupEnvironmentOverPixel(refractedWorld, refractedDx, refractedDy) * pc.tint.rgb;
  if (pc.medium.z > 0.5) color += fresnel * lookupEnvironmentOverPixel(reflectedWorld, reflectedDx, reflectedDy);
  outColor = vec4(color * pc.eyeObject.w, 1.0);
}
