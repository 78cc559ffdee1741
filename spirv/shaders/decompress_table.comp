#version 460
// Decompression in data space of the Table and Pca encodings (shrefract/field.h): for every
// sample, the eye in the sample's frame (as in decompress.comp) falls in a cell of the
// hemi-octahedral grid (shrefract/hemi_oct.glsl), and each channel c is
//   Table: sum over the cell's 4 nodes n of weight_n * a_n,c(s);
//   Pca:   sum over the K components k of a_k(s) * sum over the 4 nodes of weight_n * B_k(n, c);
// the sample's texel gets their distortion texel (decompress_common.glsl). Empty texels keep the
// zero the image was created with; the gutter pass fills gutter texels. Mirrored by
// engine/src/field/field_decode.cpp (evaluateSample), which cpu_reference.cpp (decodeTexel) uses.
//
// One invocation per sample, reading its values sample-major (gpu_layout.h): a sample reads only
// 4 nodes of its own table (Table) or its own K weights and 4 nodes of each shared basis function
// (Pca), so the SH pass's planes, which share one read of a basis function's values between 4
// samples, would gain nothing. The sums run in the CPU decoder's order.
#extension GL_GOOGLE_include_directive : require
#include "decompress_common.glsl"
#include "shrefract/hemi_oct.glsl"

layout(constant_id = kSpecEncoding) const uint ENCODING = kEncodingTable;  // kEncodingTable or kEncodingPca
// N: nodes per side of the grid (Table: of the coefficients; Pca: of the basis functions).
layout(constant_id = kSpecTableSize) const uint TABLE_SIZE = 8u;
layout(constant_id = kSpecComponents) const uint COMPONENTS = 1u;  // Pca: K
layout(local_size_x = kDecompressLocalSize) in;

const uint NODES = TABLE_SIZE * TABLE_SIZE;
// Layers and values per layer of the coefficients (field.h layerCount, valuesPerLayer).
const uint LAYERS = ENCODING == kEncodingTable ? NODES : COMPONENTS;
const uint VALUES = ENCODING == kEncodingTable ? uint(CHANNELS) : 1u;

layout(std430, set = 0, binding = kBindingScaleBiasStorage) readonly buffer ScaleBias { vec2 scaleBias[]; };
layout(std430, set = 0, binding = kBindingBasis) readonly buffer Basis { float basis[]; };

// The dequantized value v of layer `layer` of sample s (U8: bias + (scale / 255) * q).
float coefficient(uint s, uint layer, uint v) {
  uint e = (s * LAYERS + layer) * VALUES + v;
  if (QUANTIZATION == kQuantizationF16) return unpackHalf2x16(fetchWord(e >> 1u) >> (16u * (e & 1u))).x;
  vec2 sb = scaleBias[layer * VALUES + v];
  return sb.y + sb.x * float((fetchWord(e >> 2u) >> (8u * (e & 3u))) & 0xffu);
}

void main() {
  uint s = invocationIndex();
  if (s >= pc.size.w) return;
  HemiOctBilinear b = hemiOctBilinear(eyeInFrame(s, vec4(pc.eyeObject.xyz, 1.0)), TABLE_SIZE);
  float sum[5] = float[5](0.0, 0.0, 0.0, 0.0, 0.0);
  if (ENCODING == kEncodingTable) {
    for (int j = 0; j < 4; ++j)
      for (int c = 0; c < CHANNELS; ++c) sum[c] += b.weight[j] * coefficient(s, b.node[j], uint(c));
  } else {
    for (uint k = 0u; k < COMPONENTS; ++k) {
      float a = coefficient(s, k, 0u);
      for (int j = 0; j < 4; ++j) {
        uint first = (k * NODES + b.node[j]) * uint(CHANNELS);
        for (int c = 0; c < CHANNELS; ++c) sum[c] += a * b.weight[j] * basis[first + uint(c)];
      }
    }
  }
  storeSample(s, distortionTexel(vec3(sum[0], sum[1], sum[2]), sum[3], sum[4]));
}
