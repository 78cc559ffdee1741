#version 460
// Benchmark reference: a plain copy of a coefficient image (2D array, one layer per basis
// function, the format the engine uploads) into a storage buffer, every texel of every layer read
// once with texelFetch and written once. No arithmetic: the rate the memory path allows.
layout(local_size_x = 8, local_size_y = 8) in;

// x: width, y: height, z: layers, w: 1 for RGBA16F (two words per texel), 0 for RGBA8 (one).
layout(push_constant) uniform Push { uvec4 size; };
layout(set = 0, binding = 0) uniform sampler2DArray source;
layout(std430, set = 0, binding = 1) writeonly buffer Destination { uint words[]; };

void main() {
  uvec2 p = gl_GlobalInvocationID.xy;
  if (p.x >= size.x || p.y >= size.y) return;
  uint texels = size.x * size.y;
  uint t = p.y * size.x + p.x;
  for (uint i = 0u; i < size.z; ++i) {
    vec4 v = texelFetch(source, ivec3(p, int(i)), 0);
    uint o = i * texels + t;
    if (size.w == 0u) {
      words[o] = packUnorm4x8(v);
    } else {
      words[2u * o] = packHalf2x16(v.xy);
      words[2u * o + 1u] = packHalf2x16(v.zw);
    }
  }
}
