#version 460
// Split-layout continuity rules, after decompression: texel target = value(a) + value(b) - value(c)
// (field.h GutterTexel), in the distortion image and the jump image. a, b and c hold samples (validateField), so no rule reads another's target.
#extension GL_GOOGLE_include_directive : require
#include "shrefract/gpu_layout.h"

layout(local_size_x = kGutterLocalSize) in;

layout(push_constant) uniform Push { DecompressPushConstants pc; };
layout(std430, set = 0, binding = kBindingGutters) readonly buffer Gutters { uvec4 gutters[]; };
layout(set = 0, binding = kBindingDistortionOut, rgba16f) uniform image2D distortion;
layout(set = 0, binding = kBindingJumpOut, r32f) uniform image2D jumpImage;

ivec2 texelCoord(uint t) { return ivec2(t % pc.size.x, t / pc.size.x); }

void main() {
  // Dispatches beyond maxComputeWorkGroupCount[0] groups are split into rows (dispatchGrid).
  uint g = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * kGutterLocalSize;
  if (g >= pc.size.z) return;
  uvec4 rule = gutters[g];
  vec4 value = imageLoad(distortion, texelCoord(rule.y)) + imageLoad(distortion, texelCoord(rule.z)) -
               imageLoad(distortion, texelCoord(rule.w));
  imageStore(distortion, texelCoord(rule.x), value);
  // The jump image by the same rule, kept within the distances it can hold (reference::decompress).
  float cells = imageLoad(jumpImage, texelCoord(rule.y)).x + imageLoad(jumpImage, texelCoord(rule.z)).x -
                imageLoad(jumpImage, texelCoord(rule.w)).x;
  imageStore(jumpImage, texelCoord(rule.x), vec4(clamp(cells, 0.0, kJumpDistanceMaxCells)));
}
