// Structural validation of a field (docs/field-format.md, "Validation"): what parseField checks
// after the sections are read and writeField before anything is written.
#include <shrefract/field.h>
#include <shrefract/gpu_layout.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "core/half.h"
#include "field/field_file.h"
#include "field/field_validation.h"

namespace shrefract {
using namespace fieldfile;  // the layout and helpers every part of the format shares (field_file.h)

namespace {

bool allFinite(const float* v, size_t n) {
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

Error invalid(const std::string& message) { return makeError(ErrorCode::CorruptData, message); }

// A Volume field's grid and what its trace reads: the decode marches it (decompress_volume.comp),
// so every distance must lie within the band, the spacing keep the grid's coordinates finite, and
// the bounce cap be bounded.
Result<void> validateVolume(const Field& field) {
  const FieldVolume& v = field.volume;
  if (field.order != 0 || field.tableSize != 0 || field.components != 0 || field.jumpDistance || field.clustered)
    return invalid("a volume field has an SH order, a table size, components, a jump distance or clusters");
  if (v.size < kMinVolumeSize || v.size > kMaxVolumeSize)
    return invalid("volume size " + std::to_string(v.size) + " is outside " + std::to_string(kMinVolumeSize) + ".." +
                   std::to_string(kMaxVolumeSize));
  const uint64_t per = volumeBricksPerSide(v.size), stored = v.brickVoxels.size() / kVolumeBrickWords;
  if (v.bricks.size() != per * per * per)
    return invalid("volume has " + std::to_string(v.bricks.size()) + " bricks, expected " + std::to_string(per) +
                   "^3 for " + std::to_string(v.size) + "^3 voxels");
  if (v.brickVoxels.size() % kVolumeBrickWords != 0)
    return invalid("volume has " + std::to_string(v.brickVoxels.size()) + " brick voxels, not a whole number of " +
                   std::to_string(kVolumeBrickWords) + "-voxel bricks");
  for (size_t i = 0; i < v.bricks.size(); ++i)
    if (v.bricks[i] < kVolumeBrickInside && v.bricks[i] >= stored)
      return invalid("volume brick " + std::to_string(i) + " refers to stored brick " + std::to_string(v.bricks[i]) +
                     " of " + std::to_string(stored));
  if (!v.farReach.empty() && v.farReach.size() != v.bricks.size())
    return invalid("volume has " + std::to_string(v.farReach.size()) + " far reaches for " +
                   std::to_string(v.bricks.size()) + " bricks");
  // Within 1e-15..1e15: points within kMaxFrameMagnitude of the origin stay finite in voxels.
  if (!(std::isfinite(v.spacing) && v.spacing >= 1e-15f && v.spacing <= kMaxFrameMagnitude))
    return invalid("volume spacing " + formatFloat(v.spacing) + " is not within 1e-15..1e15");
  for (float o : v.origin)
    if (!(std::fabs(o) <= kMaxFrameMagnitude))
      return invalid("volume origin " + formatFloat(o) + " is not finite or beyond +-" + formatFloat(kMaxFrameMagnitude));
  // A distance level beyond the band's end (254) would read beyond it.
  for (size_t i = 0; i < v.brickVoxels.size(); ++i)
    if ((v.brickVoxels[i] & gpu::kVolumeDistanceMask) > 2 * gpu::kVolumeDistanceZero)
      return invalid("volume brick voxel " + std::to_string(i) + " has distance level " +
                     std::to_string(v.brickVoxels[i] & gpu::kVolumeDistanceMask) + ", beyond the band's " +
                     std::to_string(2 * gpu::kVolumeDistanceZero));
  if (field.media.size() != 2)
    return invalid("a volume field has " + std::to_string(field.media.size()) +
                   " media, expected 2 (the surrounding one and the object's)");
  if (field.settings.maxBounces > kMaxVolumeBounces)
    return invalid("settings.maxBounces " + std::to_string(field.settings.maxBounces) + " of a volume field is over " +
                   std::to_string(kMaxVolumeBounces));
  if (field.settings.volumeSize != v.size)
    return invalid("settings.volumeSize " + std::to_string(field.settings.volumeSize) + " differs from the grid's " +
                   std::to_string(v.size));
  return {};
}

}  // namespace

namespace fieldfile {

Result<void> validateEncoding(const Field& field) {
  const std::string n = std::to_string(field.tableSize);
  const uint32_t decoded = field.decodedChannels();
  if (decoded != (field.throughput ? 4u : 3u) && decoded != (field.throughput ? 5u : 4u))
    return invalid("channels is " + std::to_string(field.channels) + ", expected " +
                   (field.throughput ? "4 or 5 (with throughput)" : "3 or 4") +
                   (field.jumpDistance ? " and one for the jump distance" : ""));
  if (field.jumpDistance && !(field.shape().jumpAware && field.tableSize >= gpu::kJumpMinTableSize))
    return invalid("a jump distance channel needs a table or pca field traced at its nodes with a table size of at "
                   "least " + std::to_string(gpu::kJumpMinTableSize));
  switch (field.encoding) {
    case Encoding::Sh:
      if (field.order > kMaxOrder)
        return invalid("order " + std::to_string(field.order) + " is over the limit of " + std::to_string(kMaxOrder));
      if (field.tableSize != 0 || field.components != 0) return invalid("an sh field has a table size or components");
      break;
    case Encoding::Table:
    case Encoding::Pca:
      if (field.order != 0) return invalid(std::string("a ") + toString(field.encoding) + " field has an SH order");
      if (field.tableSize < 2 || field.tableSize > kMaxTableSize)
        return invalid("table size " + n + " is outside 2.." + std::to_string(kMaxTableSize));
      if (field.encoding == Encoding::Table && field.components != 0) return invalid("a table field has components");
      if (field.encoding == Encoding::Pca &&
          (field.components < 1 || field.components > (field.clustered ? kMaxClusters : kMaxComponents)))
        return invalid("components " + std::to_string(field.components) + " is outside 1.." +
                       std::to_string(field.clustered ? kMaxClusters : kMaxComponents) +
                       (field.clustered ? " (clustered)" : ""));
      break;
    case Encoding::Volume:
      if (auto r = validateVolume(field); !r) return r;
      break;
    default:
      return invalid("encoding " + std::to_string(static_cast<uint32_t>(field.encoding)) +
                     " is not sh (0), table (1), pca (2) or volume (3)");
  }
  if (field.encoding != Encoding::Volume && (field.volume.size != 0 || !field.volume.bricks.empty() ||
                                              !field.volume.brickVoxels.empty()))
    return invalid(std::string("a ") + toString(field.encoding) + " field has a volume grid");
  if (field.settings.tryVolume && field.encoding != Encoding::Pca && field.encoding != Encoding::Volume)
    return invalid(std::string("settings.tryVolume is set on a ") + toString(field.encoding) +
                   " field (only the pca bake tries the volume)");
  if (field.clustered && field.encoding != Encoding::Pca) return invalid("a clustered field is not a pca field");
  const size_t basisValues =
      field.encoding == Encoding::Pca ? size_t(field.components) * field.tableSize * field.tableSize * field.channels : 0;
  if (field.basis.size() != basisValues)
    return invalid("basis has " + std::to_string(field.basis.size()) + " values, expected " + std::to_string(basisValues));
  for (size_t i = 0; i < field.basis.size(); ++i) {
    // A clustered field stores its tables as binary16 (docs/field-format.md, ENCD).
    if (field.clustered && !(halfToFloat(floatToHalf(field.basis[i])) == field.basis[i]))
      return invalid("basis[" + std::to_string(i) + "] = " + formatFloat(field.basis[i]) +
                     " of a clustered field is not a binary16 value");
    const float bound = i % field.channels < 3 ? kMaxBasisDirectionMagnitude : kMaxBasisMagnitude;
    if (!(std::fabs(field.basis[i]) <= bound))
      return invalid("basis[" + std::to_string(i) + "] = " + formatFloat(field.basis[i]) + " is not finite or beyond +-" +
                     formatFloat(bound));
  }
  return {};
}

}  // namespace fieldfile

namespace {

Result<void> validateSettings(const Field& field) {
  const BakeRecord& s = field.settings;
  if (s.source.size() > kMaxStringBytes)
    return invalid("settings.source is " + std::to_string(s.source.size()) + " bytes, over the cap of " +
                   std::to_string(kMaxStringBytes));
  if (s.order != field.order)
    return invalid("settings.order " + std::to_string(s.order) + " differs from the field's order " +
                   std::to_string(field.order));
  if (s.encoding != field.encoding || s.tableSize != field.tableSize || s.components != field.components ||
      s.throughput != field.throughput)
    return invalid("settings (encoding, table size, components, throughput) differ from the field's");
  if (s.pathRule != PathRule::HighestEnergy && s.pathRule != PathRule::FirstRefraction)
    return invalid("settings.pathRule " + std::to_string(static_cast<uint32_t>(s.pathRule)) + " is not a path rule");
  if (s.directionSampling != DirectionSampling::Grid && s.directionSampling != DirectionSampling::Nodes)
    return invalid("settings.directionSampling " + std::to_string(static_cast<uint32_t>(s.directionSampling)) +
                   " is not a direction sampling");
  if (s.directionSampling == DirectionSampling::Nodes && s.encoding == Encoding::Sh)
    return invalid("settings.directionSampling is nodes, which needs a table or pca encoding");
  if (s.clusters > kMaxClusters)
    return invalid("settings.clusters " + std::to_string(s.clusters) + " is over " + std::to_string(kMaxClusters));
  if (!std::isfinite(s.maxBytesPerSample) || s.maxBytesPerSample < 0.0f)
    return invalid("settings.maxBytesPerSample " + formatFloat(s.maxBytesPerSample) + " is not finite and >= 0");
  if (s.directionsTheta < 1 || s.directionsPhi < 1)
    return invalid("settings: direction grid " + std::to_string(s.directionsTheta) + "x" +
                   std::to_string(s.directionsPhi) + " is empty");
  if (s.layout != SampleLayout::Split && s.layout != SampleLayout::Charts)
    return invalid("settings.layout " + std::to_string(static_cast<uint32_t>(s.layout)) + " is not a sample layout");
  if (s.window != SmoothingWindow::None && s.window != SmoothingWindow::Hann && s.window != SmoothingWindow::Lanczos)
    return invalid("settings.window " + std::to_string(static_cast<uint32_t>(s.window)) + " is not a smoothing window");
  if (s.shFit != ShFit::LeastSquares && s.shFit != ShFit::Robust)
    return invalid("settings.shFit " + std::to_string(static_cast<uint32_t>(s.shFit)) + " is not an SH fit");
  if (s.spatialNeighbours != 0 && s.spatialNeighbours != 3 && s.spatialNeighbours != 5)
    return invalid("settings.spatialNeighbours is " + std::to_string(s.spatialNeighbours) + ", not 0, 3 or 5");
  if (s.quantization != field.quantization)
    return invalid(std::string("settings.quantization ") + std::to_string(static_cast<uint32_t>(s.quantization)) +
                   " differs from the field's quantization (" + toString(field.quantization) + ")");
  if (!std::isfinite(s.samplesPerUnitArea) || s.samplesPerUnitArea < 0.0f)
    return invalid("settings.samplesPerUnitArea " + formatFloat(s.samplesPerUnitArea) + " is not finite and >= 0");
  if (!std::isfinite(s.maxErrorDegrees) || s.maxErrorDegrees < 0.0f)
    return invalid("settings.maxErrorDegrees " + formatFloat(s.maxErrorDegrees) + " is not finite and >= 0");
  if (!std::isfinite(s.regularization) || s.regularization < 0.0f)
    return invalid("settings.regularization " + formatFloat(s.regularization) + " is not finite and >= 0");
  return {};
}

// Timings and errors: informational, but a reader prints them, so they are finite.
Result<void> validateStatistics(const BakeStatistics& t) {
  const std::array<std::pair<const char*, double>, 4> doubles{{{"bakeSeconds", t.bakeSeconds},
                                                               {"traceSeconds", t.traceSeconds},
                                                               {"fitSeconds", t.fitSeconds},
                                                               {"raysPerSecond", t.raysPerSecond}}};
  for (const auto& [label, value] : doubles)
    if (!std::isfinite(value)) return invalid(std::string("statistics.") + label + " is not finite");
  const std::array<std::pair<const char*, float>, 6> floats{{{"fitRmsDegrees", t.fitRmsDegrees},
                                                             {"fitMaxDegrees", t.fitMaxDegrees},
                                                             {"heldOutRmsDegrees", t.heldOutRmsDegrees},
                                                             {"heldOutMaxDegrees", t.heldOutMaxDegrees},
                                                             {"quantizationRmsDegrees", t.quantizationRmsDegrees},
                                                             {"quantizationMaxDegrees", t.quantizationMaxDegrees}}};
  for (const auto& [label, value] : floats)
    if (!std::isfinite(value)) return invalid(std::string("statistics.") + label + " is not finite");
  return {};
}

Result<void> validateMedia(const Field& field) {
  if (field.media.empty()) return invalid("media: none (media[0] must be the surrounding medium)");
  for (size_t i = 0; i < field.media.size(); ++i) {
    const FieldMedium& m = field.media[i];
    const std::string label = "media[" + std::to_string(i) + "]";
    if (m.name.size() > kMaxStringBytes)
      return invalid(label + ".name is " + std::to_string(m.name.size()) + " bytes, over the cap of " +
                     std::to_string(kMaxStringBytes));
    if (!std::isfinite(m.ior) || !(m.ior > 0.0f)) return invalid(label + ".ior " + formatFloat(m.ior) + " is not finite and > 0");
    if (!std::isfinite(m.absorption) || m.absorption < 0.0f)
      return invalid(label + ".absorption " + formatFloat(m.absorption) + " is not finite and >= 0");
    for (float c : m.color)
      if (!std::isfinite(c) || c < 0.0f) return invalid(label + ".color has " + formatFloat(c) + ", not finite and >= 0");
    if (!field.hasOpticalDepth() && m.absorption != 0.0f)
      return invalid(label + " absorbs (" + formatFloat(m.absorption) + ") but the field has " +
                     std::to_string(field.decodedChannels()) + " channels (no optical depth stored)");
  }
  return {};
}

Result<void> validateMesh(const FieldMesh& mesh) {
  if (mesh.positions.size() % 3 != 0)
    return invalid("mesh.positions has " + std::to_string(mesh.positions.size()) + " floats, not a multiple of 3");
  const size_t vertices = mesh.positions.size() / 3;
  if (mesh.normals.size() != vertices * 3)
    return invalid("mesh.normals has " + std::to_string(mesh.normals.size()) + " floats, expected " +
                   std::to_string(vertices * 3));
  if (mesh.uvs.size() != vertices * 2)
    return invalid("mesh.uvs has " + std::to_string(mesh.uvs.size()) + " floats, expected " + std::to_string(vertices * 2));
  if (mesh.frontIor.size() != vertices)
    return invalid("mesh.frontIor has " + std::to_string(mesh.frontIor.size()) + " floats, expected " +
                   std::to_string(vertices));
  if (mesh.indices.size() % 3 != 0)
    return invalid("mesh.indices has " + std::to_string(mesh.indices.size()) + " entries, not a multiple of 3");
  for (size_t v = 0; v < vertices; ++v) {
    const std::string label = "mesh vertex " + std::to_string(v);
    if (!allFinite(&mesh.positions[3 * v], 3)) return invalid(label + ": position is not finite");
    if (!allFinite(&mesh.normals[3 * v], 3)) return invalid(label + ": normal is not finite");
    for (int k = 0; k < 2; ++k) {
      const float uv = mesh.uvs[2 * v + static_cast<size_t>(k)];
      if (!(uv >= 0.0f && uv <= 1.0f)) return invalid(label + ": uv " + formatFloat(uv) + " is outside [0,1]");
    }
    const float ior = mesh.frontIor[v];
    if (!std::isfinite(ior) || !(ior > 0.0f)) return invalid(label + ": frontIor " + formatFloat(ior) + " is not finite and > 0");
  }
  for (size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= vertices)
      return invalid("mesh.indices[" + std::to_string(i) + "] = " + std::to_string(mesh.indices[i]) +
                     " is out of range (" + std::to_string(vertices) + " vertices)");
  return {};
}

Result<void> validateAtlas(const Field& field) {
  const uint64_t texels = field.texelCount();
  if (field.texelKinds.size() != texels)
    return invalid("texelKinds has " + std::to_string(field.texelKinds.size()) + " entries, expected " +
                   std::to_string(texels) + " (" + std::to_string(field.width) + "x" + std::to_string(field.height) + ")");
  if (field.frames.size() != texels * 12)
    return invalid("frames has " + std::to_string(field.frames.size()) + " floats, expected " + std::to_string(texels * 12));
  for (uint64_t t = 0; t < texels; ++t) {
    const uint8_t kind = field.texelKinds[t];
    if (kind != kTexelEmpty && kind != kTexelSample && kind != kTexelGutter)
      return invalid(texelName(field, t) + ": kind " + std::to_string(kind) + " is not empty (0), sample (1) or gutter (2)");
    const float* frame = &field.frames[t * 12];
    if (!allFinite(frame, 12)) return invalid(texelName(field, t) + ": frame is not finite");
    if (!std::all_of(frame, frame + 12, [](float v) { return std::fabs(v) <= kMaxFrameMagnitude; }))
      return invalid(texelName(field, t) + ": frame has an entry beyond +-" + formatFloat(kMaxFrameMagnitude));
    const bool zero = std::all_of(frame, frame + 12, [](float v) { return v == 0.0f; });
    if (kind == kTexelEmpty && !zero) return invalid(texelName(field, t) + " is empty but its frame is not zero");
    if (kind == kTexelSample && zero) return invalid(texelName(field, t) + " holds a sample but its frame is zero");
  }
  // Every gutter texel is filled by exactly one rule, from sample texels.
  std::vector<uint8_t> rules(static_cast<size_t>(texels), 0);
  for (size_t g = 0; g < field.gutters.size(); ++g) {
    const GutterTexel& r = field.gutters[g];
    const std::string label = "gutters[" + std::to_string(g) + "]";
    const std::array<std::pair<const char*, uint32_t>, 4> refs{{{"target", r.target}, {"a", r.a}, {"b", r.b}, {"c", r.c}}};
    for (const auto& [which, texel] : refs)
      if (texel >= texels)
        return invalid(label + "." + which + " = " + std::to_string(texel) + " is out of range (" +
                       std::to_string(texels) + " texels)");
    if (field.texelKinds[r.target] != kTexelGutter)
      return invalid(label + ".target is " + texelName(field, r.target) + ", which is not a gutter texel");
    for (size_t k = 1; k < refs.size(); ++k)
      if (field.texelKinds[refs[k].second] != kTexelSample)
        return invalid(label + "." + refs[k].first + " is " + texelName(field, refs[k].second) +
                       ", which does not hold a sample");
    if (rules[r.target]++ != 0) return invalid(label + ": " + texelName(field, r.target) + " is the target of two rules");
  }
  for (uint64_t t = 0; t < texels; ++t)
    if (field.texelKinds[t] == kTexelGutter && rules[t] == 0)
      return invalid(texelName(field, t) + " is a gutter texel but no rule fills it");
  return {};
}

// A clustered field: one index per texel, below the components, 0 where no sample is; nothing in
// the quantized arrays.
Result<void> validateClusterIndices(const Field& field) {
  if (!field.coefficientsU8.empty() || !field.coefficientsF16.empty() || !field.scale.empty() || !field.bias.empty())
    return invalid("a clustered field has quantized coefficients or scale/bias (expected none)");
  if (field.clusterIndices.size() != field.texelCount())
    return invalid("cluster indices has " + std::to_string(field.clusterIndices.size()) + " entries, expected " +
                   std::to_string(field.texelCount()) + " (texels)");
  for (uint64_t t = 0; t < field.texelCount(); ++t) {
    const uint16_t k = field.clusterIndices[t];
    if (k >= field.components || (k != 0 && field.texelKinds[t] != kTexelSample))
      return invalid("cluster index " + std::to_string(k) + " of " + texelName(field, t) +
                     (k >= field.components ? " is not below the " + std::to_string(field.components) + " components"
                                            : " is not 0, and the texel holds no sample"));
  }
  return {};
}

// The array of the field's quantization holds `count` values and the other none.
Result<void> validateCoefficientCounts(const Field& field, uint64_t count) {
  const bool u8 = field.quantization == Quantization::U8;
  const std::string name = u8 ? "coefficientsU8" : "coefficientsF16", other = u8 ? "coefficientsF16" : "coefficientsU8";
  const size_t stored = u8 ? field.coefficientsU8.size() : field.coefficientsF16.size();
  const size_t otherStored = u8 ? field.coefficientsF16.size() : field.coefficientsU8.size();
  if (stored != count)
    return invalid(name + " has " + std::to_string(stored) + " entries, expected " + std::to_string(count) +
                   " (layers x texels x values)");
  if (otherStored != 0)
    return invalid(other + " has " + std::to_string(otherStored) + " entries but the field is quantized to " +
                   (u8 ? "u8" : "f16"));
  return {};
}

// U8: a scale and bias per layer and value (`tables` of them), each decoding to finite values.
Result<void> validateScaleBias(const Field& field, uint64_t tables, uint32_t values) {
  if (field.scale.size() != tables || field.bias.size() != tables)
    return invalid("scale/bias have " + std::to_string(field.scale.size()) + "/" + std::to_string(field.bias.size()) +
                   " entries, expected " + std::to_string(tables) + " (layers x values)");
  for (size_t i = 0; i < tables; ++i) {
    const float top = field.bias[i] + field.scale[i];  // the decoded value of q = 255
    if (!std::isfinite(field.scale[i]) || !std::isfinite(field.bias[i]) || !std::isfinite(top))
      return invalid("scale/bias of layer " + std::to_string(i / values) + " value " + std::to_string(i % values) +
                     " (" + formatFloat(field.scale[i]) + ", " + formatFloat(field.bias[i]) +
                     ") do not decode to finite values");
    // Every level lies between bias and top; bounding both keeps every SH sum finite in float.
    if (!(std::fabs(field.bias[i]) <= kMaxCoefficientMagnitude) || !(std::fabs(top) <= kMaxCoefficientMagnitude))
      return invalid("scale/bias of layer " + std::to_string(i / values) + " value " + std::to_string(i % values) +
                     " (" + formatFloat(field.scale[i]) + ", " + formatFloat(field.bias[i]) + ") decode beyond +-" +
                     formatFloat(kMaxCoefficientMagnitude));
  }
  return {};
}

// F16: no scale or bias, and no NaN or Inf among the `count` values.
Result<void> validateF16Values(const Field& field, uint64_t count, uint64_t texels, uint32_t values) {
  if (!field.scale.empty() || !field.bias.empty())
    return invalid("scale/bias have " + std::to_string(field.scale.size()) + "/" + std::to_string(field.bias.size()) +
                   " entries but the field is quantized to f16 (expected none)");
  for (size_t i = 0; i < count; ++i) {
    const uint16_t h = field.coefficientsF16[i];
    if ((h & 0x7C00u) == 0x7C00u) {
      const uint64_t perLayer = texels * values;
      return invalid("coefficientsF16[" + std::to_string(i) + "] (layer " + std::to_string(i / perLayer) + ", " +
                     texelName(field, (i % perLayer) / values) + ", value " + std::to_string(i % values) + ") is " +
                     ((h & 0x3FFu) ? "NaN" : "Inf") + " (bits " + hex32(h) + ")");
    }
  }
  return {};
}

Result<void> validateCoefficients(const Field& field) {
  if (field.clustered) return validateClusterIndices(field);
  if (!field.clusterIndices.empty())
    return invalid("cluster indices has " + std::to_string(field.clusterIndices.size()) +
                   " entries but the field is not clustered");
  const uint64_t texels = field.texelCount();
  const uint32_t values = field.valuesPerLayer();
  const uint64_t tables = uint64_t(field.layerCount()) * values;
  const uint64_t count = tables * texels;
  if (auto r = validateCoefficientCounts(field, count); !r) return r;
  if (field.quantization == Quantization::U8) return validateScaleBias(field, tables, values);
  return validateF16Values(field, count, texels, values);
}

}  // namespace

Result<void> validateField(const Field& field) {
  if (field.width == 0 || field.height == 0 || field.width > kMaxAtlasSize || field.height > kMaxAtlasSize)
    return invalid("atlas is " + std::to_string(field.width) + "x" + std::to_string(field.height) + ", expected 1.." +
                   std::to_string(kMaxAtlasSize) + " texels per side");
  if (auto r = validateEncoding(field); !r) return r;
  if (field.quantization != Quantization::U8 && field.quantization != Quantization::F16)
    return invalid("quantization " + std::to_string(static_cast<uint32_t>(field.quantization)) +
                   " is neither u8 (0) nor f16 (1)");
  if (auto r = validateSettings(field); !r) return r;
  if (auto r = validateStatistics(field.statistics); !r) return r;
  if (auto r = validateMedia(field); !r) return r;
  if (auto r = validateMesh(field.mesh); !r) return r;
  if (auto r = validateAtlas(field); !r) return r;
  return validateCoefficients(field);
}

}  // namespace shrefract
