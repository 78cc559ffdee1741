#version 460
// Decompression in data space: for every sample texel of the atlas, the eye goes into the
// sample's frame (w = M_s (eye, 1), w.z clamped to >= 0, then normalized by the SH evaluator), and
// sum_i c_i Y_i(w) over the basis functions of the field's order gives the exit direction
// (normalized) and the optical depth. Empty and gutter texels are written as zero; the gutter pass
// fills the latter. Mirrored by engine/src/reference/cpu_reference.cpp (decodeTexel).
#extension GL_GOOGLE_include_directive : require
#include "shrefract/gpu_layout.h"
#include "shrefract/sh.glsl"

// The field's SH order: only bands 0..SH_ORDER are evaluated (the loops fold for a constant).
layout(constant_id = kSpecShOrder) const int SH_ORDER = 8;
layout(local_size_x = kDecompressLocalSize, local_size_y = kDecompressLocalSize) in;

layout(push_constant) uniform Push { DecompressPushConstants pc; };
layout(set = 0, binding = kBindingCoefficients) uniform sampler2DArray coefficients;
layout(std430, set = 0, binding = kBindingScaleBias) readonly buffer ScaleBias { vec4 scaleBias[]; };
layout(std430, set = 0, binding = kBindingFrames) readonly buffer Frames { vec4 frames[]; };
layout(std430, set = 0, binding = kBindingTexelKinds) readonly buffer Kinds { uint kinds[]; };
layout(set = 0, binding = kBindingDistortionOut, rgba16f) uniform writeonly image2D distortion;

void main() {
  uvec2 p = gl_GlobalInvocationID.xy;
  if (p.x >= pc.size.x || p.y >= pc.size.y) return;
  uint t = p.y * pc.size.x + p.x;
  uint kind = (kinds[t >> 2u] >> ((t & 3u) * 8u)) & 0xffu;
  vec4 result = vec4(0.0);
  if (kind == kGpuTexelSample) {
    vec4 eye = vec4(pc.eyeWorld.xyz, 1.0);
    vec3 w = vec3(dot(frames[3u * t], eye), dot(frames[3u * t + 1u], eye), dot(frames[3u * t + 2u], eye));
    // Below the sample's tangent plane the field has no data: use the horizon.
    w.z = max(w.z, 0.0);
    vec4 sum = vec4(0.0);
    // Dequantize: U8 textures read q/255 (UNORM), F16 read the value with scale 1 and bias 0.
#define SHR_ACCUMULATE(i, y) \
    sum += (scaleBias[2 * (i) + 1] + scaleBias[2 * (i)] * texelFetch(coefficients, ivec3(p, (i)), 0)) * (y)
    SH_FOR_EACH_BASIS(w, SH_ORDER, SHR_ACCUMULATE)
#undef SHR_ACCUMULATE
    float len2 = dot(sum.xyz, sum.xyz);
    vec3 direction = len2 > kMinDirectionLength2 ? sum.xyz * inversesqrt(len2) : vec3(0.0);
    result = vec4(direction, clamp(sum.w, -kMaxOpticalDepth, kMaxOpticalDepth));
  }
  imageStore(distortion, ivec2(p), result);
}
