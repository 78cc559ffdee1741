#version 460
#extension GL_GOOGLE_include_directive : require
#include "shrefract/gpu_layout.h"

layout(push_constant) uniform Push { ObjectPushConstants pc; };
layout(location = 0) in vec3 inPosition;  // object space
layout(location = 1) in vec3 inNormal;    // object space, unit
layout(location = 2) in vec2 inFieldUv;   // normalized atlas coordinates of the field's sample layout
layout(location = 3) in float inFrontIor; // n_inside / n_outside of this surface; 0: use pc.medium.x
layout(location = 4) in uint inTriangle;   // the triangle this vertex is the first corner of

layout(location = 0) out vec3 outPosition;
layout(location = 1) out vec3 outNormal;
layout(location = 2) out vec2 outFieldUv;
layout(location = 3) out float outFrontIor;
// Flat: the provoking (first) vertex's, which the engine makes each triangle's own
// (gpu_layout.h kBindingTriangleEdges).
layout(location = 4) flat out uint outTriangle;

void main() {
  outPosition = inPosition;
  outNormal = inNormal;
  outFieldUv = inFieldUv;
  outFrontIor = inFrontIor;
  outTriangle = inTriangle;
  gl_Position = pc.clipFromObject * vec4(inPosition, 1.0);
}
