// The refraction field: what the baker writes and the engine replays.
//
// For every surface sample s (a texel of the sample atlas) and every view direction w over the
// hemisphere of the sample's local frame, the bake traced where the refracted path leaves the
// object (a unit direction, in object space or in the sample's own frame: `sampleFrameExits`), how
// much optical depth it crossed and, optionally, the Fresnel throughput of the path. These channels
// (x, y, z, [tau], [throughput]) are functions on the hemisphere (node-sampled Table and Pca fields
// may add a last channel that only guides their decode: the distance to the nearest jump of the
// exit direction, docs/encodings.md "Jumps"), stored in one of three encodings (docs/encodings.md):
//  - Sh: real SH coefficients of order L (see shrefract/sh.h), the paper's scheme;
//  - Table: the values at the N x N nodes of a hemi-octahedral grid, bilinear between nodes;
//  - Pca: K weights per sample of a basis learned from the whole field (each basis function a
//    hemi-octahedral table of all channels, stored once per field); or, clustered, the index of
//    one of K tables (the mean table of the sample's cluster): 2 bytes per sample.
// All three are linear: value_c(s, w) = sum_j a_j(s) * B_j,c(w) over the field's layers j, with
// B_j the SH function, the bilinear hat of node j, or the learned basis function j.
//
// The local frame: w = normalize(M_s * (eye, 1)) where M_s (3 rows of 4 floats, `frames`) maps a
// world-space eye position to the direction toward the eye in the sample's frame (z = normal).
//
// This header is the in-memory form; docs/field-format.md specifies the `.shrf` file.
#pragma once

