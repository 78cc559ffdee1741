#version 460
// Decompression in data space of the Sh encoding: for every sample of the atlas, the eye goes into
// the sample's frame (w = M_s (eye, 1), w.z clamped to >= 0, then normalized by the SH evaluator),
// and sum_i c_i Y_i(w) over the basis functions of the field's order gives each channel; the
// sample's texel gets their distortion texel (decompress_common.glsl: the normalized direction,
// scaled by the throughput when the field has one, and the optical depth). Empty texels keep the
// zero the image was created with; the gutter pass fills gutter texels. Mirrored by
// engine/reference/src/cpu_reference.cpp (decodeTexel).
//
// One invocation decompresses 4 consecutive samples, as the 4 components of vec4s: the SH
// recurrence runs on vec4s (SH_FOR_EACH_BASIS_X4), and per basis function it reads one word per
// channel (U8: that channel's byte of the 4 samples; F16: two words) from the channel planes
// (gpu_layout.h), dequantizes them with the function's scale and bias (uniform: one load for all
// 4 samples) and accumulates with one vec4 multiply-add per channel. So a field without optical
// depth reads 3 bytes per sample and basis function, not 4 (or 5), with no unaligned reads; and
// consecutive invocations read consecutive words (coalesced on a GPU, streamed on a CPU).
//
// Measured on llvmpipe (docs/performance.md, "Decompression"): against one sample per invocation
// reading its own 3 bytes (two words across a boundary), this more than halves the time of a
// 3-channel field; the scale/bias table is a uniform buffer because llvmpipe reads a uniform
// buffer at a uniform address once for all lanes, but a storage buffer once per lane inside loops.
#extension GL_GOOGLE_include_directive : require
#include "decompress_common.glsl"
#include "shrefract/sh.glsl"

// The field's SH order: only bands 0..SH_ORDER are evaluated (the loops fold for a constant).
layout(constant_id = kSpecShOrder) const int SH_ORDER = 8;
// true: the scale/bias table exceeds kMaxUniformScaleBiasBytes; read the storage one.
layout(constant_id = kSpecScaleBiasStorage) const bool SCALE_BIAS_STORAGE = false;
layout(local_size_x = kDecompressLocalSize) in;

const int SH_BASIS = (SH_ORDER + 1) * (SH_ORDER + 1);
// vec4s of the scale/bias table per basis function (gpu_layout.h).
const int SCALE_BIAS_VEC4S = SHR_SH_SCALE_BIAS_VEC4S(CHANNELS);

layout(std140, set = 0, binding = kBindingScaleBias) uniform ScaleBias {
  vec4 scaleBias[SCALE_BIAS_STORAGE ? 1 : SCALE_BIAS_VEC4S * SH_BASIS];
};
layout(std430, set = 0, binding = kBindingScaleBiasStorage) readonly buffer ScaleBiasStorage {
  vec4 scaleBiasStorage[];
};

// The four bytes of a word as floats 0..255 (shifts and conversions; the table carries scale / 255).
vec4 bytesOf(uint word) { return vec4((uvec4(word) >> uvec4(0u, 8u, 16u, 24u)) & 0xffu); }

vec4 scaleBiasEntry(int k) { return SCALE_BIAS_STORAGE ? scaleBiasStorage[k] : scaleBias[k]; }
// Scale / 255 and bias of basis function i, channel c (a constant after unrolling).
float scaleOf(int i, int c) {
  return c < 4 ? scaleBiasEntry(SCALE_BIAS_VEC4S * i)[c] : scaleBiasEntry(SCALE_BIAS_VEC4S * i + 2).x;
}
float biasOf(int i, int c) {
  return c < 4 ? scaleBiasEntry(SCALE_BIAS_VEC4S * i + 1)[c] : scaleBiasEntry(SCALE_BIAS_VEC4S * i + 2).y;
}

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
  uint invocation = invocationIndex();
  bool inside = invocation < quads;
  uint quad = min(invocation, quads - 1u);
  uint planeWords = QUANTIZATION == kQuantizationU8 ? quads : 2u * quads;

  // The eye in each sample's frame (the padding samples of the last group repeat the last sample).
  vec4 eye = vec4(pc.eyeObject.xyz, 1.0);
  vec4 wx, wy, wz;
  for (int j = 0; j < 4; ++j) {
    vec3 w = eyeInFrame(min(4u * quad + uint(j), sampleCount - 1u), eye);
    wx[j] = w.x;
    wy[j] = w.y;
    wz[j] = w.z;
  }

  // sumC[j]: channel C of sample j (sum3, sum4: channels 3 and 4, when the field has them).
  vec4 sumX = vec4(0.0), sumY = vec4(0.0), sumZ = vec4(0.0), sum3 = vec4(0.0), sum4 = vec4(0.0);
  // Dequantize: U8 reads q (then bias + (scale / 255) * q), F16 reads the value (no table).
#define SHR_DEQUANTIZE(q, i, c) (QUANTIZATION == kQuantizationU8 ? biasOf(i, c) + scaleOf(i, c) * (q) : (q))
#define SHR_CHANNEL(sum, i, c, y) \
  sum += SHR_DEQUANTIZE(fetchPlane(uint(i) * uint(CHANNELS) + uint(c), planeWords, quad), i, c) * (y)
#define SHR_ACCUMULATE(i, y)                      \
  {                                               \
    SHR_CHANNEL(sumX, i, 0, y);                   \
    SHR_CHANNEL(sumY, i, 1, y);                   \
    SHR_CHANNEL(sumZ, i, 2, y);                   \
    if (CHANNELS > 3) SHR_CHANNEL(sum3, i, 3, y); \
    if (CHANNELS > 4) SHR_CHANNEL(sum4, i, 4, y); \
  }
  SH_FOR_EACH_BASIS_X4(wx, wy, wz, SH_ORDER, SHR_ACCUMULATE)
#undef SHR_ACCUMULATE
#undef SHR_CHANNEL
#undef SHR_DEQUANTIZE

  if (!inside) return;
  for (int j = 0; j < 4; ++j) {
    uint s = 4u * quad + uint(j);
    if (s >= sampleCount) break;
    storeSample(s, distortionTexel(objectExit(s, vec3(sumX[j], sumY[j], sumZ[j])), sum3[j], sum4[j]));
  }
}
