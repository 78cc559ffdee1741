// Evaluates the SH basis of order `order` for every direction with spirv/include/shrefract/sh.glsl,
// either through the streaming macro or through shEvaluate into an array (push constant
// useArray), and writes basisCount(order) floats per direction. Used by sh_gpu_test.
#version 460
#extension GL_GOOGLE_include_directive : require

layout(local_size_x = 64) in;

#define SH_GLSL_MAX_BASIS 441  // order 20
#include "shrefract/sh.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Directions {
  vec4 directions[];  // xyz; w unused
};
layout(std430, set = 0, binding = 1) writeonly buffer Values {
  float values[];  // basisCount(order) per direction
};
layout(push_constant) uniform Push {
  uint count;     // number of directions
  int order;      // 0 .. 20
  uint useArray;  // 0: SH_FOR_EACH_BASIS, 1: shEvaluate
} pc;

void main() {
  uint id = gl_GlobalInvocationID.x;
  if (id >= pc.count) return;
  vec3 dir = directions[id].xyz;
  int n = shBasisCount(pc.order);
  uint base = id * uint(n);
  if (pc.useArray != 0u) {
    float Y[SH_GLSL_MAX_BASIS];
    shEvaluate(dir, pc.order, Y);
    for (int i = 0; i < n; ++i) values[base + uint(i)] = Y[i];
  } else {
#define STORE(i, y) values[base + uint(i)] = (y)
    SH_FOR_EACH_BASIS(dir, pc.order, STORE)
#undef STORE
  }
}
