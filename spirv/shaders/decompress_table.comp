#version 460
// Decompression in data space of the Table and Pca encodings (shrefract/field.h): for every
// sample, the eye in the sample's frame (as in decompress.comp) falls in a cell of the
// hemi-octahedral grid (shrefract/hemi_oct.glsl), whose 4 corners n hold, for each channel c,
//   Table: a_n,c(s);
//   Pca:   the sum over the K components k of a_k(s) * B_k(n, c);
// blended bilinearly, or jump-aware where the corners disagree (interpolateCorners below); the
// sample's texel gets the result's distortion texel (decompress_common.glsl), and with the jump
// distance channel the jump image its eyeJump. Empty texels keep the zero (the jump image: the
// cap) the images were created with; the gutter pass fills gutter texels. Mirrored by
// engine/reference/src/field_decode.cpp (evaluateSample), which cpu_reference.cpp (decodeTexel) uses.
//
// One invocation per sample, reading its values sample-major (gpu_layout.h): a sample reads only
// 4 nodes of its own table (Table) or its own K weights and 4 nodes of each shared basis function
// (Pca; clustered: its index and 4 nodes of that one function), so the SH pass's planes, which
// share one read of a basis function's values between 4 samples, would gain nothing. The sums run
// in the CPU decoder's order.
#extension GL_GOOGLE_include_directive : require
#include "decompress_common.glsl"
#include "shrefract/hemi_oct.glsl"

layout(constant_id = kSpecEncoding) const uint ENCODING = kEncodingTable;  // kEncodingTable or kEncodingPca
// N: nodes per side of the grid (Table: of the coefficients; Pca: of the basis functions).
layout(constant_id = kSpecTableSize) const uint TABLE_SIZE = 8u;
layout(constant_id = kSpecComponents) const uint COMPONENTS = 1u;  // Pca: K
layout(constant_id = kSpecJumpAware) const bool JUMP_AWARE = false;  // the corners blended jump-aware
layout(constant_id = kSpecClustered) const bool CLUSTERED = false;  // Pca: one function index per sample
layout(local_size_x = kDecompressLocalSize) in;

const uint NODES = TABLE_SIZE * TABLE_SIZE;
// Layers and values per layer of the coefficients (field.h layerCount, valuesPerLayer).
const uint LAYERS = ENCODING == kEncodingTable ? NODES : COMPONENTS;
const uint VALUES = ENCODING == kEncodingTable ? uint(CHANNELS) : 1u;

layout(std430, set = 0, binding = kBindingScaleBiasStorage) readonly buffer ScaleBias { vec2 scaleBias[]; };
layout(std430, set = 0, binding = kBindingBasis) readonly buffer Basis { float basis[]; };
// The same buffer read a whole node at a time where a node holds 4 channels (the tool's default
// field): one 16-byte load in place of four 4-byte ones, the sums unchanged.
layout(std430, set = 0, binding = kBindingBasis) readonly buffer Basis4 { vec4 basis4[]; };
// A clustered field's tables: binary16, two to a word (gpu_layout.h kSpecClustered).
layout(std430, set = 0, binding = kBindingBasis) readonly buffer BasisHalves { uint basisHalves[]; };

float tableValue(uint i) { return unpackHalf2x16(basisHalves[i >> 1u] >> (16u * (i & 1u))).x; }

// The dequantized value v of layer `layer` of sample s (U8: bias + (scale / 255) * q).
float coefficient(uint s, uint layer, uint v) {
  uint e = (s * LAYERS + layer) * VALUES + v;
  if (QUANTIZATION == kQuantizationF16) return unpackHalf2x16(fetchWord(e >> 1u) >> (16u * (e & 1u))).x;
  vec2 sb = scaleBias[layer * VALUES + v];
  return sb.y + sb.x * float((fetchWord(e >> 2u) >> (8u * (e & 3u))) & 0xffu);
}

// The exit of a path that goes straight through for the local direction w toward the eye, in the
// space the exits are stored in (field_decode.cpp straightThrough).
vec3 straightThrough(uint s, vec3 w) {
  float l = sqrt(w.x * w.x + w.y * w.y + w.z * w.z);
  if (!(l > 0.0)) return vec3(0.0);
  if (SAMPLE_FRAME_EXITS) return vec3(-w.x / l, -w.y / l, -w.z / l);
  vec3 r0 = frames[3u * s].xyz, r1 = frames[3u * s + 1u].xyz, r2 = frames[3u * s + 2u].xyz;
  return vec3(-(w.x * r0.x + w.y * r1.x + w.z * r2.x) / l, -(w.x * r0.y + w.y * r1.y + w.z * r2.y) / l,
              -(w.x * r0.z + w.y * r1.z + w.z * r2.z) / l);
}

