#version 460
// Decompression in data space of the Volume encoding (shrefract/field.h): for every sample, the
// eye in the sample's frame (as in decompress.comp) gives the view direction, which refracts at the
// sample's point and normal (its frame's rows) into the object and is traced through the object's
// signed distance grid (kBindingBasis: gpu_layout.h VolumeHeader, then the bricks): marched
// along the trilinear distance until it turns positive, the crossing bisected, the interface's
// normal the trilinear normal there, the branch the field's path rule picks, up to the bounce cap.
// The trace is volume_trace.glsl's; the sample's texel gets the exit's distortion texel (decompress_common.glsl). Mirrored by
// engine/src/field/volume_trace.cpp (traceVolumeSample), the same float operations in the same
// order, which cpu_reference.cpp (decodeTexel) uses.
//
// One invocation per sample. Paths differ in length from sample to sample, so lanes of a subgroup
// wait for the longest; the grid is read 8 words a step, near the surface mostly (cached).
#extension GL_GOOGLE_include_directive : require
#include "decompress_common.glsl"
#include "shrefract/environment.glsl"

layout(local_size_x = kDecompressLocalSize) in;

layout(std430, set = 0, binding = kBindingBasis) readonly buffer Volume {
  VolumeHeader head;
  uint words[];  // the brick entries, then the stored bricks
};
// The grid's words through the R32_UINT texel view of the same buffer (coefficientWords, the header's
// 12 words first) where the device's texel buffer limit allows: on lavapipe a texel fetch is one
// gather, a storage read at a per-lane address a loop over the lanes. The storage binding otherwise.
const int kVolumeHeaderWords = 12;
uint volumeWord(uint index) {
  return COEFFICIENTS_STORAGE ? words[index] : texelFetch(coefficientWords, kVolumeHeaderWords + int(index)).x;
}

#include "volume_trace.glsl"

void main() {
  uint s = invocationIndex();
  if (s >= pc.size.w) return;
  vec4 r0 = frames[3u * s], r1 = frames[3u * s + 1u], r2 = frames[3u * s + 2u];
  vec3 ax = r0.xyz, ay = r1.xyz, az = r2.xyz;
  vec3 p = -1.0 * (r0.w * ax + r1.w * ay + r2.w * az);
  vec3 eye = eyeInFrameUnclamped(s, vec4(pc.eyeObject.xyz, 1.0));
  vec3 local = unitOr(eye);
  vec3 d = -1.0 * (local.x * ax + local.y * ay + local.z * az);
  // A sample facing away (the eye below its tangent plane) is not traced: the view passes by.
  VolumePath path = VolumePath(d, 0.0, 1.0);
  if (eye.z >= 0.0) path = traceVolumePath(p, unitOr(az), d);
  storeSample(s, distortionTexel(path.exit, HAS_TAU ? path.tau : path.energy, path.energy));
}
