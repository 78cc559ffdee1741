#version 460
// Benchmark reference: a plain copy of words between texel buffers (read through a uniform texel
// buffer, written through a storage texel buffer), one R32G32B32A32_UINT texel (four words) per
// invocation, consecutive invocations on consecutive texels. No arithmetic.
layout(local_size_x = 64) in;

layout(push_constant) uniform Push { uvec4 size; };  // x: texel count
layout(set = 0, binding = 0) uniform usamplerBuffer source;
layout(set = 0, binding = 1, rgba32ui) writeonly uniform uimageBuffer destination;

void main() {
  uint o = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u;  // rows of groups
  if (o < size.x) imageStore(destination, int(o), texelFetch(source, int(o)));
}
