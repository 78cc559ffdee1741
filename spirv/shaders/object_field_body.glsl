// Field shading: the decompressed distortion image gives, at the fragment's field texture
// coordinate, the direction in which the refracted path leaves the object and its optical depth.
// Mirrored exactly by engine/reference/src/cpu_reference.cpp (shadeField).
#extension GL_EXT_samplerless_texture_functions : require  // texelFetch of the jump image
#include "shrefract/gpu_layout.h"
#include "environment_select.glsl"

#include "object_field_common.glsl"

layout(set = 1, binding = kBindingDistortion) uniform sampler2D distortionMap;
// The jump image is read texel by texel with no sampler: R32F need not support linear filtering.
layout(set = 1, binding = kBindingJumpDistance) uniform texture2D jumpMap;

// The four texels around a field coordinate, with the sampler's bilinear weights, and how far
// apart their exits are: 0 where every pair is within acos(kSpatialAgreeCosine), 1 where some pair
// is beyond acos(kSpatialSplitCosine), linearly in the cosine between (gpu_layout.h).
struct TexelCell {
  vec3 exit[4];  // unit, object space; zero where the texel is empty
  float weight[4];
  ivec2 texel[4];  // where the texels are (for the jump image, read only in jump cells)
  vec2 fraction;   // where the coordinate lies between the texels, along x and y
  float jump;
};

// How far the four exits still spread once one jump may split them into two groups, in radians:
// the widest angle within a group, for the split that makes it narrowest (two and two, or one and
// three). 0 in a smooth cell and in a cell a clean jump crosses; wide where the exit changes
// faster than the texels resolve (gpu_layout.h kSpatialScatterThreshold). An empty texel agrees
// with every other. Mirrored by cpu_reference.cpp scatterAfterOneJump.
float scatterAfterOneJump(vec3 exit[4]) {
  const int first[6] = int[](0, 0, 0, 1, 1, 2), second[6] = int[](1, 2, 3, 2, 3, 3);  // ab ac ad bc bd cd
  float c[6];
  for (int q = 0; q < 6; ++q) {
    vec3 a = exit[first[q]], b = exit[second[q]];
    c[q] = a == vec3(0.0) || b == vec3(0.0) ? 1.0 : dot(a, b);
  }
  float best = max(max(min(c[0], c[5]), min(c[1], c[4])), min(c[2], c[3]));  // ab|cd, ac|bd, ad|bc
  best = max(best, max(min(min(c[3], c[4]), c[5]), min(min(c[1], c[2]), c[5])));  // a|bcd, b|acd
  best = max(best, max(min(min(c[0], c[2]), c[4]), min(min(c[0], c[1]), c[3])));  // c|abd, d|abc
  return acos(clamp(best, -1.0, 1.0));
}

