// Shared by the decompression shaders (decompress.comp: Sh; decompress_table.comp: Table, Pca):
// the specialization constants and bindings both read, the eye in a sample's frame, and the
// distortion texel of a decoded sum (gpu_layout.h). Mirrored by engine/reference/src/
// cpu_reference.cpp (decodeTexel).
#include "shrefract/gpu_layout.h"

// 3: x, y, z; 4: x, y, z and tau, or (THROUGHPUT) x, y, z and the throughput; 5: x, y, z, tau and
// the throughput. Nothing of an absent channel is read or summed.
layout(constant_id = kSpecChannels) const int CHANNELS = 4;
// true: the last channel is the path's throughput, which scales the stored direction.
layout(constant_id = kSpecThroughput) const bool THROUGHPUT = false;
layout(constant_id = kSpecQuantization) const uint QUANTIZATION = kQuantizationU8;
// true: the coefficients exceed the device's texel buffer limit; read the storage buffer.
layout(constant_id = kSpecCoefficientsStorage) const bool COEFFICIENTS_STORAGE = false;
// Channel 3 is the optical depth (and not the throughput).
// true (decompress_table.comp): the last of the CHANNELS is the jump distance, which guides the
// decode and is not decoded (field.h EncodingShape::jumpDistance).
layout(constant_id = kSpecJumpDistance) const bool JUMP_DISTANCE = false;
// true: channels 0..2 are the exit in the sample's frame (field.h EncodingShape::sampleFrameExits).
layout(constant_id = kSpecSampleFrameExits) const bool SAMPLE_FRAME_EXITS = false;
const int DECODED = CHANNELS - (JUMP_DISTANCE ? 1 : 0);
const bool HAS_TAU = DECODED == (THROUGHPUT ? 5 : 4);

layout(push_constant) uniform Push { DecompressPushConstants pc; };
layout(set = 0, binding = kBindingCoefficients) uniform usamplerBuffer coefficientWords;
layout(std430, set = 0, binding = kBindingCoefficientsStorage) readonly buffer CoefficientsStorage {
  uint coefficientStorage[];
};
layout(std430, set = 0, binding = kBindingFrames) readonly buffer Frames { vec4 frames[]; };
layout(std430, set = 0, binding = kBindingSampleTexels) readonly buffer SampleTexels { uint sampleTexels[]; };
layout(set = 0, binding = kBindingDistortionOut, rgba16f) uniform writeonly image2D distortion;
// The eye's distance from each sample's nearest table jump (gpu_layout.h kBindingJumpOut); only
// decompress_table.comp writes it, for fields with the jump distance channel.
layout(set = 0, binding = kBindingJumpOut, r32f) uniform writeonly image2D jumpImage;

uint fetchWord(uint index) {
  return COEFFICIENTS_STORAGE ? coefficientStorage[index] : texelFetch(coefficientWords, int(index)).x;
}

// Dispatches beyond maxComputeWorkGroupCount[0] groups are split into rows (dispatchGrid), numbered
// row after row.
uint invocationIndex() {
  return gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * kDecompressLocalSize;
}

// M_s (eye, 1) of sample s, below its tangent plane too (decompress_volume.comp skips those).
vec3 eyeInFrameUnclamped(uint s, vec4 eye) {
  return vec3(dot(frames[3u * s], eye), dot(frames[3u * s + 1u], eye), dot(frames[3u * s + 2u], eye));
}

// w = M_s (eye, 1) of sample s. Below the sample's tangent plane the field has no data: w.z is
// clamped to the horizon. Not normalized: the SH evaluator and the hemi-octahedral map both are
// invariant to the length (and both take the zero vector as +z).
vec3 eyeInFrame(uint s, vec4 eye) {
  vec3 w = eyeInFrameUnclamped(s, eye);
  w.z = max(w.z, 0.0);
  return w;
}

// The decoded exit sum of sample s in object space: a sample-frame sum is rotated by the transpose
// of the frame's rows (field_decode.cpp evaluateCoefficients), an object-space one kept.
vec3 objectExit(uint s, vec3 xyz) {
  if (!SAMPLE_FRAME_EXITS) return xyz;
  return xyz.x * frames[3u * s].xyz + xyz.y * frames[3u * s + 1u].xyz + xyz.z * frames[3u * s + 2u].xyz;
}

// The distortion texel (gpu_layout.h) of a decoded sum: xyz the sum of channels 0..2, channel3
// and channel4 those channels' sums (ignored where the field has no such channel).
vec4 distortionTexel(vec3 xyz, float channel3, float channel4) {
  float len2 = dot(xyz, xyz);
  vec3 direction = len2 > kMinDirectionLength2 ? xyz * inversesqrt(len2) : vec3(0.0);
  if (THROUGHPUT) direction *= clamp(DECODED == 5 ? channel4 : channel3, 0.0, 1.0);
  return vec4(direction, HAS_TAU ? clamp(channel3, -kMaxOpticalDepth, kMaxOpticalDepth) : 0.0);
}

void storeSample(uint s, vec4 texel) {
  uint t = sampleTexels[s];
  imageStore(distortion, ivec2(t % pc.size.x, t / pc.size.x), texel);
}

void storeJump(uint s, float cells) {
  uint t = sampleTexels[s];
  imageStore(jumpImage, ivec2(t % pc.size.x, t / pc.size.x), vec4(cells));
}