// A side's estimate at w from its corners' values: coefficients (sum 1) of the plane fitted to them
// (field_decode.cpp sideCoefficients, which explains it), in the same float operations.
void sideCoefficients(HemiOctBilinear b, float kept[4], float keep[4], out float alpha[4]) {
  float tx = b.weight[1] + b.weight[3], ty = b.weight[2] + b.weight[3];
  float dx[4] = float[4](-tx, 1.0 - tx, -tx, 1.0 - tx), dy[4] = float[4](-ty, -ty, 1.0 - ty, 1.0 - ty);
  float f[4];
  float sx = 0.0, sy = 0.0, sxx = kJumpSideSlopeRidge, sxy = 0.0, syy = kJumpSideSlopeRidge;
  for (int j = 0; j < 4; ++j) {
    float k2 = keep[j] * keep[j];
    f[j] = kept[j] * (k2 * k2);
    sx += f[j] * dx[j];
    sy += f[j] * dy[j];
    sxx += f[j] * dx[j] * dx[j];
    sxy += f[j] * dx[j] * dy[j];
    syy += f[j] * dy[j] * dy[j];
  }
  float minor = sxx * syy - sxy * sxy;
  float det = 0.0;
  for (int j = 0; j < 4; ++j) {
    alpha[j] = f[j] * (minor - sx * (dx[j] * syy - sxy * dy[j]) + sy * (dx[j] * sxy - sxx * dy[j]));
    det += alpha[j];
  }
  for (int j = 0; j < 4; ++j) alpha[j] /= det;
}

// The cell's corners blended into sum: node-sampled exits by b_j |o_j|, the rest bilinearly
// (field_decode.cpp blendCorners says why), in the same float operations.
void blendCorners(HemiOctBilinear b, float v[4][6], inout float sum[5]) {
  float lengths[4] = float[4](1.0, 1.0, 1.0, 1.0);
  float exitWeight[4];
  float weighted = 0.0;
  if (JUMP_AWARE)
    for (int j = 0; j < 4; ++j) lengths[j] = octahedronLength(b.node[j], TABLE_SIZE);
  for (int j = 0; j < 4; ++j) weighted += b.weight[j] * lengths[j];
  for (int j = 0; j < 4; ++j) exitWeight[j] = b.weight[j] * lengths[j] / weighted;
  for (int j = 0; j < 4; ++j)
    for (int c = 0; c < DECODED; ++c) sum[c] += (c < 3 ? exitWeight[j] : b.weight[j]) * v[j][c];
}

