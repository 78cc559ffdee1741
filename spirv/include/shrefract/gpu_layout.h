// Shared by GLSL and C++: descriptor binding numbers, push-constant layouts and constants.
// Nothing here is declared twice: shaders include this file, and so does the engine.
//
// Layout rules: push-constant blocks use std430 (the default for push constants); members are
// vec4/mat4 only, so C++ and GLSL agree on offsets without padding rules.
#ifndef SHREFRACT_GPU_LAYOUT_H
#define SHREFRACT_GPU_LAYOUT_H

#ifdef __cplusplus
#include <cstdint>
namespace shrefract::gpu {
struct vec4 { float x, y, z, w; };
struct uvec4 { uint32_t x, y, z, w; };
struct mat4 { float m[16]; };  // column-major, as in GLSL
#define SHR_CONST(name, value) inline constexpr uint32_t name = value;
#define SHR_CONSTF(name, value) inline constexpr float name = value;
#else
#define SHR_CONST(name, value) const uint name = value;
#define SHR_CONSTF(name, value) const float name = value;
#endif

// Descriptor set 0 of the raster pipelines: the environment (a sampler2D for a lat-long map, a
// samplerCube for a cube map; the shader variant is chosen by the environment's encoding).
SHR_CONST(kBindingEnvironment, 0u)
// Descriptor set 1 of the field raster pipeline: the object's distortion image (RGBA16F,
// bilinear, clamp to edge), sampled at the mesh's field texture coordinates.
SHR_CONST(kBindingDistortion, 0u)
// Set 1, also: the mesh's TriangleEdges, one per triangle in index order (storage buffer, fragment
// stage), read by the polygon silhouette coverage. Each vertex carries the index of the triangle it
// is the first corner of (the provoking vertex: the object pass reads it flat), so that no
// triangle needs gl_PrimitiveID (which would need the geometryShader feature).
SHR_CONST(kBindingTriangleEdges, 1u)
// Set 1, also: the object's jump image (R32F, a sampled image read with texelFetch and no sampler):
// per texel, how far the eye lies from the nearest jump of that sample's table, in table cells
// (kBindingJumpOut).
SHR_CONST(kBindingJumpDistance, 2u)
// Set 1, also: a Volume field's grid (VolumeHeader, then the voxel words: the same buffer as the
// decompression pass's kBindingBasis), which the per-fragment volume shading
// (object_volume_body.glsl, Object::tracesVolumePerFragment) traces each fragment's path through.
// A uniform texel buffer (R32_UINT, fragment stage), not a storage buffer: the fine derivatives of
// the traced exit need the helper invocations' traces, and lavapipe's helper invocations read
// zeros from storage buffers (measured: a constant word's derivative was non-zero along every
// triangle's edge). Other fields bind a placeholder that nothing reads.
SHR_CONST(kBindingVolumeGrid, 3u)
// shrefract/object.h TriangleEdges says what the members hold: edge[k] = (m, m . a), the edge's
// inward unit normal in the triangle's plane and its offset; neighbour[k] = (n', n' . a), the
// normal of the triangle across it and its offset.
struct TriangleEdges {
  vec4 edge[3];
  vec4 neighbour[3];
};

// Environment encodings.
SHR_CONST(kEnvironmentLatLong, 0u)
SHR_CONST(kEnvironmentCube, 1u)

// Shading modes of the object pass (ObjectPushConstants.medium.w).
SHR_CONST(kModeSingleInterface, 0u)
SHR_CONST(kModeField, 1u)
SHR_CONST(kModeFieldExitDirection, 2u)  // writes (exit direction, tau) instead of a colour

// Decompression compute pass, descriptor set 0 (one set per field object). Only sample texels are
// stored and decompressed: sample s (0 <= s < sampleCount, in increasing texel order) is texel
// sampleTexels[s]. Empty texels of the distortion image stay as createFromField cleared them (zero);
// gutter texels are written by the gutter pass. Two shaders read the same set: decompress.comp
// (Sh encoding) and decompress_table.comp (Table and Pca); the coefficients are laid out for each.
//
// Channels (field.h): 3 (x, y, z), 4 (x, y, z and tau, or x, y, z and the throughput) or 5 (x, y, z,
// tau, throughput); the throughput, when the field has one, is always the last channel.
//
// Sh coefficients: one invocation decompresses kDecompressSamplesPerInvocation = 4 consecutive
// samples and reads, per basis function i and channel c, one word (U8: that channel's byte of its
// 4 samples) or two (F16: the halves). The values form planes, one per (i, c) at p = i * channels +
// c, each holding paddedSamples = sampleCount rounded up to a multiple of 4 values (padding zero):
// value (p, s) is number p * paddedSamples + s. Consecutive invocations read consecutive words of
// a plane, and nothing is stored for channels a field does not have. (Measured on llvmpipe,
// docs/performance.md: faster than one invocation per sample reading its own 3 or 4 bytes, and than
// blocks holding a workgroup's planes contiguously.)
//
// Table and Pca coefficients: sample-major, one invocation per sample. The values of sample s are
// contiguous: value (s, layer, v) is element (s * layers + layer) * values + v, with layers = N^2
// (Table) or K (Pca) and values = channels (Table) or 1 (Pca, the component's weight). A sample
// reads only its own 4 grid nodes (Table) or K weights (Pca), at addresses no other sample shares,
// so planes would gain nothing; elements are not padded (U8: element e is bits 8 (e % 4) of word
// e / 4; F16: bits 16 (e % 2) of word e / 2).
//
// Values are bytes (U8: value = bias + scale * q / 255) or binary16 (F16), read as uint words
// (little-endian) through an R32_UINT texel buffer view (a storage buffer when the words exceed the
// device's maxTexelBufferElements, kSpecCoefficientsStorage: on llvmpipe a texel fetch is one
// vector gather, a storage-buffer read one load per lane).
SHR_CONST(kBindingCoefficients, 0u)     // usamplerBuffer (R32_UINT): the coefficients above
// Sh scale/bias (U8 only): per basis function i, SHR_SH_SCALE_BIAS_VEC4S(channels) vec4s from
// S = i * SHR_SH_SCALE_BIAS_VEC4S(channels): [S] scale / 255 of channels 0..3, [S + 1] their bias,
// and with 5 channels [S + 2] = (scale / 255, bias, 0, 0) of channel 4. A uniform buffer when the
// table fits in kMaxUniformScaleBiasBytes, the same bytes as a storage buffer otherwise
// (kSpecScaleBiasStorage). A macro, so that GLSL can size an array with it from spec constants.
#define SHR_SH_SCALE_BIAS_VEC4S(channels) ((channels) > 4 ? 3 : 2)
SHR_CONST(kBindingScaleBias, 1u)        // uniform: the Sh scale/bias table
SHR_CONST(kBindingFrames, 2u)           // vec4 frames[3 * sampleCount]: rows of M_s, sample s at 3s..3s+2
SHR_CONST(kBindingSampleTexels, 3u)     // uint sampleTexels[sampleCount]: texel index y * width + x
SHR_CONST(kBindingDistortionOut, 4u)    // image2D rgba16f: xyz = exit direction, w = tau
SHR_CONST(kBindingGutters, 5u)          // uvec4 gutters[]: (target, a, b, c) texel indices
// The Sh table as a storage buffer (tables too big for a UBO); for Table and Pca (U8 only) always
// this binding, as vec2 scaleBias[layers * values]: (scale / 255, bias) of (layer, value) at
// layer * values + value (the index a sample reads depends on its grid nodes: no uniform address).
SHR_CONST(kBindingScaleBiasStorage, 6u)
SHR_CONST(kBindingCoefficientsStorage, 7u) // uint coefficients[]: the coefficients as a storage buffer
// Pca only: float basis[K * N^2 * channels], function k at node n, channel c at (k * N^2 + n) *
// channels + c (field.h Field::basis, as stored).
SHR_CONST(kBindingBasis, 8u)
// image2D r32f, the jump image: per sample texel, the decoded distance from the eye's view to the
// nearest jump of the sample's table, in cells (the largest of interpolateCorners' signed distances,
// clamped to 0..kJumpDistanceMaxCells). Written by decompress_table.comp for fields with the jump
// distance channel; every other texel keeps the kJumpDistanceMaxCells it was cleared to (no jump
// within a cell: the raster pass does not place one there); the gutter pass extends it.
SHR_CONST(kBindingJumpOut, 9u)

// Specialization constants of the decompression shaders: the SH order L (bands 0..L evaluated),
// the stored channels (3, 4 or 5: nothing of an absent channel is read or summed), the
// quantization, and where the Sh scale/bias table is read from (false: the uniform buffer, when it
// fits in kMaxUniformScaleBiasBytes, orders up to 21 with 3 or 4 channels and 17 with 5; true: the
// storage buffer). kSpecThroughput: the last channel is the throughput. kSpecEncoding, kSpecTableSize
// and kSpecComponents select what decompress_table.comp decodes (Table: N; Pca: N and K);
// kSpecJumpAware: it blends the cell's corners jump-aware (field.h EncodingShape::jumpAware).
SHR_CONST(kSpecShOrder, 0u)
SHR_CONST(kSpecChannels, 1u)
SHR_CONST(kSpecQuantization, 2u)
SHR_CONST(kSpecScaleBiasStorage, 3u)
SHR_CONST(kSpecCoefficientsStorage, 4u)  // true: read the coefficients from the storage buffer
SHR_CONST(kSpecThroughput, 5u)
SHR_CONST(kSpecEncoding, 6u)
SHR_CONST(kSpecTableSize, 7u)
SHR_CONST(kSpecComponents, 8u)
SHR_CONST(kSpecJumpAware, 9u)
// The object pass's fragment shaders: taps per axis of a filtered environment lookup
// (RendererCreateInfo::environmentTapsPerAxis; default kEnvironmentTapsPerAxis).
SHR_CONST(kSpecEnvironmentTaps, 10u)
// decompress_table.comp: the field's last channel is the jump distance (EncodingShape::jumpDistance).
SHR_CONST(kSpecJumpDistance, 11u)
// Both decompression shaders: channels 0..2 hold the exit in the sample's frame (field.h
// EncodingShape::sampleFrameExits); the decode rotates it to object space with the frame's rows.
SHR_CONST(kSpecSampleFrameExits, 12u)
// object_field_body.glsl: the fragment's coverage of a smooth silhouette goes out as its alpha,
// blended over what is drawn (RendererCreateInfo::silhouetteCoverage, at one sample per pixel).
SHR_CONST(kSpecSilhouetteCoverage, 13u)
// object_volume_body.glsl: a pixel whose traced paths disagree is traced again with more
// (RendererCreateInfo::refineVolumePaths).
SHR_CONST(kSpecRefineVolumePaths, 14u)
// decompress_table.comp: a clustered Pca field (EncodingShape::clustered): each sample's
// coefficients are one 16-bit function index, two to a 32-bit word, sample s in the low half of
// word s / 2 when s is even; the sample decodes that function of the basis, whole. The basis
// (kBindingBasis) then holds binary16 values, two to a word in the same order.
SHR_CONST(kSpecClustered, 14u)
// Largest scale/bias table read as a uniform buffer: the maxUniformBufferRange every device offers,
// so that the choice (and the code path) is the same on every device.
SHR_CONST(kMaxUniformScaleBiasBytes, 16384u)
SHR_CONST(kQuantizationU8, 0u)   // field.h Quantization::U8
SHR_CONST(kQuantizationF16, 1u)  // field.h Quantization::F16
SHR_CONST(kEncodingSh, 0u)       // field.h Encoding::Sh
SHR_CONST(kEncodingTable, 1u)    // field.h Encoding::Table
SHR_CONST(kEncodingPca, 2u)      // field.h Encoding::Pca
SHR_CONST(kEncodingVolume, 3u)   // field.h Encoding::Volume
// decompress_volume.comp (and field_decode.h traceVolumeSample): the basis binding (kBindingBasis) holds
// VolumeHeader, then the grid's bricks (field.h FieldVolume): ceil(N / kVolumeBrickSide)^3 entries,
// then the stored bricks' kVolumeApronWords voxel words each: a brick's kVolumeBrickSide^3 voxels
// and one more along each axis (the next brick's first, the grid's last where none), x fastest, so
// that the 8 voxels of the trilinear cell at any voxel of the brick are read through one entry.
// A cell whose brick is an entry (beyond the band) reads its far word at all 8 corners. A path
// marches from its start by kVolumeStartStep voxels, then by kVolumeStepScale times the grid's
// distance there, at least kVolumeMinStep voxels, at most kVolumeMaxSteps steps a segment, bisects the step that
// turns the distance positive kVolumeBisections times and takes the zero of the line through the
// last interval's ends (docs/encodings.md, "Volume").
SHR_CONSTF(kVolumeStartStep, 0.05f)
SHR_CONSTF(kVolumeMinStep, 0.2f)
SHR_CONSTF(kVolumeStepScale, 1.0f)
SHR_CONST(kVolumeMaxSteps, 4096u)
SHR_CONST(kVolumeBisections, 6u)
// The normal at a crossing blends the 8 voxels' normals that lie within acos(kVolumeNormalBlendCos)
// (45 deg) of the nearest voxel's, so that an edge of the surface stays sharp.
SHR_CONSTF(kVolumeNormalBlendCos, 0.70710678f)
// A voxel word (field.h FieldVolume): the distance's level (bits 0..7, kVolumeDistanceMask) is
// kVolumeDistanceZero at 0 and 0 or 2 kVolumeDistanceZero at -+kVolumeBandVoxels; a normal
// coordinate's (12 bits from kVolumeNormalShiftX and kVolumeNormalShiftY, kVolumeNormalMask) is
// kVolumeNormalZero at 0 and 0 or 2 kVolumeNormalZero at -+1.
SHR_CONST(kVolumeDistanceZero, 127u)
SHR_CONST(kVolumeDistanceMask, 0xffu)
SHR_CONST(kVolumeNormalMask, 0xfffu)
SHR_CONST(kVolumeNormalShiftX, 8u)
SHR_CONST(kVolumeNormalShiftY, 20u)
// The grid's bricks (field.h FieldVolume): kVolumeBrickSide^3 voxels each, x fastest. A brick's
// entry is the index of its words among the stored bricks, or kVolumeBrickOutside /
// kVolumeBrickInside for a brick that lies wholly beyond the band on that side, which is not
// stored: its every voxel reads as the far word (field.h volumeFarWord).
SHR_CONST(kVolumeBrickSide, 8u)
SHR_CONST(kVolumeBrickWords, 512u)
SHR_CONST(kVolumeApronSide, 9u)
SHR_CONST(kVolumeApronWords, 729u)
SHR_CONST(kVolumeBrickInside, 0xfffffffeu)
SHR_CONST(kVolumeBrickOutside, 0xffffffffu)
// On the device a far brick's entry is kVolumeBrickFar + (its farReach << 1) + 1 outside, + 0
// inside (field.h FieldVolume::farReach): a march in it steps at least to the edge of the cube of
// far bricks that reach spans.
SHR_CONST(kVolumeBrickFar, 0xff000000u)
SHR_CONST(kVolumeNormalZero, 2047u)
SHR_CONSTF(kVolumeBandVoxels, 4.0f)
// Workgroup sizes: the Sh decompression runs one invocation per 4 samples, the Table and Pca
// decompression one per sample, 64 to a workgroup (whole subgroups on every device: 8 x 8 SIMD
// lanes on llvmpipe, 2 x 32 on NVIDIA, 1 x 64 on AMD); the gutter pass runs one invocation per rule.
SHR_CONST(kDecompressSamplesPerInvocation, 4u)
SHR_CONST(kDecompressLocalSize, 64u)
SHR_CONST(kGutterLocalSize, 64u)
// Both passes dispatch at most this many workgroups in x (the limit every device offers is 65535)
// and the rest as further rows in y; the shaders number invocations row after row.
SHR_CONST(kMaxDispatchGroupsX, 32768u)

// The head of a Volume field's basis buffer (decompress_volume.comp): grid.x = N, grid.y = the
// bounce cap, grid.z = 1 for the highest-energy rule (0: first refraction), grid.w = 1 for a convex object
// (field.h FieldVolume::convex: the trace stops at the first way out); origin.xyz the centre
// of voxel (0, 0, 0) in object space, origin.w the voxel spacing; media.x = n_outside / n_inside
// (the entry), media.y its inverse (the way out), media.z the inner medium's absorption.
struct VolumeHeader {
  uvec4 grid;
  vec4 origin;
  vec4 media;
};

// A decoded sum (or a bilinear sample of decoded directions) whose squared length is at most
// this has no direction: decompression writes the zero vector, and the raster pass then looks
// straight through the surface (the view direction).
//
// Distortion image texels (both decompression shaders): xyz = the normalized direction (zero as
// above), times clamp(throughput, 0, 1) when the field has a throughput channel, so that the
// sampler's bilinear filter blends throughput and direction together and the raster pass reads
// the throughput back as min(|d.xyz|, 1) (ObjectPushConstants.tint.a); w = tau clamped to
// +-kMaxOpticalDepth (0 without an optical depth channel).
SHR_CONSTF(kMinDirectionLength2, 1e-20f)
// Optical depth is clamped to the finite range of the RGBA16F distortion image.
SHR_CONSTF(kMaxOpticalDepth, 65504.0f)

// Jump-aware interpolation of the Table and Pca cells (decompress_table.comp, field_decode.cpp
// interpolateCorners and jumpCosines, docs/encodings.md "Jumps"): a corner whose estimate of the
// exit is more than an angle `none` from the dominant corner's is left out, one within `full`
// kept, linearly in the cosine between; the result replaces the bilinear one by
// min(1, kJumpBlendGain x the weight left out). The bake bisects the edges whose corners are more
// than midway apart. The angles scale with the cell: up to kJumpReferenceTableSize nodes a side
// they are kJumpFullDegrees and kJumpNoneDegrees (chosen at 16x16: hard thresholds of 30 or 40 deg
// and a 30..50 deg ramp did as well; a gain of 4 kept half the gain on the cube, 19.95 against
// 21.31 dB at 16 and 21.46 for a step); above, times kJumpReferenceTableSize / N, but not under
// kJumpFullMinDegrees and kJumpNoneMinDegrees. At the default 64x64 (16 and 28 deg; a cell spans
// 2.8 deg) the cube's and glass's jumps of 25 to 40 deg had been decoded half-kept, to directions
// between the sides: fields baked with 16 / 28 deg read (linear measure, 4x4) glass of water 23.96
// dB against 23.29, cube 30.52 and torus 25.35 against 30.52 and 25.33; 12 / 20 deg lost the torus
// 0.2 dB (docs/encodings.md "The ramp across a jump").
SHR_CONST(kJumpReferenceTableSize, 16u)
SHR_CONSTF(kJumpFullDegrees, 25.0f)
SHR_CONSTF(kJumpNoneDegrees, 45.0f)
SHR_CONSTF(kJumpFullMinDegrees, 16.0f)
SHR_CONSTF(kJumpNoneMinDegrees, 28.0f)
SHR_CONSTF(kJumpBlendGain, 16.0f)
// The side of a jump is chosen by weighting each corner's view of the cell by its bilinear
// weight to this power: a soft argmax. Steeper is sharper and flickers more as the eye moves
// (docs/encodings.md "Jumps": probe PSNR on the cube 20.30, 20.63, 20.93, 21.05 dB for powers
// 2, 4, 6, 12 and 21.31 for a hard argmax; orbit flicker on the torus 1.56, -, 1.65, - and 1.72
// times the reference's, 1.50 for plain bilinear).
SHR_CONSTF(kJumpDominancePower, 4.0f)
// ... for tables traced at their nodes (DirectionSampling::Nodes: node values are exact exits on
// either side of a jump, where a fit blurs a jump into a ramp whose corners disagree without a
// side to choose; measured: fitted Pca tables decoded jump-aware erred more, 5.8 to 6.8 deg mean
// on the cube in tests/bake/encoding_test.cpp) of at least this many nodes a side. A corner's estimate moves the exit by the
// change of the straight-through direction across the cell, so a field constant in the view
// direction has estimates as far apart as the cell's corners: at N = 12 a cell spans under about
// 17 deg, inside kJumpFullDegrees; coarser cells span as much as the jumps they would have to find.
SHR_CONST(kJumpMinTableSize, 12u)
// Fields with the jump distance channel (field.h EncodingShape::jumpDistance): each node stores its
// distance d in grid cells to the nearest jump (bisected by the bake, at most
// kJumpDistanceMaxCells), as d * kJumpDistanceScale / (N - 1), about the angle those cells span,
// so that the Pca weighs an error in it like an error of the exit direction (probe on the cube:
// 25.60 dB at this scale, 25.21 at half of it, 24.68 at 1 per cell). The decode interpolates the
// corners' distances, signed by which side of the cell's jump each corner is on: zero on the jump,
// exact for a straight one. A view of the cell counts in full where that interpolated distance
// puts the eye on its side by kJumpDistanceSoftness cells, linearly from the jump. Within the ramp
// the decode blends the two sides' exits, a direction no path takes, so the ramp is kept about as
// narrow as the channel is accurate (bisected to 1/32 cell; the Pca reconstructs it to 0.013 to
// 0.019 cells RMS at the cube's default view): default fields (64x64 nodes), linear measure at
// 4x4, cube 30.25 / 30.50 / 30.52 dB for 0.1 / 0.05 / 0.02 cells, torus 25.30 / 25.30 / 25.33,
// glass of water 23.25 / 23.28 / 23.29 (docs/encodings.md "The ramp across a jump").
SHR_CONSTF(kJumpDistanceScale, 3.14159265f)
SHR_CONSTF(kJumpDistanceMaxCells, 1.0f)
SHR_CONSTF(kJumpDistanceSoftness, 0.02f)
// A side's estimate at w (interpolateCorners): a plane through its corners' values, least
// squares over the corners at their offsets from w (in cells), each weighted by kept_j keep_j^4
// (the 4th power: corners only partly on the side barely tilt it) with this ridge on the two
// slopes. One corner: its value (the slopes stay 0); three or four: the plane through them,
// extrapolated to w. Measured (linear measure, default fields, 4x4): cube 26.95 -> 27.14, torus
// 23.47 -> 23.52, glass of water 22.56 -> 22.82 dB; ridge 0.005 / 0.02: cube 27.15 / 27.14, torus
// 23.47 / 23.43, glass 22.77 / 22.73; weights kept_j alone (no power), ridge 0.005: cube 26.17.
SHR_CONSTF(kJumpSideSlopeRidge, 0.001f)
// Every view keeps this much of its bilinear weight, so that a cell whose views all put w on the
// other side (three sides meeting) still decodes to their bilinear blend.
SHR_CONSTF(kJumpDistanceFloor, 1e-4f)

// Filtered environment lookups (environment.glsl environmentLevel, docs/technique.md): the
// level is log2(footprint / texel angle) + this bias, for each tap's share of the footprint (below).
// The level whose texels are as wide as the footprint, read bilinearly, blurs over a tent about
// twice the footprint (its own box, then the bilinear tap). With one tap per lookup half a level
// finer measured best; with 2x2 taps, each reading the level of its own cell, none (the field's
// own noise on the cube and the glass of water wants the blur; docs/technique.md, "Taps").
SHR_CONSTF(kEnvironmentLevelBias, 0.0f)
// A filtered lookup averages this many taps per axis over the parallelogram its direction sweeps
// across the pixel (environment_select.glsl lookupEnvironmentOverPixel), each at the level of its
// own share of the footprint: closer to the pixel's box than one tap of the level chain, whose
// support is about twice the footprint (bright, small sources spread over too many pixels), and
// anisotropic where the direction sweeps along one axis (docs/technique.md, "Taps").
// The default; a host picks 1 to kMaxEnvironmentTapsPerAxis per renderer (RendererCreateInfo).
SHR_CONST(kEnvironmentTapsPerAxis, 4u)
SHR_CONST(kMaxEnvironmentTapsPerAxis, 4u)
// One tap per axis reads the footprint scaled by this (a level bias of -0.5): one trilinear
// lookup spreads over about twice the footprint, and half a level finer measured best for it
// (docs/technique.md, "Level bias"; with more taps each reads its own cell's level, unscaled).
SHR_CONSTF(kOneTapFootprintScale, 0.70710678f)
// The per-fragment volume shading (object_volume_body.glsl) traces this many paths per axis of
// the pixel (at most the renderer's environment taps), each at its own sub-pixel place, and reads
// the environment over each one's cell with the rest of the taps: one path per pixel aliased what
// the texture-space shading's taps, reading many texels across the pixel, do not (the cube at one
// sample per pixel: 30.51 dB with one path, 31.52 with 2x2, 31.86 with 3x3 at 9 traces; the
// bunny 19.76, 21.73, 22.31; docs/encodings.md, "Volume traced per fragment").
SHR_CONST(kVolumeTracedTapsPerAxis, 2u)
// Where one of those paths leaves more than acos(kVolumeRefineCosine) away from the centre path's
// exit, the pixel straddles a path discontinuity (a bounce that changes within it: the torus's
// inner rim, the bunny's folds) and is traced again with kVolumeRefinedTapsPerAxis^2 paths, each
// looked up over its own cell; elsewhere the 2x2 paths stand. Only where the transmitted term
// weighs at least kVolumeRefineWeight ((1 - F) times the transmittance): at a smooth rim the
// grazing paths bounce many times, cost the most and show least (the sphere's rim refined at
// 10 deg: 2.4x its frame on lavapipe for 0.03 dB; with the weight, 0.96x and the 2x2 image).
// 10 deg against 3, both with the weight (the torus at one sample per pixel: 26.88 against 27.20 dB
// for 1.73x against 2.03x the frame). docs/technique.md, "Refined paths where the volume's exits part".
SHR_CONSTF(kVolumeRefineCosine, 0.98480775f)  // cos 10 deg
SHR_CONST(kVolumeRefinedTapsPerAxis, 4u)
SHR_CONSTF(kVolumeRefineWeight, 0.5f)

// Jumps across texels (object_field_body.glsl transmittedOverPixel, docs/encodings.md "Jumps
// across texels: blending colours"): where the four texels around a fragment are within
// acos(kSpatialAgreeCosine) of each other the raster pass blends their exits as directions; where
// some pair is beyond acos(kSpatialSplitCosine) it blends their own environment lookups, linearly
// between. A direction blended across a jump points at a part of the environment no path sees;
// the blended colours are the expected colour while the jump's place in the cell is unknown.
// Measured (default fields, 4x4, against the physical reference): 3 and 10 deg best over the four
// built-in scenes; 2 and 8 gained more on the cube and the glass of water and less on the torus;
// 1 and 4 lost 0.2 dB on the sphere (a smooth field's texels blend as colours too: a blur).
// Silhouette coverage (object_field_body.glsl silhouetteCoverage, cpu_reference.cpp): where a
// smooth surface turns away, the cosine c between the view and the interpolated normal falls to 0
// as the square root of the distance to the silhouette, so c / |grad c| is twice that distance
// (in pixels); the fragment covers 0.5 + kSilhouetteCoverageScale c / |grad c| of its pixel
// (clamped to 0..1). Measured (the sphere's 64x64 field, 1 spp, linear PSNR against the 4x4 full
// tree): 0.5 30.26 dB, 1 30.08, 0.25 30.21, none 29.84.
SHR_CONSTF(kSilhouetteCoverageScale, 0.5f)
SHR_CONSTF(kSpatialAgreeCosine, 0.99862953f)  // cos 3 deg
SHR_CONSTF(kSpatialSplitCosine, 0.98480775f)  // cos 10 deg
// Scatter in a jump cell (object_field_body.glsl scatterAfterOneJump): where the four texels'
// exits still spread once one jump may split them, the exit changes faster than the texels
// resolve (a chaotic field such as the bunny's, paths that cross many faces), and the pixel sees a
// spread of directions, not the four texels' exits; each colour lookup of the blend then reads
// its footprint widened by kSpatialScatterBlur times the scatter beyond kSpatialScatterThreshold
// (radians, added in quadrature). Smooth cells and clean jumps have no scatter beyond it. Measured
// (64x64 fields, linear PSNR against the 4x4 full tree, 1 spp / 4x4, docs/encodings.md
// "Scatter"): bunny 14.45 / 14.54 -> 14.85 / 15.09, torus 24.12 / 25.22 -> 24.30 / 25.45, others
// within 0.03 dB or better; no threshold lost 1 dB on the torus, whose texels differ by a few
// degrees nearly everywhere and read sharp structure.
SHR_CONSTF(kSpatialScatterThreshold, 0.15f)
SHR_CONSTF(kSpatialScatterBlur, 4.0f)
// Placing a jump across texels (object_field_body.glsl placedColours, docs/encodings.md "Placing
// the jump between texels"). The blend above is the expected colour while the jump's place in the
// cell is unknown; the jump image tells it. A texel's distance (in its table's cells) from the eye's
// view to the jump its path is next to changes linearly as the surface point moves toward the place
// where the path changes, and is zero there; signed + for the texels on one side and - for the
// others, the four interpolate bilinearly to a function that is zero on the jump in the image
// (exactly, for a straight jump that moves uniformly). The fragment's share on each side follows
// from that function and its change across the pixel. Placed only where it can hold: all four
// texels within kSpatialPlaceMaxCells of a jump (a cell's cap means none near), two clean groups
// (scatter within kSpatialPlaceMaxScatter radians: the torus, whose cells hold curved or several
// jumps, lost 0.28 dB without it) split at kSpatialSplitCosine from the texel of largest weight.
// The table's jump need not be the one between the texels, so the placed share is trusted by
// kSpatialPlaceTrust and the bilinear one keeps the rest (measured, CPU raster, default fields, 1 spp
// / 4x4: trust 1 cube 29.44 / 31.46, 0.75 29.61 / 31.47, 0.6 29.70 / 31.40; the blend alone 29.79 /
// 30.65).
SHR_CONSTF(kSpatialPlaceMaxCells, 0.99f)
SHR_CONSTF(kSpatialPlaceMaxScatter, 0.05f)
SHR_CONSTF(kSpatialPlaceTrust, 0.75f)
// A bilinearly filtered exit shorter than 1 blends texels that point apart (object_field_body.glsl
// filteredExitBlur): where acos(length) exceeds kFilteredExitSpreadThreshold (radians) its lookup
// reads a footprint widened by kFilteredExitSpreadBlur times the excess. The threshold stays above
// what binary16 rounding of unit exits reads (without one every lookup blurred: the cube 29.09 ->
// 17.85 dB); the factor makes a tap between texels far apart read the coarse levels. Measured
// (64x64 fields, linear PSNR against the 4x4 full tree, 1 spp; docs/technique.md "Taps
// between texels that point apart"): sphere 30.94 -> 31.24, cube 27.26 -> 27.33, glass of water
// 22.71 -> 22.77, torus 24.30 -> 24.32; 4x4 within +0.02 dB; 0.05 lost 0.2 dB on the torus.
SHR_CONSTF(kFilteredExitSpreadThreshold, 0.08f)
SHR_CONSTF(kFilteredExitSpreadBlur, 16.0f)
// The colour blend weighs each texel's colour c by its bilinear weight / (1 + luma(c)) (Rec. 709
// luma), a firefly-robust average: a texel whose decoded exit strays onto a bright part of the
// sky would otherwise light its whole cell (torus, blending from 10 to 25 deg: 23.08 dB with plain
// weights, 23.39 with these, 23.38 blending directions everywhere).
SHR_CONSTF(kLumaRed, 0.2126f)
SHR_CONSTF(kLumaGreen, 0.7152f)
SHR_CONSTF(kLumaBlue, 0.0722f)

// Texel roles as stored in the kinds buffer (the values of field.h's kTexel* constants).
SHR_CONST(kGpuTexelEmpty, 0u)
SHR_CONST(kGpuTexelSample, 1u)
SHR_CONST(kGpuTexelGutter, 2u)

// Background pass: the environment seen through the camera.
struct BackgroundPushConstants {
  mat4 worldDirFromClip;  // maps clip-space (x, y, 1, 1) to an unnormalized world direction
};

// Object pass. Vertex positions, normals and the field are in object space (fields are baked
// there); the pass shades in object space, with the eye brought into it, and turns the directions
// it looks up (exit, reflection) to world space with the instance's rotation. A uniform scale s
// changes no direction, only lengths: the absorption per object-space unit is k * s.
struct ObjectPushConstants {
  mat4 clipFromObject;
  vec4 eyeObject;  // xyz: eye position in object space; w: exposure
  vec4 medium;     // x: IOR of the object where the mesh has no per-vertex frontIor (0),
                   // y: absorption scale per object-space unit (k * s), z: reflection on (1) or off (0),
                   // w: shading mode (kMode*)
  vec4 tint;       // rgb: attenuation colour; a: 1 when the distortion image carries the throughput
  vec4 worldFromObjectRotation;  // unit quaternion (x, y, z, w)
};
// Decompression and gutter passes.
struct DecompressPushConstants {
  vec4 eyeObject;  // xyz: eye position in the field's (object) space; w unused
  uvec4 size;     // x: atlas width, y: atlas height, z: number of gutter rules, w: sample count
};

#ifdef __cplusplus
static_assert(sizeof(BackgroundPushConstants) == 64);
static_assert(sizeof(ObjectPushConstants) <= 128, "within the 128 bytes every device offers");
static_assert(sizeof(DecompressPushConstants) == 32);
}  // namespace shrefract::gpu
#endif
#undef SHR_CONST
#undef SHR_CONSTF
#endif  // SHREFRACT_GPU_LAYOUT_H
