// Volume shading per fragment (renderer.h ShadingMode::Field for an object whose Volume field
// traces per fragment: Object::tracesVolumePerFragment): the fragment's own paths are refracted in
// at its interpolated position and normal and traced through the field's distance grid
// (volume_trace.glsl), where the texture-space shading reads the distortion image the
// decompression pass traced at the sample texels and interpolates between them. Nothing between
// texels is interpolated, so the field's spatial sampling costs nothing; the grid's own errors
// remain. Mirrored by engine/reference/src/cpu_reference.cpp (shadeVolume).
#include "shrefract/gpu_layout.h"
#include "environment_select.glsl"

#include "object_field_common.glsl"

// The grid's words: the VolumeHeader's 12, then the bricks (gpu_layout.h kBindingVolumeGrid says
// why a texel buffer).
layout(set = 1, binding = kBindingVolumeGrid) uniform usamplerBuffer volumeWords;
const int kVolumeHeaderWords = 12;
VolumeHeader head;  // read from volumeWords at the start of main
uint volumeWord(uint index) { return texelFetch(volumeWords, kVolumeHeaderWords + int(index)).x; }

VolumeHeader readVolumeHeader() {
  uvec4 grid = uvec4(texelFetch(volumeWords, 0).x, texelFetch(volumeWords, 1).x, texelFetch(volumeWords, 2).x,
                     texelFetch(volumeWords, 3).x);
  vec4 origin = uintBitsToFloat(uvec4(texelFetch(volumeWords, 4).x, texelFetch(volumeWords, 5).x,
                                      texelFetch(volumeWords, 6).x, texelFetch(volumeWords, 7).x));
  vec4 media = uintBitsToFloat(uvec4(texelFetch(volumeWords, 8).x, texelFetch(volumeWords, 9).x,
                                     texelFetch(volumeWords, 10).x, texelFetch(volumeWords, 11).x));
  return VolumeHeader(grid, origin, media);
}

#include "volume_trace.glsl"

// Paths traced per axis of the pixel, and of a pixel refined where they disagree.
// (REFINE_VOLUME_PATHS: RendererCreateInfo::refineVolumePaths).
layout(constant_id = kSpecRefineVolumePaths) const bool REFINE_VOLUME_PATHS = true;
const uint TRACED_TAPS = ENVIRONMENT_TAPS < kVolumeTracedTapsPerAxis ? ENVIRONMENT_TAPS : kVolumeTracedTapsPerAxis;
const uint REFINED_TAPS = kVolumeRefinedTapsPerAxis;

// The view, and the normal bent toward it as object_field_body.glsl bends it (interpolated normals
// can face away near silhouettes), at object-space point p with interpolated normal `normal`.
void viewAndBentNormal(vec3 p, vec3 normal, out vec3 v, out vec3 n) {
  n = normalize(normal);
  v = normalize(p - pc.eyeObject.xyz);
  float c = -dot(v, n);
  if (c < 1e-4) n = normalize(n + (1e-4 - c) * -v);
}

// The environment over one traced path's cell of the pixel (ddx, ddy: the exit's change across
// the cell): cellTaps^2 taps of the parallelogram, as lookupEnvironmentOverPixel's over the pixel.
vec3 lookupOverCell(vec3 dir, vec3 ddx, vec3 ddy, uint cellTaps) {
  float n = float(cellTaps);
  float footprint = directionFootprint(ddx / n, ddy / n);
  vec3 sum = vec3(0.0);
  for (uint j = 0u; j < cellTaps; ++j)
    for (uint i = 0u; i < cellTaps; ++i) {
      vec3 tap = dir + tapOffset(i, n) * ddx + tapOffset(j, n) * ddy;
      sum += lookupEnvironment(dot(tap, tap) > 1e-12 ? tap : dir, footprint);
    }
  return sum / (n * n);
}

// The pixel's surface moved along its screen derivatives, for the traced paths.
struct PixelSurface {
  vec3 dPdx, dPdy, dNdx, dNdy;
};

// taps x taps paths at the centres of the pixel's cells, each looked up over its cell (the
// exit's derivatives exitDx, exitDy divided among them); the mean, and in `apart` whether any
// path left more than acos(kVolumeRefineCosine) away from the centre path's exit.
vec3 pathsOverPixel(uint taps, vec3 exitWorld, vec3 exitDx, vec3 exitDy, PixelSurface s, out bool apart) {
  float n = float(taps);
  uint cellTaps = max(ENVIRONMENT_TAPS / taps, 1u);
  vec3 sum = vec3(0.0);
  apart = false;
  for (uint j = 0u; j < taps; ++j)
    for (uint i = 0u; i < taps; ++i) {
      float a = tapOffset(i, n), b = tapOffset(j, n);
      vec3 p = inPosition + a * s.dPdx + b * s.dPdy;
      vec3 v, nn;
      viewAndBentNormal(p, inNormal + a * s.dNdx + b * s.dNdy, v, nn);
      VolumePath path = traceVolumePath(p, nn, v);
      vec3 exit = rotateByQuaternion(pc.worldFromObjectRotation, path.exit);
      apart = apart || dot(exit, exitWorld) < kVolumeRefineCosine;
      sum += lookupOverCell(exit, exitDx / n, exitDy / n, cellTaps);
    }
  return sum / (n * n);
}

