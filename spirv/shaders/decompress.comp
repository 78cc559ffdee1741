#version 460
// Decompression in data space: for every sample of the atlas, the eye goes into the sample's frame
// (w = M_s (eye, 1), w.z clamped to >= 0, then normalized by the SH evaluator), and
// sum_i c_i Y_i(w) over the basis functions of the field's order gives the exit direction
// (normalized) and the optical depth. Empty texels keep the zero the image was created with; the
// gutter pass fills gutter texels. Mirrored by engine/src/reference/cpu_reference.cpp (decodeTexel).
//
// One invocation decompresses 4 consecutive samples, as the 4 components of vec4s: the SH
// recurrence runs on vec4s (SH_FOR_EACH_BASIS_X4), and per basis function it reads one word per
// channel (U8: that channel's byte of the 4 samples; F16: two words) from the channel planes
// (gpu_layout.h), dequantizes them with the function's scale and bias (uniform: one load for all
// 4 samples) and accumulates with one vec4 multiply-add per channel. So a field without optical
// depth reads 3 bytes per sample and basis function, not 4, with no unaligned reads; and
// consecutive invocations read consecutive words (coalesced on a GPU, streamed on a CPU).
//
// Measured on llvmpipe (docs/performance.md, "Decompression"): against one sample per invocation
// reading its own 3 bytes (two words across a boundary), this more than halves the time of a
// 3-channel field; the scale/bias table is a uniform buffer because llvmpipe reads a uniform
// buffer at a uniform address once for all lanes, but a storage buffer once per lane inside loops.
#extension GL_GOOGLE_include_directive : require
#include "shrefract/gpu_layout.h"
#include "shrefract/sh.glsl"

// The field's SH order: only bands 0..SH_ORDER are evaluated (the loops fold for a constant).
layout(constant_id = kSpecShOrder) const int SH_ORDER = 8;
// 4: x, y, z, tau; 3: x, y, z (tau is 0 and neither read nor summed).
layout(constant_id = kSpecChannels) const int CHANNELS = 4;
layout(constant_id = kSpecQuantization) const uint QUANTIZATION = kQuantizationU8;
// true: the scale/bias table exceeds kMaxUniformScaleBiasBytes (orders above 21); read the storage one.
layout(constant_id = kSpecScaleBiasStorage) const bool SCALE_BIAS_STORAGE = false;
// true: the coefficients exceed the device's texel buffer limit; read the storage buffer.
layout(constant_id = kSpecCoefficientsStorage) const bool COEFFICIENTS_STORAGE = false;
layout(local_size_x = kDecompressLocalSize) in;

const int SH_BASIS = (SH_ORDER + 1) * (SH_ORDER + 1);

layout(push_constant) uniform Push { DecompressPushConstants pc; };
layout(set = 0, binding = kBindingCoefficients) uniform usamplerBuffer coefficientWords;
layout(std430, set = 0, binding = kBindingCoefficientsStorage) readonly buffer CoefficientsStorage {
  uint coefficientStorage[];
};
layout(std140, set = 0, binding = kBindingScaleBias) uniform ScaleBias {
  vec4 scaleBias[SCALE_BIAS_STORAGE ? 2 : 2 * SH_BASIS];
};
layout(std430, set = 0, binding = kBindingScaleBiasStorage) readonly buffer ScaleBiasStorage {
  vec4 scaleBiasStorage[];
};
layout(std430, set = 0, binding = kBindingFrames) readonly buffer Frames { vec4 frames[]; };
layout(std430, set = 0, binding = kBindingSampleTexels) readonly buffer SampleTexels { uint sampleTexels[]; };
layout(set = 0, binding = kBindingDistortionOut, rgba16f) uniform writeonly image2D distortion;

// The four bytes of a word as floats 0..255 (shifts and conversions; the table carries scale / 255).
vec4 bytesOf(uint word) { return vec4((uvec4(word) >> uvec4(0u, 8u, 16u, 24u)) & 0xffu); }

uint fetchWord(uint index) {
  return COEFFICIENTS_STORAGE ? coefficientStorage[index] : texelFetch(coefficientWords, int(index)).x;
}