TexelCell readCell(vec2 uv) {
  ivec2 size = textureSize(distortionMap, 0);
  vec2 p = uv * vec2(size) - 0.5;
  ivec2 corner = ivec2(floor(p));
  vec2 f = p - floor(p);
  TexelCell cell;
  cell.weight = float[]((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
  cell.fraction = f;
  for (int k = 0; k < 4; ++k) {
    cell.texel[k] = clamp(corner + ivec2(k & 1, k >> 1), ivec2(0), size - 1);
    vec3 d = texelFetch(distortionMap, cell.texel[k], 0).xyz;
    float len2 = dot(d, d);
    cell.exit[k] = len2 > kMinDirectionLength2 ? d * inversesqrt(len2) : vec3(0.0);
  }
  float minCos = 1.0;
  for (int a = 0; a < 4; ++a)
    for (int c = a + 1; c < 4; ++c)
      if (cell.exit[a] != vec3(0.0) && cell.exit[c] != vec3(0.0)) minCos = min(minCos, dot(cell.exit[a], cell.exit[c]));
  cell.jump = clamp((kSpatialAgreeCosine - minCos) / (kSpatialAgreeCosine - kSpatialSplitCosine), 0.0, 1.0);
  return cell;
}

// Where the jump between the cell's texels lies, from the jump image (gpu_layout.h
// kSpatialPlaceTrust says how): the share of the pixel on the side of the texel of largest weight
// (own[k]: texel k is on it), or -1 where the cell does not qualify. scatter: the cell's
// scatterAfterOneJump. texelsDx, texelsDy: the screen axes' steps in texels. Mirrored by
// cpu_reference.cpp placedShare.
float placedShare(TexelCell cell, float scatter, vec2 texelsDx, vec2 texelsDy, out bool own[4]) {
  int r = 0;
  for (int k = 1; k < 4; ++k)
    if (cell.weight[k] > cell.weight[r]) r = k;
  float side[4];  // + the distance on r's side, - beyond
  float ownWeight = 0.0;
  bool across = false;
  for (int k = 0; k < 4; ++k) {
    own[k] = false;
    float cells = texelFetch(jumpMap, cell.texel[k], 0).x;  // the jump image's distance
    if (cell.exit[k] == vec3(0.0) || !(cells < kSpatialPlaceMaxCells)) return -1.0;
    own[k] = dot(cell.exit[k], cell.exit[r]) > kSpatialSplitCosine;
    across = across || !own[k];
    side[k] = own[k] ? cells : -cells;
    ownWeight += own[k] ? cell.weight[k] : 0.0;
  }
  if (!across || scatter > kSpatialPlaceMaxScatter) return -1.0;
  float fx = cell.fraction.x, fy = cell.fraction.y;
  float at = (1.0 - fy) * ((1.0 - fx) * side[0] + fx * side[1]) + fy * ((1.0 - fx) * side[2] + fx * side[3]);
  float alongX = (1.0 - fy) * (side[1] - side[0]) + fy * (side[3] - side[2]);
  float alongY = (1.0 - fx) * (side[2] - side[0]) + fx * (side[3] - side[1]);
  // The side function's change across the pixel: a linear function's box-filtered step.
  float width = abs(alongX * texelsDx.x + alongY * texelsDx.y) + abs(alongX * texelsDy.x + alongY * texelsDy.y);
  float placed = clamp(0.5 + at / max(width, 1e-6), 0.0, 1.0);
  return ownWeight + kSpatialPlaceTrust * (placed - ownWeight);
}

// The texels' weights for a placed jump: `share` of the pixel to the texels of side `own`, the rest
// to the others, each side's spread over its texels by their bilinear weights (at least 1e-4, so
// that a side the coordinate sits away from still has a colour). Mirrored by cpu_reference.cpp
// placedWeights.
float[4] placedWeights(TexelCell cell, bool own[4], float share) {
  float floorWeight[4], weights[4];
  float ownSum = 0.0, otherSum = 0.0;
  for (int k = 0; k < 4; ++k) {
    floorWeight[k] = max(cell.weight[k], 1e-4);
    if (own[k]) ownSum += floorWeight[k];
    else otherSum += floorWeight[k];
  }
  for (int k = 0; k < 4; ++k) weights[k] = floorWeight[k] * (own[k] ? share / ownSum : (1.0 - share) / otherSum);
  return weights;
}

// The cell's texels' own lookups blended by `weights` (the bilinear ones, or placedWeights), each
// divided by 1 + its luma (a firefly-robust average: gpu_layout.h kLumaRed); w = 0 where no texel
// with weight holds an exit.
vec4 cellColours(TexelCell cell, float weights[4], float footprint) {
  vec3 sum = vec3(0.0);
  float weight = 0.0;
  for (int k = 0; k < 4; ++k) {
    if (cell.exit[k] == vec3(0.0)) continue;
    vec3 c = lookupEnvironment(rotateByQuaternion(pc.worldFromObjectRotation, cell.exit[k]), footprint);
    float w = weights[k] / (1.0 + dot(c, vec3(kLumaRed, kLumaGreen, kLumaBlue)));
    sum += w * c;
    weight += w;
  }
  return weight > 0.0 ? vec4(sum / weight, 1.0) : vec4(0.0);
}

// A lookup's footprint widened by `blur` radians of uncertainty in its direction (added in
// quadrature: independent spreads). Mirrored by cpu_reference.cpp widenedFootprint.
float widenedFootprint(float footprint, float blur) { return sqrt(footprint * footprint + blur * blur); }

// How much wider than the pixel's share a lookup at a bilinearly filtered exit reads, in radians:
// the distortion image holds unit exits (without a throughput channel), so a filtered exit
// shorter than 1 blends texels that point apart, by about acos(length) (Toksvig's measure for
// filtered normals); beyond kFilteredExitSpreadThreshold the lookup widens by
// kFilteredExitSpreadBlur times the excess (gpu_layout.h). 0 for a field with throughput, whose
// length is the throughput. Mirrored by cpu_reference.cpp filteredExitBlur.
float filteredExitBlur(float len2) {
  if (pc.tint.a > 0.5 || !(len2 > kMinDirectionLength2)) return 0.0;
  return kFilteredExitSpreadBlur * max(acos(min(sqrt(len2), 1.0)) - kFilteredExitSpreadThreshold, 0.0);
}

// The transmitted light over the pixel, interpolating directions: the taps of
// lookupEnvironmentOverPixel, but each at the exit the distortion image holds at the tap's own
// place in the pixel (the field coordinate moved by the tap's offset along its derivatives), where
// it holds one, instead of the centre's exit moved linearly: near a silhouette or a jump the exit
// turns faster than linearly across a pixel.
// Each lookup widened by filteredExitBlur of its exit (exitBlur: the centre's). Mirrored by
// cpu_reference.cpp directionsOverPixel.
vec3 directionsOverPixel(vec3 exitWorld, float exitBlur, vec3 ddx, vec3 ddy, vec2 uv, vec2 uvDx, vec2 uvDy) {
  // No derivatives or one tap: nothing but the centre's exit is read.
  if ((ddx == vec3(0.0) && ddy == vec3(0.0)) || ENVIRONMENT_TAPS == 1u) {
    if (exitBlur == 0.0) return lookupEnvironmentOverPixel(exitWorld, ddx, ddy);
    float one = ddx == vec3(0.0) && ddy == vec3(0.0) ? 0.0 : directionFootprint(ddx, ddy) * kOneTapFootprintScale;
    return lookupEnvironment(exitWorld, widenedFootprint(one, exitBlur));
  }
  float n = float(ENVIRONMENT_TAPS);
  float footprint = directionFootprint(ddx / n, ddy / n);
  vec3 sum = vec3(0.0);
  for (uint j = 0u; j < ENVIRONMENT_TAPS; ++j) {
    for (uint i = 0u; i < ENVIRONMENT_TAPS; ++i) {
      float a = tapOffset(i, n), b = tapOffset(j, n);
      vec4 d = textureLod(distortionMap, uv + a * uvDx + b * uvDy, 0.0);
      float len2 = dot(d.xyz, d.xyz);
      vec3 tap = len2 > kMinDirectionLength2 ? rotateByQuaternion(pc.worldFromObjectRotation, d.xyz * inversesqrt(len2))
                                             : exitWorld + a * ddx + b * ddy;
      float blur = filteredExitBlur(len2);
      sum += lookupEnvironment(dot(tap, tap) > 1e-12 ? tap : exitWorld, widenedFootprint(footprint, blur));
    }
  }
  return sum / (n * n);
}

// The transmitted light over the pixel: directionsOverPixel where the texels around the centre
// agree, their own lookups' blend (cellColours, each at one tap's share of the footprint, widened
// by the cell's scatter beyond kSpatialScatterThreshold; placed by the jump image where the cell
// qualifies: placedShare) where they straddle a jump, linearly between (TexelCell.jump). Once per pixel, not per tap: at 4x4 supersampling the same images
// (within 0.01 dB), at 1 spp 0.06 dB less, for a quarter of the lookups (docs/encodings.md
// "Jumps across texels").
vec3 transmittedOverPixel(vec3 exitWorld, float exitBlur, vec3 ddx, vec3 ddy, vec2 uv, vec2 uvDx, vec2 uvDy) {
  TexelCell cell = readCell(uv);
  if (cell.jump == 0.0) return directionsOverPixel(exitWorld, exitBlur, ddx, ddy, uv, uvDx, uvDy);
  float footprint = directionFootprint(ddx / float(ENVIRONMENT_TAPS), ddy / float(ENVIRONMENT_TAPS));
  // Only here: a cell whose texels agree has no scatter to measure.
  float scatter = scatterAfterOneJump(cell.exit);
  float blur = kSpatialScatterBlur * max(scatter - kSpatialScatterThreshold, 0.0);
  vec2 size = vec2(textureSize(distortionMap, 0));
  bool own[4];
  float share = placedShare(cell, scatter, uvDx * size, uvDy * size, own);
  vec4 colours = cellColours(cell, share < 0.0 ? cell.weight : placedWeights(cell, own, share), widenedFootprint(footprint, blur));
  float t = cell.jump * colours.w;
  if (t == 1.0) return colours.rgb;  // the direction taps would weigh nothing
  return mix(directionsOverPixel(exitWorld, exitBlur, ddx, ddy, uv, uvDx, uvDy), colours.rgb, t);
}

// The world exit the distortion image holds at `uv`; zero where it holds none.
vec3 exitWorldAt(vec2 uv) {
  vec3 d = textureLod(distortionMap, uv, 0.0).xyz;
  float len2 = dot(d, d);
  return len2 > kMinDirectionLength2 ? rotateByQuaternion(pc.worldFromObjectRotation, d * inversesqrt(len2)) : vec3(0.0);
}

// The exit's change across one pixel along the screen axis whose field coordinate step is uvD,
// for the lookups' footprints: of the two one-sided differences to the exits the distortion image
// holds one pixel away (uv - uvD, uv + uvD), the gentler. Beside a jump the fine derivative
// (`fine`, kept where neither neighbour holds an exit) may span it and widen every lookup of the
// pixel to tens of degrees, which lit the cube's face-change lines with the sky's sun; the side
// away from the jump is the slope. On smooth glass the gentler side is the slower half of the
// divergence, which measured better than the central difference everywhere but on the bunny
// (docs/technique.md, "The exit's derivative beside a jump"). Mirrored by cpu_reference.cpp
// exitDerivative.
vec3 exitDerivative(vec3 exitWorld, vec3 fine, vec2 uv, vec2 uvD) {
  vec3 ahead = exitWorldAt(uv + uvD), behind = exitWorldAt(uv - uvD);
  if (ahead == vec3(0.0)) return behind == vec3(0.0) ? fine : exitWorld - behind;
  if (behind == vec3(0.0)) return ahead - exitWorld;
  vec3 forward = ahead - exitWorld, backward = exitWorld - behind;
  return dot(forward, forward) < dot(backward, backward) ? forward : backward;
}

void main() {
  vec3 n = normalize(inNormal);
  vec3 v = normalize(inPosition - pc.eyeObject.xyz);
  // Interpolated normals can face away near silhouettes; bend them back toward the viewer.
  float cosI = -dot(v, n);
  vec3 dPdx = dFdxFine(inPosition), dPdy = dFdyFine(inPosition);
  float coverage = SILHOUETTE_COVERAGE ? min(silhouetteCoverage(cosI), polygonCoverage(dPdx, dPdy)) : 1.0;
  if (cosI < 1e-4) {
    n = normalize(n + (1e-4 - cosI) * -v);
    cosI = -dot(v, n);
  }
  float ior = inFrontIor > 0.0 ? inFrontIor : pc.medium.x;
  float fresnel = fresnelDielectric(cosI, 1.0 / ior);

  // Bilinear between texel centres; level 0 (the atlas has no mip chain: gutters are one texel).
  vec4 d = textureLod(distortionMap, inFieldUv, 0.0);
  float len2 = dot(d.xyz, d.xyz);
  vec3 exitDirection = len2 > kMinDirectionLength2 ? d.xyz * inversesqrt(len2) : v;
  // Looked up, and measured, in world space.
  vec3 exitWorld = rotateByQuaternion(pc.worldFromObjectRotation, exitDirection);
  vec3 reflectedWorld = rotateByQuaternion(pc.worldFromObjectRotation, reflect(v, n));
  // Derivatives before any branch that is not uniform (fine derivatives of the quad's lanes): a
  // direction that diverges fast across the pixel reads blurrier levels instead of sparkling.
  vec3 exitDx = dFdxFine(exitWorld), exitDy = dFdyFine(exitWorld);
  vec2 uvDx = dFdxFine(inFieldUv), uvDy = dFdyFine(inFieldUv);
  vec3 reflectedDx = dFdxFine(reflectedWorld), reflectedDy = dFdyFine(reflectedWorld);
  if (len2 > kMinDirectionLength2) {
    exitDx = exitDerivative(exitWorld, exitDx, inFieldUv, uvDx);
    exitDy = exitDerivative(exitWorld, exitDy, inFieldUv, uvDy);
  }
  if (uint(pc.medium.w) == kModeFieldExitDirection) {  // the measured quantity itself
    outColor = vec4(exitWorld, d.w);
    return;
  }
  float transmittance = exp(-max(d.w, 0.0) * pc.medium.y);  // Beer-Lambert, natural units
  // A field with throughput stores direction * clamp(throughput, 0, 1) (gpu_layout.h): the
  // filtered length is the throughput, blended as the direction is. Others store unit lengths,
  // which bilinear filtering shortens between diverging texels: they must not be scaled.
  if (pc.tint.a > 0.5) transmittance *= min(sqrt(len2), 1.0);
  vec3 color = (1.0 - fresnel) * transmittance * pc.tint.rgb * transmittedOverPixel(exitWorld, filteredExitBlur(len2), exitDx, exitDy, inFieldUv, uvDx, uvDy);
  if (pc.medium.z > 0.5)
    color += fresnel * lookupEnvironmentOverPixel(reflectedWorld, reflectedDx, reflectedDy);
  outColor = vec4(color * pc.eyeObject.w, coverage);
}
