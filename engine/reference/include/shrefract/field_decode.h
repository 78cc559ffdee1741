// The CPU decode of a field, the mirror of the engine's decompression: the hemi-octahedral grid
// of the Table and Pca encodings, the coefficients summed at a direction, and a Volume field's
// paths traced through its grid. The bake fits and checks fields with it, tests hold the GPU to
// it; a host does not need it (shrefract_reference, not installed with the runtime).
#pragma once

#include <shrefract/field.h>

#include <array>
#include <cstdint>
#include <vector>

namespace shrefract {

// The hemi-octahedral grid of the Table and Pca encodings. A local direction w (z >= 0) maps to
//   p = (x, y) / (|x| + |y| + z),  (u, v) = ((p.x + p.y + 1) / 2, (p.x - p.y + 1) / 2) in [0,1]^2,
// the square whose border is the horizon. Node (i, j) of an N x N table sits at (i, j) / (N - 1),
// index j * N + i; a value is the bilinear blend of the 4 nodes around (u, v) (N >= 2).
struct HemiOctCoordinates {
  float u = 0.5f, v = 0.5f;
};
HemiOctCoordinates hemiOctFromDirection(float x, float y, float z);  // z is clamped to >= 0
// The unit local direction of node (i, j) of an N x N grid (inverse of the map above).
std::array<float, 3> hemiOctDirection(uint32_t i, uint32_t j, uint32_t n);
// The same at fractional grid coordinates (x, y) in [0, N - 1]^2, between nodes.
std::array<float, 3> hemiOctDirectionAt(float x, float y, uint32_t n);
// The 4 nodes around a direction and their bilinear weights (sum 1): node indices j * N + i.
struct HemiOctBilinear {
  std::array<uint32_t, 4> node{};
  std::array<float, 4> weight{};
};
HemiOctBilinear hemiOctBilinear(float x, float y, float z, uint32_t n);
// The cosines below which the jump-aware decode of an N x N table starts to discount a corner
// (full) and leaves it out (none), gpu_layout.h kJumpFullDegrees; the bake bisects between them.
// Mirrored by decompress_table.comp.
struct JumpCosines {
  float full = 1.0f;
  float none = 1.0f;
};
JumpCosines jumpCosines(uint32_t n);

// The linear sum of an encoding at a local direction, in out[0..decodedChannels()), before normalization,
// from one sample's coefficients a[layer * valuesPerLayer + value] (floats: dequantized, or a
// bake's fit before quantization) and, for Pca, the basis (field.h layout; nullptr otherwise).
// z is clamped to >= 0 (the engine does the same). The one implementation of the three sums.
// Table and Pca with shape.jumpAware blend the cell's corners across jumps of the exit direction as
// the engine does (docs/encodings.md, "Jumps"); otherwise plainly bilinearly. The sample's frame
// (frameRows: the 12 floats of M_s, as `frames` holds them) gives object-space exits: a field with
// shape.sampleFrameExits is rotated by it (without it, out stays in the sample's frame), and an
// object-space jump-aware field needs it for the straight-through exit (without it, bilinear).
// eyeJump (optional): the direction's distance from the nearest jump of the sample's table, in
// cells, as the decode placed it (0..gpu::kJumpDistanceMaxCells, the cap where the field stores no
// jump distance or none is within a cell): what the jump image holds (gpu_layout.h kBindingJumpOut).
void evaluateCoefficients(const EncodingShape& shape, const float* coefficients, const float* basis,
                          const std::array<float, 3>& localDirection, float* out, const float* frameRows = nullptr,
                          float* eyeJump = nullptr);

// The grid's signed distance at an object-space point, in object units (trilinear, clamped to the grid).
float volumeDistance(const FieldVolume& volume, const std::array<float, 3>& objectPoint);

// A Volume field's path for one sample (the decode of the Volume encoding): the view direction w in
// the sample's frame (as evaluateSample takes it, not clamped to the horizon) arrives at the sample's point
// and normal (from its frame's rows `frameRows`), refracts into media[1] and is traced through the
// grid under the field's path rule and bounce cap: marched along the trilinear distance until it
// changes sign, the crossing bisected, the interface's normal the trilinear normal there; a way
// out is marched on outside the object until it meets the object again (re-entering it, as the
// tracer's paths do: the torus's hole) or leaves the grid, and every interface counts toward the
// cap (docs/encodings.md, "Volume"). out[0..2]: the exit direction in object space (unit; a path
// still inside after maxBounces interfaces, or that leaves the grid without a crossing, leaves
// along its direction of travel), then the optical depth (path length inside times media[1]'s absorption)
// where the field has one, then the throughput (the Fresnel factors after the entry) where it has
// one. A sample whose eye lies below its tangent plane is not traced (no fragment reads it): the
// view passes by, optical depth 0, throughput 1. Mirrored by decompress_volume.comp. Preconditions: validateField(field), a
// Volume field. Returns the path it stored.
struct VolumePath;
VolumePath traceVolumeSample(const Field& field, const float* frameRows, const std::array<float, 3>& w, float* out);

// One path through a Volume field's grid, as traceVolumeSample follows it from a sample and the
// raster pass from a fragment (Object::tracesVolumePerFragment; volume_trace.glsl): the unit view
// direction `view` (toward the surface) meets it at `point` with unit normal `normal` (object
// space, facing the view), refracts in (or reflects: total internal reflection at the entry) and
// is followed as above. Preconditions as traceVolumeSample's.
struct VolumePath {
  std::array<float, 3> exit{};  // unit, object space
  float opticalDepth = 0.0f;    // path length inside times media[1]'s absorption
  float throughput = 1.0f;      // the Fresnel factors after the entry
  uint32_t steps = 0;           // distance reads along the way: march steps and bisections
  bool traced = true;           // false: traceVolumeSample left a sample facing away untraced
};
VolumePath traceVolumePath(const Field& field, const std::array<float, 3>& point, const std::array<float, 3>& normal,
                           const std::array<float, 3>& view);

// One sample's dequantized coefficients (texel of kind kTexelSample), as evaluateCoefficients reads
// them: out[layer * valuesPerLayer() + value], layerCount() * valuesPerLayer() floats. A caller that
// decodes one sample at many directions dequantizes it once. Preconditions as evaluateSample's.
void dequantizeSample(const Field& field, uint64_t texel, std::vector<float>& out);

// Decoded channels at a local direction of one sample (texel of kind kTexelSample): its dequantized
// coefficients through evaluateCoefficients. `order` below an SH field's order sums its first
// (order + 1)^2 bands only (Object::setDecodeOrder). Preconditions: validateField(field)
// succeeded, texel in range and a sample.
void evaluateSample(const Field& field, uint64_t texel, const std::array<float, 3>& localDirection, float* out,
                    uint32_t order = UINT32_MAX, float* eyeJump = nullptr);

}  // namespace shrefract