vec4 scaleOf(int i) { return SCALE_BIAS_STORAGE ? scaleBiasStorage[2 * i] : scaleBias[2 * i]; }
vec4 biasOf(int i) { return SCALE_BIAS_STORAGE ? scaleBiasStorage[2 * i + 1] : scaleBias[2 * i + 1]; }

// The stored values of plane `plane` for the invocation's 4 samples: bytes 0..255 (U8) or half
// values (F16). `planeWords` words per plane; `quad` is the invocation's group of 4 samples.
vec4 fetchPlane(uint plane, uint planeWords, uint quad) {
  if (QUANTIZATION == kQuantizationU8) return bytesOf(fetchWord(plane * planeWords + quad));
  uint first = plane * planeWords + 2u * quad;
  return vec4(unpackHalf2x16(fetchWord(first)), unpackHalf2x16(fetchWord(first + 1u)));
}

void main() {
  uint sampleCount = pc.size.w;
  uint quads = (sampleCount + 3u) / 4u;
  // No early return: invocations past the end repeat the last group and store nothing, so that the
  // whole pass runs in uniform control flow (llvmpipe then reads uniform addresses once).
  // Dispatches beyond maxComputeWorkGroupCount[0] groups are split into rows (dispatchGrid).
  uint invocation = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * kDecompressLocalSize;
  bool inside = invocation < quads;
  uint quad = min(invocation, quads - 1u);
  uint planeWords = QUANTIZATION == kQuantizationU8 ? quads : 2u * quads;

  // The eye in each sample's frame (the padding samples of the last group repeat the last sample).
  vec4 eye = vec4(pc.eyeWorld.xyz, 1.0);
  vec4 wx, wy, wz;
  uvec4 texel;
  for (int j = 0; j < 4; ++j) {
    uint s = min(4u * quad + uint(j), sampleCount - 1u);
    texel[j] = sampleTexels[s];
    wx[j] = dot(frames[3u * s], eye);
    wy[j] = dot(frames[3u * s + 1u], eye);
    wz[j] = dot(frames[3u * s + 2u], eye);
  }
  // Below the sample's tangent plane the field has no data: use the horizon.
  wz = max(wz, vec4(0.0));

  // sumC[j]: channel C of sample j.
  vec4 sumX = vec4(0.0), sumY = vec4(0.0), sumZ = vec4(0.0), sumW = vec4(0.0);
  // Dequantize: U8 reads q (then bias + (scale / 255) * q), F16 reads the value (no table).
#define SHR_DEQUANTIZE(q, i, c) \
  (QUANTIZATION == kQuantizationU8 ? biasOf(i)[c] + scaleOf(i)[c] * (q) : (q))
#define SHR_ACCUMULATE(i, y)                                                                  \
  {                                                                                          \
    uint plane_ = uint(i) * uint(CHANNELS);                                                  \
    sumX += SHR_DEQUANTIZE(fetchPlane(plane_, planeWords, quad), i, 0) * (y);                \
    sumY += SHR_DEQUANTIZE(fetchPlane(plane_ + 1u, planeWords, quad), i, 1) * (y);           \
    sumZ += SHR_DEQUANTIZE(fetchPlane(plane_ + 2u, planeWords, quad), i, 2) * (y);           \
    if (CHANNELS == 4) sumW += SHR_DEQUANTIZE(fetchPlane(plane_ + 3u, planeWords, quad), i, 3) * (y); \
  }
  SH_FOR_EACH_BASIS_X4(wx, wy, wz, SH_ORDER, SHR_ACCUMULATE)
#undef SHR_ACCUMULATE
#undef SHR_DEQUANTIZE

  if (!inside) return;
  for (int j = 0; j < 4; ++j) {
    if (4u * quad + uint(j) >= sampleCount) break;
    vec3 sum = vec3(sumX[j], sumY[j], sumZ[j]);
    float len2 = dot(sum, sum);
    vec3 direction = len2 > kMinDirectionLength2 ? sum * inversesqrt(len2) : vec3(0.0);
    float tau = CHANNELS == 4 ? clamp(sumW[j], -kMaxOpticalDepth, kMaxOpticalDepth) : 0.0;
    imageStore(distortion, ivec2(texel[j] % pc.size.x, texel[j] / pc.size.x), vec4(direction, tau));
  }
}
