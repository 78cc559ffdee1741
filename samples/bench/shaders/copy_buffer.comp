#version 460
// Benchmark reference: a plain copy of words between storage buffers, one word per invocation,
// consecutive invocations on consecutive words. No arithmetic: the rate the memory path allows.
layout(local_size_x = 64) in;

layout(push_constant) uniform Push { uvec4 size; };  // x: word count
layout(std430, set = 0, binding = 0) readonly buffer Source { uint source[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Destination { uint words[]; };

void main() {
  uint o = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u;  // rows of groups
  if (o < size.x) words[o] = source[o];
}
