#version 460
#extension GL_GOOGLE_include_directive : require
#include "shrefract/gpu_layout.h"

layout(push_constant) uniform Push { ObjectPushConstants pc; };
layout(location = 0) in vec3 inPosition;  // world space
layout(location = 1) in vec3 inNormal;    // world space, unit
layout(location = 2) in vec2 inFieldUv;   // texel coordinates of the field's sample layout

layout(location = 0) out vec3 outPosition;
layout(location = 1) out vec3 outNormal;
layout(location = 2) out vec2 outFieldUv;

void main() {
  outPosition = inPosition;
  outNormal = inNormal;
  outFieldUv = inFieldUv;
  gl_Position = pc.clipFromWorld * vec4(inPosition, 1.0);
}