// The transmitted light over the pixel: TRACED_TAPS^2 paths at the centres of the pixel's cells
// (the position and normal moved along their screen derivatives), each looked up over its cell;
// where one of them leaves apart from the centre path, REFINED_TAPS^2 instead (a 1-spp pixel
// across a path discontinuity otherwise shows whichever side its few paths fell on).
// The exit's derivatives (exitDx, exitDy: the centre path's, fine) size the cells' footprints; an
// axis across which the exit jumps (beyond acos(kSpatialSplitCosine)) while the other's is smooth
// is a path discontinuity, not divergence, and is left out of them (a clean edge stays sharp,
// where the jump's width would blur the whole pixel); where both axes jump (chaotic paths) both
// are kept, and the blur stands for the colours the pixel mixes. One path: the centre's over
// the pixel (lookupEnvironmentOverPixel).
vec3 transmittedOverPixel(vec3 exitWorld, vec3 exitDx, vec3 exitDy, vec3 dPdx, vec3 dPdy, float weight) {
  bool jumpX = dot(exitDx, exitDx) > 2.0 * (1.0 - kSpatialSplitCosine);
  bool jumpY = dot(exitDy, exitDy) > 2.0 * (1.0 - kSpatialSplitCosine);
  if (jumpX != jumpY) {
    if (jumpX) exitDx = vec3(0.0);
    else exitDy = vec3(0.0);
  }
  if (TRACED_TAPS == 1u) return lookupEnvironmentOverPixel(exitWorld, exitDx, exitDy);
  PixelSurface s = PixelSurface(dPdx, dPdy, dFdxFine(inNormal), dFdyFine(inNormal));
  // A second turn of a loop, which a SIMD rasterizer leaves as soon as no lane needs it (lavapipe
  // with the angle set so that no pixel refines: 1.03x the 2x2 frame on the sphere).
  bool mayRefine = REFINE_VOLUME_PATHS && weight >= kVolumeRefineWeight;
  uint taps = TRACED_TAPS;
  vec3 traced;
  while (true) {
    bool apart;
    traced = pathsOverPixel(taps, exitWorld, exitDx, exitDy, s, apart);
    if (!apart || !mayRefine || taps == REFINED_TAPS) break;
    taps = REFINED_TAPS;
  }
  return traced;
}

void main() {
  head = readVolumeHeader();
  vec3 v, n;
  viewAndBentNormal(inPosition, inNormal, v, n);
  // As object_field_body.glsl: the coverage from the cosine before the normal is bent.
  float cosView = -dot(normalize(inPosition - pc.eyeObject.xyz), normalize(inNormal));
  vec3 dPdx = dFdxFine(inPosition), dPdy = dFdyFine(inPosition);
  float coverage = SILHOUETTE_COVERAGE ? min(silhouetteCoverage(cosView), polygonCoverage(dPdx, dPdy)) : 1.0;
  float ior = inFrontIor > 0.0 ? inFrontIor : pc.medium.x;
  float fresnel = fresnelDielectric(-dot(v, n), 1.0 / ior);

  VolumePath path = traceVolumePath(inPosition, n, v);
  vec3 exitWorld = rotateByQuaternion(pc.worldFromObjectRotation, path.exit);
  vec3 reflectedWorld = rotateByQuaternion(pc.worldFromObjectRotation, reflect(v, n));
  // In uniform control flow (every lane has left the trace's loops): the fine derivatives, which
  // need the helper invocations' traces (gpu_layout.h kBindingVolumeGrid).
  vec3 exitDx = dFdxFine(exitWorld), exitDy = dFdyFine(exitWorld);
  vec3 reflectedDx = dFdxFine(reflectedWorld), reflectedDy = dFdyFine(reflectedWorld);
  float tau = clamp(path.tau, -kMaxOpticalDepth, kMaxOpticalDepth);
  if (uint(pc.medium.w) == kModeFieldExitDirection) {  // the measured quantity itself
    outColor = vec4(exitWorld, tau);
    return;
  }
  // Beer-Lambert as the texture-space shading (a medium without absorption has tau = 0), and the
  // centre path's Fresnel factors where the field keeps its throughput (ObjectPushConstants.tint.a).
  float transmittance = exp(-max(tau, 0.0) * pc.medium.y);
  if (pc.tint.a > 0.5) transmittance *= clamp(path.energy, 0.0, 1.0);
  vec3 color = (1.0 - fresnel) * transmittance * pc.tint.rgb *
               transmittedOverPixel(exitWorld, exitDx, exitDy, dPdx, dPdy, (1.0 - fresnel) * transmittance);
  if (pc.medium.z > 0.5)
    color += fresnel * lookupEnvironmentOverPixel(reflectedWorld, reflectedDx, reflectedDy);
  outColor = vec4(color * pc.eyeObject.w, coverage);
}
