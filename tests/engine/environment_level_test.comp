// Evaluates the environment level selection of spirv/include/shrefract/environment.glsl for given
// screen derivatives: per case, directionFootprint(ddx, ddy) and environmentLevel(footprint,
// texelAngle, maxLevel). Used by environment_level_test.
#version 460
#extension GL_GOOGLE_include_directive : require

layout(local_size_x = 64) in;

#include "shrefract/environment.glsl"

struct Case {
  vec4 ddx;     // xyz
  vec4 ddy;     // xyz
  vec4 params;  // x: texel angle (radians), y: max level
};
layout(std430, set = 0, binding = 0) readonly buffer Cases { Case cases[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Results { vec2 results[]; };  // footprint, level
layout(push_constant) uniform Push { uint count; } pc;

void main() {
  uint id = gl_GlobalInvocationID.x;
  if (id >= pc.count) return;
  Case c = cases[id];
  float footprint = directionFootprint(c.ddx.xyz, c.ddy.xyz);
  results[id] = vec2(footprint, environmentLevel(footprint, c.params.x, c.params.y));
}
