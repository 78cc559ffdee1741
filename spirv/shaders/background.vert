#version 460
#extension GL_GOOGLE_include_directive : require
#include "shrefract/gpu_layout.h"

layout(push_constant) uniform Push { BackgroundPushConstants pc; };
layout(location = 0) out vec3 outDirection;

void main() {
  // One triangle covering the viewport: (-1,-1), (3,-1), (-1,3).
  vec2 clip = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2) * 2.0 - 1.0;
  outDirection = (pc.worldDirFromClip * vec4(clip, 1.0, 1.0)).xyz;
  // At the far plane, so host geometry drawn before or after with depth testing stays in front.
  gl_Position = vec4(clip, 1.0, 1.0);
}