// Jump-aware interpolation of the cell's corners v (field_decode.cpp interpolateCorners, which
// explains it; constants in gpu_layout.h), in the same float operations. sum: the DECODED channels.
// eyeJump: the eye's distance from the cell's jump (field_decode.cpp interpolateCorners' eyeJump),
// left as it is where the decode does not get that far.
void interpolateCorners(uint s, HemiOctBilinear b, vec3 w, float v[4][6], inout float sum[5], inout float eyeJump) {
  blendCorners(b, v, sum);
  if (!JUMP_AWARE || TABLE_SIZE < kJumpMinTableSize) return;
  vec3 eye = straightThrough(s, w);
  vec3 e[4];
  for (int j = 0; j < 4; ++j) {
    uint node = b.node[j];
    vec3 d = straightThrough(s, hemiOctDirection(node % TABLE_SIZE, node / TABLE_SIZE, TABLE_SIZE));
    e[j] = vec3(v[j][0] + (eye.x - d.x), v[j][1] + (eye.y - d.y), v[j][2] + (eye.z - d.z));
  }
  // Each corner m in turn as the reference side, weighted by w_m^p.
  float len[4];
  float distance[4] = float[4](0.0, 0.0, 0.0, 0.0);
  float estimate[5] = float[5](0.0, 0.0, 0.0, 0.0, 0.0);
  float dominance = 0.0, discounted = 0.0;
  float nearest = -kJumpDistanceMaxCells;
  // field_decode.cpp jumpCosines: the reference angles, scaled down for finer cells, floored.
  float scale = TABLE_SIZE > kJumpReferenceTableSize ? float(kJumpReferenceTableSize) / float(TABLE_SIZE) : 1.0;
  float cosineFull = cos(radians(max(kJumpFullDegrees * scale, kJumpFullMinDegrees)));
  float cosineNone = cos(radians(max(kJumpNoneDegrees * scale, kJumpNoneMinDegrees)));
  for (int j = 0; j < 4; ++j) len[j] = sqrt(e[j].x * e[j].x + e[j].y * e[j].y + e[j].z * e[j].z);
  if (JUMP_DISTANCE)
    for (int j = 0; j < 4; ++j)
      distance[j] = clamp(v[j][DECODED] * (float(TABLE_SIZE - 1u) / kJumpDistanceScale), 0.0, kJumpDistanceMaxCells);
  for (int m = 0; m < 4; ++m) {
    float pm = JUMP_DISTANCE ? b.weight[m] : pow(b.weight[m], kJumpDominancePower);
    float keep[4], kept[4];
    float signedDistance = 0.0;
    for (int j = 0; j < 4; ++j) {
      float dotJ = e[j].x * e[m].x + e[j].y * e[m].y + e[j].z * e[m].z;
      float cosine = len[j] * len[m] > kMinDirectionLength2 ? dotJ / (len[j] * len[m]) : 1.0;
      keep[j] = clamp((cosine - cosineNone) / (cosineFull - cosineNone), 0.0, 1.0);
      kept[j] = b.weight[j] * keep[j];
      signedDistance += b.weight[j] * distance[j] * (2.0 * keep[j] - 1.0);
    }
    nearest = max(nearest, signedDistance);  // every view's (field_decode.cpp says why)
    if (!(pm > 0.0)) continue;
    if (JUMP_DISTANCE) pm *= clamp(0.5 + signedDistance / kJumpDistanceSoftness, 0.0, 1.0) + kJumpDistanceFloor;
    for (int j = 0; j < 4; ++j) discounted += pm * (b.weight[j] - kept[j]);
    float alpha[4];
    sideCoefficients(b, kept, keep, alpha);
    for (int c = 0; c < DECODED; ++c) {
      float side = 0.0;
      for (int j = 0; j < 4; ++j) side += alpha[j] * (c < 3 ? e[j][c] : v[j][c]);
      estimate[c] += pm * side;
    }
    dominance += pm;
  }
  if (JUMP_DISTANCE) eyeJump = clamp(nearest, 0.0, kJumpDistanceMaxCells);
  float blend = min(1.0, kJumpBlendGain * discounted / dominance);
  if (!(blend > 0.0)) return;
  for (int c = 0; c < DECODED; ++c) sum[c] += blend * (estimate[c] / dominance - sum[c]);
}

void main() {
  uint s = invocationIndex();
  if (s >= pc.size.w) return;
  vec3 w = eyeInFrame(s, vec4(pc.eyeObject.xyz, 1.0));
  HemiOctBilinear b = hemiOctBilinear(w, TABLE_SIZE);
  float v[4][6];  // CHANNELS at most kMaxEncodedChannels
  for (int j = 0; j < 4; ++j)
    for (int c = 0; c < 6; ++c) v[j][c] = 0.0;
  if (ENCODING == kEncodingTable) {
    for (int j = 0; j < 4; ++j)
      for (int c = 0; c < CHANNELS; ++c) v[j][c] = coefficient(s, b.node[j], uint(c));
  } else if (CLUSTERED) {  // the sample's one function, whole (field_decode.cpp evaluateStored)
    uint k = min((fetchWord(s >> 1u) >> (16u * (s & 1u))) & 0xffffu, COMPONENTS - 1u);
    for (int j = 0; j < 4; ++j)
      for (int c = 0; c < CHANNELS; ++c) v[j][c] = tableValue((k * NODES + b.node[j]) * uint(CHANNELS) + uint(c));
  } else {  // each corner sums over k in ascending order, as the CPU decoder does
    for (uint k = 0u; k < COMPONENTS; ++k) {
      float a = coefficient(s, k, 0u);
      for (int j = 0; j < 4; ++j) {
        uint node = k * NODES + b.node[j];
        if (CHANNELS == 4) {
          vec4 n4 = basis4[node];
          for (int c = 0; c < 4; ++c) v[j][c] += a * n4[c];
        } else {
          for (int c = 0; c < CHANNELS; ++c) v[j][c] += a * basis[node * uint(CHANNELS) + uint(c)];
        }
      }
    }
  }
  float sum[5] = float[5](0.0, 0.0, 0.0, 0.0, 0.0);
  float eyeJump = kJumpDistanceMaxCells;
  interpolateCorners(s, b, w, v, sum, eyeJump);
  storeSample(s, distortionTexel(objectExit(s, vec3(sum[0], sum[1], sum[2])), sum[3], sum[4]));
  if (JUMP_DISTANCE) storeJump(s, eyeJump);
}