#include <shrefract/result.h>

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace shrefract {

// The `.shrf` version that serializeField writes (docs/field-format.md, "Versioning").
inline constexpr uint32_t kFieldFormatVersion = 9;
// The oldest version parseField reads. An older version is read only where the current reader
// handles its layout with no branch of its own; every other one is refused as Unsupported with
// one line: "FILE: field format version V is no longer read; bake the field again with this
// version of shrefract". No version before 9 reads that way, so 9 is the only one read.
inline constexpr uint32_t kOldestReadFieldFormatVersion = 9;

// Largest magnitude of a decoded coefficient (validateField, encodeCoefficients). With at most
// 1089 basis functions (order 32) the sum of |Y_i| is at most 1089 / sqrt(4 pi) = 307, so every
// SH sum stays below 3.1e17 and its squared length below 3e35: finite in float, with margin for
// rounding. Baked coefficients are unit directions and optical depths, far below it.
inline constexpr float kMaxCoefficientMagnitude = 1e15f;
// Largest magnitude of a frame entry (validateField). Baked frames hold unit axes and minus the
// sample's position along them; with entries up to 1e15, M_s (eye, 1) stays finite in float for
// every eye within 1e22 of the origin (3 * 1e15 * 1e22 + 1e15 < 3.4e38).
inline constexpr float kMaxFrameMagnitude = 1e15f;

enum class SampleLayout : uint32_t {
  Split = 0,   // revised technique: one texel patch per triangle, continuity-corrected gutters
  Charts = 1,  // straightforward technique: samples are texels of a chart atlas (seams at borders)
};

enum class Quantization : uint32_t {
  U8 = 0,   // 8 bits per channel with a per-basis-function, per-channel scale and bias
  F16 = 1,  // IEEE binary16
};

enum class SmoothingWindow : uint32_t { None = 0, Hann = 1, Lanczos = 2 };

// How the hemisphere functions of a sample are stored (see the top of this file).
// Sh, Table and Pca store each sample's exits as a function of the view direction. Volume stores
// none: the object's signed distance and normals on a voxel grid, shared by every sample, through
// which the decompression traces each sample's path for the eye (docs/encodings.md, "Volume").
enum class Encoding : uint32_t { Sh = 0, Table = 1, Pca = 2, Volume = 3 };

// Which view directions the bake traces for each sample (docs/encodings.md, "Sampling").
enum class DirectionSampling : uint32_t {
  // The (theta, phi) grid of directionsTheta x directionsPhi, fitted by least squares (SH) or by
  // the regularized table fit (Table, Pca).
  Grid = 0,
  // Table and Pca only: the N x N nodes of the hemi-octahedral table themselves, each node holding
  // the exit of the path traced at its direction (directionsTheta and Phi are not used).
  Nodes = 1,
};

// The frame a field's exit directions are stored in (docs/encodings.md, "Exits in the sample's
// frame"). A field stores Object or Sample; Auto is a bake's request: trace in the sample's frame
// and, for Pca, keep whichever frame leaves the smaller rank-K residual of the tables.
enum class ExitFrame : uint32_t { Object = 0, Sample = 1, Auto = 2 };

// How an SH bake fits each sample's expansion to its traced directions (docs/technique.md, "Robust
// fit").
enum class ShFit : uint32_t {
  LeastSquares = 0,  // regularized least squares over the grid directions
  // The same, iteratively reweighted: a direction the expansion misses by far counts less, so that
  // a jump of the exit (another face, a trapped path) no longer rings over the directions it shares
  // the hemisphere with.
  Robust = 1,
};

// Which branch a single traced path follows at every interface (docs/technique.md).
enum class PathRule : uint32_t {
  HighestEnergy = 0,    // the paper: the branch with the larger Fresnel factor
  FirstRefraction = 1,  // refract wherever refraction is possible, reflect only on total internal reflection
};

const char* toString(SampleLayout layout);
const char* toString(Quantization quantization);
const char* toString(SmoothingWindow window);
const char* toString(Encoding encoding);
const char* toString(PathRule rule);
const char* toString(DirectionSampling sampling);
const char* toString(ExitFrame frame);
const char* toString(ShFit fit);

// Largest table size N (nodes per side) of the Table encoding and of Pca basis functions, and the
// largest number of Pca components.
inline constexpr uint32_t kMaxTableSize = 64;
inline constexpr uint32_t kMaxComponents = 1024;
// Largest number of tables of a clustered Pca field (EncodingShape::clustered): its index is 16
// bits and it sums nothing, but every table is stored (4096 tables of 64x64 nodes and 5 channels
// are 168 MB of binary16).
inline constexpr uint32_t kMaxClusters = 4096;

// Voxels per side of a Volume field's grid: 8 to 512 (a grid over the device's buffer limits is
// refused at upload), and the tool's default (docs/encodings.md, "Volume").
inline constexpr uint32_t kMinVolumeSize = 8;
inline constexpr uint32_t kMaxVolumeSize = 512;
inline constexpr uint32_t kDefaultVolumeSize = 128;

// A Volume field's grid: N^3 voxels, voxel (i, j, k) centred at origin + (i, j, k) * spacing
// (object space). Each voxel is one 32-bit word (packVolumeVoxel): bits 0..7 the signed distance
// from its centre to the object's surface in voxels (negative inside the medium; 255 levels over
// +-kVolumeBandVoxels, 0 exact; beyond the band the band's end with its sign), bits 8..19 and
// 20..31 the unit normal of the nearest surface point, octahedral (4095 levels over [-1, 1] a
// coordinate, 0 and +-1 exact; gpu_layout.h kVolumeDistanceZero and kVolumeNormalZero). Decoded
// by trilinear interpolation of the 8 voxels around a point (the distance; the normals of the
// corners that face the nearest one's way, then normalized). Mirrored by decompress_volume.comp.
//
// Stored in bricks of kVolumeBrickSide^3 voxels: only the bricks the band reaches hold words.
// Beyond the band a voxel holds nothing but its side (volumeFarWord), so a brick wholly beyond it
// is an entry, not 512 words (docs/encodings.md, "Bricks").
inline constexpr float kVolumeBandVoxels = 4.0f;  // gpu_layout.h kVolumeBandVoxels
inline constexpr uint32_t kVolumeBrickSide = 8;   // gpu_layout.h kVolumeBrickSide
inline constexpr uint32_t kVolumeBrickWords = kVolumeBrickSide * kVolumeBrickSide * kVolumeBrickSide;
inline constexpr uint32_t kVolumeBrickInside = 0xfffffffeu;   // gpu_layout.h: a brick beyond the band, inside
inline constexpr uint32_t kVolumeBrickOutside = 0xffffffffu;  // and outside
// The bounce cap (BakeRecord::maxBounces) a Volume field may ask its decode to trace.
inline constexpr uint32_t kMaxVolumeBounces = 1024;
struct FieldVolume {
  uint32_t size = 0;  // N; 0 for the other encodings
  std::array<float, 3> origin{0.0f, 0.0f, 0.0f};
  float spacing = 0.0f;
  // Per brick (volumeBricksPerSide(N)^3 of them, brick (a, b, c) at (c * B + b) * B + a), the index
  // of its words in brickVoxels (kVolumeBrickWords each, voxel (x, y, z) of the brick at
  // (z * 8 + y) * 8 + x), or kVolumeBrickInside / kVolumeBrickOutside. Set by setVolumeVoxels.
  std::vector<uint32_t> bricks;
  std::vector<uint32_t> brickVoxels;
  // Per brick beyond the band, how far its side's region beyond the band reaches around it: every
  // brick within farReach - 1 of it (counted in bricks along each axis) lies beyond the band on the
  // same side, so a march crosses that cube in one step (empty-space skipping). 0 for a stored
  // brick. Not stored: parseField and setVolumeVoxels set it (setVolumeFarReach); empty reads as 1.
  std::vector<uint8_t> farReach;
  // No straight way out meets the object again (meshIsConvex of the field's mesh): the trace stops
  // at the first way out instead of marching it to the grid's box. Not stored: parseField and the
  // bake set it from the mesh; a grid built by hand leaves it false, which costs time, never a path.
  bool convex = false;
};

// Bricks per side of an N^3 grid: N / kVolumeBrickSide, rounded up (the last ones partly outside
// the grid; their voxels beyond it are never read).
inline uint32_t volumeBricksPerSide(uint32_t n) { return (n + kVolumeBrickSide - 1) / kVolumeBrickSide; }

// The word of a voxel beyond the band on the `inside` side or the other: the band's end, and the
// normal's levels at 0 (packVolumeVoxel of +-kVolumeBandVoxels and the zero vector).
inline uint32_t volumeFarWord(bool inside) { return (inside ? 0u : 254u) | (2047u << 8) | (2047u << 20); }

// Voxel (x, y, z) of the grid, each < N (volume.size).
inline uint32_t volumeVoxel(const FieldVolume& v, uint32_t x, uint32_t y, uint32_t z) {
  const uint32_t per = volumeBricksPerSide(v.size), s = kVolumeBrickSide;
  const uint32_t entry = v.bricks[(size_t(z / s) * per + y / s) * per + x / s];
  if (entry >= kVolumeBrickInside) return volumeFarWord(entry == kVolumeBrickInside);
  return v.brickVoxels[size_t(entry) * kVolumeBrickWords + ((z % s) * s + y % s) * s + x % s];
}

// Stores `dense` (N^3 words, voxel (x, y, z) at (z * N + y) * N + x; N = v.size) as v's bricks: a
// brick whose every voxel within the grid is one far word becomes its entry; the others are
// stored in brick order. volumeVoxel then reads every voxel back exactly.
void setVolumeVoxels(FieldVolume& v, const std::vector<uint32_t>& dense);

// Sets v.farReach from v.bricks (at most 255 bricks).
void setVolumeFarReach(FieldVolume& v);

// A brick's farReach: 1 where v has none set, 0 for a stored brick.
inline uint32_t volumeFarReach(const FieldVolume& v, size_t brick) {
  if (v.bricks[brick] < kVolumeBrickInside) return 0;
  return v.farReach.empty() ? 1u : v.farReach[brick];
}

// The grid's bytes as stored and uploaded: its entries and its stored bricks' words.
inline uint64_t volumeGridBytes(const FieldVolume& v) {
  return 4 * (uint64_t(v.bricks.size()) + uint64_t(v.brickVoxels.size()));
}

struct FieldMedium {
  std::string name;
  float ior = 1.0f;
  float absorption = 0.0f;  // weight per unit length in the optical depth
  std::array<float, 3> color{1.0f, 1.0f, 1.0f};
};

// How the field was baked: the settings its file records, so that a field documents itself. The
// bake's own settings (shrefract/bake/bake_settings.h BakeSettings) add the switches of its driver
// that leave nothing in a field.
struct BakeRecord {
  std::string source;                // scene: "builtin:NAME" or the glTF path as given
  uint32_t order = 8;                // SH order L
  uint32_t directionsTheta = 32;     // hemisphere grid: rows in polar angle
  uint32_t directionsPhi = 64;       // columns in azimuth
  SampleLayout layout = SampleLayout::Split;
  Encoding encoding = Encoding::Sh;
  uint32_t tableSize = 0;            // Table / Pca: nodes per side N of the hemi-octahedral grid
  uint32_t components = 0;           // Pca: basis functions K
  // Pca: the clusters of the samples the bake tries against the K components (0: K). A clustered
  // field stores their mean tables (components is then this count) and each sample's index.
  uint32_t clusters = 0;
  PathRule pathRule = PathRule::HighestEnergy;
  bool throughput = false;           // the path's Fresnel throughput is stored as a channel
  DirectionSampling directionSampling = DirectionSampling::Grid;
  // Store the jump distance channel where the decode is jump-aware (Table and Pca traced at their
  // nodes, N >= kJumpMinTableSize): the bake traces where each node's exit jumps, and the decode
  // places the jump there instead of midway between nodes. A field's settings record whether it was
  // stored (false for every other field).
  bool jumpDistance = true;
  // Store each exit direction in its sample's frame (x, y along the tangents, z along the normal)
  // or in object space. In the sample's frame, samples whose geometry around them looks alike store
  // alike functions wherever they sit, which a Pca basis learns with fewer functions; on glass with
  // no such symmetry object space can need fewer (docs/encodings.md, "Exits in the sample's frame").
  // Auto: Pca keeps the frame with the smaller residual. A field's settings record what it stores.
  ExitFrame exitFrame = ExitFrame::Auto;
  float maxBytesPerSample = 0.0f;    // > 0: encoding and parameters were chosen to fit this budget
  uint64_t sampleBudget = 0;         // requested total samples (0: not used)
  float samplesPerUnitArea = 0.0f;   // requested density (0: not used)
  uint32_t maxBounces = 16;          // cap on interactions after entering the object
  SmoothingWindow window = SmoothingWindow::None;
  uint32_t spatialNeighbours = 0;    // 0, 3 or 5
  Quantization quantization = Quantization::U8;
  float regularization = 0.0f;       // lambda of the hemisphere fit (docs/technique.md)
  ShFit shFit = ShFit::Robust;       // SH: how the expansion is fitted; other encodings store LeastSquares
  float maxErrorDegrees = 0.0f;      // > 0: order and directions were chosen to meet this error
  uint32_t threads = 0;              // informational: does not change the data
  uint32_t volumeSize = 0;           // Volume: voxels per side N; 0 otherwise
  // The tool's default when no encoding is asked for: the bake decides the encoding from what the
  // scene is (bake.h settingsForScene), or, with BakeSettings::chooseByImages, bakes Pca and the Volume
  // encoding (volumeSize; when 0, kDefaultVolumeSize or twice it, bake.h kFinerVolumeGainDb) and
  // keeps whichever field's images come closer to exact renders. A field records what it became.
  bool tryVolume = false;
};

// Timing fields (seconds, rays per second, memory) vary from run to run; everything else is
// deterministic for a given scene and settings.
struct BakeStatistics {
  uint64_t samples = 0;              // texels that hold a traced sample
  uint64_t uniqueSamples = 0;        // distinct surface points traced (shared edges traced once)
  uint64_t directions = 0;           // directions per sample
  uint64_t paths = 0;                // paths traced (samples x directions, plus held-out checks)
  uint64_t rays = 0;                 // Embree ray queries
  uint64_t trappedPaths = 0;         // paths that hit the interaction cap
  double bakeSeconds = 0.0;
  double traceSeconds = 0.0;
  double fitSeconds = 0.0;
  double raysPerSecond = 0.0;
  uint64_t peakMemoryBytes = 0;
  float fitRmsDegrees = 0.0f;        // angle between traced and reconstructed exit directions at the grid
  float fitMaxDegrees = 0.0f;
  float heldOutRmsDegrees = 0.0f;    // same at random directions not in the grid
  float heldOutMaxDegrees = 0.0f;
  float quantizationRmsDegrees = 0.0f;  // extra error of the quantized coefficients over the float fit
  float quantizationMaxDegrees = 0.0f;
};

// The render mesh for the field's layout. Only surfaces facing the surrounding medium are here:
// those are the ones an eye outside the object sees.
struct FieldMesh {
  std::vector<float> positions;  // 3 per vertex, world space
  std::vector<float> normals;    // 3 per vertex, unit
  std::vector<float> uvs;        // 2 per vertex: atlas coordinates in [0,1], texel centre i at (i+0.5)/size
  std::vector<float> frontIor;   // 1 per vertex: n_inside / n_outside of the surface the eye sees
  std::vector<uint32_t> indices; // triangle list
};

// Split layout continuity correction: after decompression, texel `target` is set to
// value(a) + value(b) - value(c), so bilinear filtering along a triangle's hypotenuse is linear
// between the samples on it (docs/technique.md).
struct GutterTexel {
  uint32_t target = 0, a = 0, b = 0, c = 0;  // texel indices y * width + x
};

// Texel roles in `texelKinds`.
inline constexpr uint8_t kTexelEmpty = 0;   // no sample; frame is zero; decompresses to zero
inline constexpr uint8_t kTexelSample = 1;  // holds a sample
inline constexpr uint8_t kTexelGutter = 2;  // split layout: filled by a GutterTexel rule

// A field's encoding without its data: what decoding a sample needs besides its coefficients
// (and, for Pca, the basis).
struct EncodingShape {
  Encoding encoding = Encoding::Sh;
  uint32_t order = 0;       // Sh
  uint32_t tableSize = 0;   // Table, Pca
  uint32_t components = 0;  // Pca
  uint32_t channels = 3;  // encoded: the decoded ones, then the jump distance when jumpDistance
  // Table, Pca traced at their nodes (DirectionSampling::Nodes): the corners of a cell are blended
  // jump-aware (docs/encodings.md, "Jumps"), since node values are exact exits on either side.
  bool jumpAware = false;
  // The last channel is the distance from each node to the nearest jump (jump-aware fields only):
  // the decode uses it to place a jump inside a cell and does not output it.
  bool jumpDistance = false;
  // Channels 0..2 are the exit in the sample's frame (BakeRecord::exitFrame): the decode
  // rotates its sum to object space by the frame's rows, and the straight-through exit that the
  // jump-aware blend compares with is simply -w.
  bool sampleFrameExits = false;
  // Pca only: each sample's one coefficient is the index of the basis function it decodes to,
  // whole (its cluster's mean table; docs/encodings.md "Clusters"), in place of K weights.
  bool clustered = false;
  uint32_t decodedChannels() const { return channels - (jumpDistance ? 1u : 0u); }
  // Layers (coefficients per sample and stored value): Sh (L+1)^2, Table N^2, Pca K (clustered: 1),
  // Volume none.
  uint32_t layerCount() const {
    return encoding == Encoding::Volume  ? 0u
           : encoding == Encoding::Sh    ? (order + 1) * (order + 1)
           : encoding == Encoding::Table ? tableSize * tableSize
           : clustered                   ? 1u
                                         : components;
  }
  uint32_t valuesPerLayer() const { return encoding == Encoding::Pca ? 1u : channels; }
};

struct Field {
  uint32_t width = 0;            // atlas size in texels
  uint32_t height = 0;
  Encoding encoding = Encoding::Sh;
  uint32_t order = 0;            // Sh: order L, (L+1)^2 layers; 0 for the other encodings
  uint32_t tableSize = 0;        // Table: N, N^2 layers; Pca: N of the basis tables; 0 for Sh
  uint32_t components = 0;       // Pca: K layers; 0 otherwise
  // Encoded channels: x, y, z, then tau when a medium absorbs, then the throughput when
  // `throughput` is set (3, 4 or 5 decoded channels), then the jump distance when `jumpDistance`
  // is set (EncodingShape::jumpDistance; in grid cells times kJumpDistanceScale / (N - 1), gpu_layout.h).
  uint32_t channels = 4;
  bool throughput = false;
  bool jumpDistance = false;
  bool sampleFrameExits = false;  // EncodingShape::sampleFrameExits
  // EncodingShape::clustered: the coefficients are `clusterIndices`, exact, whatever the
  // quantization (which then names how the bake was asked to quantize, and nothing is stored in
  // coefficientsU8 / F16, scale or bias).
  bool clustered = false;
  Quantization quantization = Quantization::U8;

  // Coefficients a_j(s), layer-major: index ((layer * height + y) * width + x) * values + v, with
  // values = valuesPerLayer() (Sh, Table: one per channel; Pca: one weight shared by all channels).
  // U8: value = bias[layer * values + v] + scale[layer * values + v] * q / 255.
  std::vector<uint8_t> coefficientsU8;
  std::vector<uint16_t> coefficientsF16;  // binary16 bit patterns
  std::vector<float> scale;               // layerCount * values (U8 only)
  std::vector<float> bias;                // layerCount * values (U8 only)
  // Clustered Pca: per texel, the index (< components) of the basis function it decodes to; 0 for
  // texels that hold no sample. Empty for every other field.
  std::vector<uint16_t> clusterIndices;
  // Pca: the basis, components * tableSize^2 * channels floats: function k at node n, channel c at
  // (k * tableSize^2 + n) * channels + c (clustered: each a binary16 value, as stored). Empty for
  // the other encodings.
  std::vector<float> basis;
  // Volume: the grid every sample's path is traced through (empty for the other encodings).
  FieldVolume volume;

  std::vector<float> frames;        // width * height * 12: rows of M_s (zero for empty texels)
  std::vector<uint8_t> texelKinds;  // width * height: kTexelEmpty, kTexelSample, kTexelGutter
  std::vector<GutterTexel> gutters;

  FieldMesh mesh;
  std::vector<FieldMedium> media;  // media[0] surrounds the object
  BakeRecord settings;
  BakeStatistics statistics;

  EncodingShape shape() const {
    return {encoding, order, tableSize, components, channels,
            encoding != Encoding::Sh && settings.directionSampling == DirectionSampling::Nodes, jumpDistance,
            sampleFrameExits, clustered};
  }
  uint32_t decodedChannels() const { return shape().decodedChannels(); }
  uint32_t layerCount() const { return shape().layerCount(); }
  uint32_t basisCount() const { return layerCount(); }  // the name of SH-era callers
  uint32_t valuesPerLayer() const { return shape().valuesPerLayer(); }
  bool hasOpticalDepth() const { return decodedChannels() == (throughput ? 5u : 4u); }
  uint32_t throughputChannel() const { return decodedChannels() - 1; }  // meaningful when throughput is set
  uint64_t texelCount() const { return uint64_t(width) * height; }
  // Bytes of one stored coefficient value: u8, binary16, or a clustered field's 16-bit index.
  uint32_t coefficientValueBytes() const { return quantization == Quantization::U8 && !clustered ? 1u : 2u; }
  // Bytes of one stored basis value: float, or a clustered field's binary16 table value.
  uint32_t basisValueBytes() const { return clustered ? 2u : 4u; }
  // Encoded bytes per sample: the coefficients only (frames, mesh, tables and basis not counted).
  uint32_t bytesPerSample() const { return layerCount() * valuesPerLayer() * coefficientValueBytes(); }
};

// The colour of the medium behind the field's front surfaces (the render mesh's): of the media
// other than media[0], the one whose ior, relative to media[0], is nearest the mesh's per-vertex
// frontIor at most vertices (media[1] without per-vertex values); white without media. What
// Object::createFromField sets as ObjectShading::tint (docs/scenes.md, "Colour model").
std::array<float, 3> frontMediumColor(const Field& field);

// Decoded channels at most: x, y, z, tau, throughput; encoded ones add the jump distance.
inline constexpr uint32_t kMaxFieldChannels = 5;
inline constexpr uint32_t kMaxEncodedChannels = kMaxFieldChannels + 1;

// A Volume field's voxel word (FieldVolume) from a signed distance in voxels (clamped to
// +-kVolumeBandVoxels, rounded to its level) and a unit normal (octahedral, 12 bits a coordinate),
// and the unit normal back from a word.
uint32_t packVolumeVoxel(float distanceVoxels, const std::array<float, 3>& normal);
std::array<float, 3> unpackVolumeNormal(uint32_t word);
// Whether every vertex of `mesh` lies on or behind every triangle's plane (within 1e-5 of its
// extent, each plane facing the way its vertex normals do): the mesh then bounds one convex body,
// which a straight ray leaving it never meets again (two convex parts fail: each lies in front of
// a face of the other). Gives up, answering false, after kConvexTestPairs (triangle, vertex) pairs,
// so a large convex mesh loses the early stop, never a path.
inline constexpr uint64_t kConvexTestPairs = uint64_t(1) << 26;
bool meshIsConvex(const FieldMesh& mesh);
// Dequantized coefficient a_layer(texel), value v < valuesPerLayer() (clustered: the index, as a
// float). Preconditions:
// validateField(field) succeeded, indices in range.
float fieldCoefficient(const Field& field, uint32_t layer, uint64_t texel, uint32_t value);

// Encodes float coefficients (same indexing as the quantized arrays) into field.coefficientsU8 +
// scale/bias or field.coefficientsF16, per field.quantization. A channel of zero range gets
// scale 0 and decodes exactly to its bias. A clustered field stores each texel's value in
// clusterIndices instead: it must be a whole number below `components`; its basis (the tables) is
// first rounded to binary16, as the file stores it. Errors (InvalidArgument):
// sizes that disagree, a value that is not finite or beyond kMaxCoefficientMagnitude (F16: beyond
// the binary16 range; clustered: not an index).
Result<void> encodeCoefficients(Field& field, const std::vector<float>& coefficients);

// The same encoding, the coefficients read per texel instead of from one texel-ordered array:
// texelValues(t) points at texel t's value v of layer i at [i * layerStride + v], or is nullptr
// for a texel whose coefficients are all zero (empty texels; they count in the u8 ranges as zeros,
// as in the array form). A baker whose texels share per-sample data encodes straight from it, with
// no float copy of the whole atlas (the bake's largest allocation); the bytes are the same.
Result<void> encodeCoefficients(Field& field, const std::function<const float*(uint64_t texel)>& texelValues,
                                uint64_t layerStride);

// Structural validation: sizes agree, values finite, indices and texel references in range,
// UVs in [0,1], frames zero exactly for empty texels and within kMaxFrameMagnitude, order <= 32,
// 3 to 5 decoded channels (a jump distance only where the decode is jump-aware), every decodable U8
// coefficient within kMaxCoefficientMagnitude.
Result<void> validateField(const Field& field);

// Serialization. parseField validates everything: magic, file size, checksum, version (a newer
// version, or one before kOldestReadFieldFormatVersion, is rejected as Unsupported), section
// sizes, then validateField. `name` is used in messages.
std::vector<uint8_t> serializeField(const Field& field);
Result<Field> parseField(const uint8_t* data, size_t size, const std::string& name);
Result<Field> readField(const std::string& path);
// Writes atomically: a temporary file in the same directory, then rename. No partial file remains
// on failure.
Result<void> writeField(const std::string& path, const Field& field);

}  // namespace shrefract
