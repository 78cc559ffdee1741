// Reading a .shrf file (docs/field-format.md, "Reading: the order of checks"): the frame, the
// version, the header, then each section to its exact length, then validateField.
#include <shrefract/field.h>

#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <new>
#include <string>
#include <system_error>
#include <vector>

#include "core/half.h"
#include "field/field_file.h"
#include "field/section_reader.h"

namespace shrefract {
using namespace fieldfile;  // the layout and helpers every part of the format shares (field_file.h)

namespace {

void readSettings(SectionReader& r, BakeRecord& s, BakeStatistics& t) {
  s.order = r.u32("settings.order");
  s.directionsTheta = r.u32("settings.directionsTheta");
  s.directionsPhi = r.u32("settings.directionsPhi");
  s.layout = static_cast<SampleLayout>(r.u32("settings.layout"));
  s.sampleBudget = r.u64("settings.sampleBudget");
  s.samplesPerUnitArea = r.f32("settings.samplesPerUnitArea");
  s.maxBounces = r.u32("settings.maxBounces");
  s.window = static_cast<SmoothingWindow>(r.u32("settings.window"));
  s.spatialNeighbours = r.u32("settings.spatialNeighbours");
  s.quantization = static_cast<Quantization>(r.u32("settings.quantization"));
  s.regularization = r.f32("settings.regularization");
  s.threads = r.u32("settings.threads");
  t.samples = r.u64("statistics.samples");
  t.uniqueSamples = r.u64("statistics.uniqueSamples");
  t.directions = r.u64("statistics.directions");
  t.paths = r.u64("statistics.paths");
  t.rays = r.u64("statistics.rays");
  t.trappedPaths = r.u64("statistics.trappedPaths");
  t.bakeSeconds = r.f64("statistics.bakeSeconds");
  t.traceSeconds = r.f64("statistics.traceSeconds");
  t.fitSeconds = r.f64("statistics.fitSeconds");
  t.raysPerSecond = r.f64("statistics.raysPerSecond");
  t.peakMemoryBytes = r.u64("statistics.peakMemoryBytes");
  t.fitRmsDegrees = r.f32("statistics.fitRmsDegrees");
  t.fitMaxDegrees = r.f32("statistics.fitMaxDegrees");
  t.heldOutRmsDegrees = r.f32("statistics.heldOutRmsDegrees");
  t.heldOutMaxDegrees = r.f32("statistics.heldOutMaxDegrees");
  t.quantizationRmsDegrees = r.f32("statistics.quantizationRmsDegrees");
  t.quantizationMaxDegrees = r.f32("statistics.quantizationMaxDegrees");
  r.string(s.source, "settings.source");
  s.maxErrorDegrees = r.f32("settings.maxErrorDegrees");
}

void readMedia(SectionReader& r, std::vector<FieldMedium>& media) {
  const uint32_t count = r.u32("media count");
  if (r.failed()) return;
  constexpr size_t kMinMediumBytes = 24;  // five floats and an empty name
  if (count > r.remaining() / kMinMediumBytes) {
    r.fail("truncated: media section: " + std::to_string(count) + " media need at least " +
           std::to_string(uint64_t(count) * kMinMediumBytes) + " bytes, " + std::to_string(r.remaining()) + " left");
    return;
  }
  media.resize(count);
  for (FieldMedium& m : media) {
    m.ior = r.f32("medium.ior");
    m.absorption = r.f32("medium.absorption");
    for (float& c : m.color) c = r.f32("medium.color");
    r.string(m.name, "medium.name");
  }
}

void readMesh(SectionReader& r, FieldMesh& mesh) {
  r.arrayF32(mesh.positions, "mesh.positions");
  r.arrayF32(mesh.normals, "mesh.normals");
  r.arrayF32(mesh.uvs, "mesh.uvs");
  r.arrayF32(mesh.frontIor, "mesh.frontIor");
  r.arrayU32(mesh.indices, "mesh.indices");
}

// The end of ENCD: a Volume field's grid (FieldVolume; size 0 and no bricks for the other
// encodings). The array before the settings is always empty: the grid is stored in bricks.
void readVolume(SectionReader& r, Field& field) {
  FieldVolume& v = field.volume;
  v.size = r.u32("volume.size");
  for (int k = 0; k < 3; ++k) v.origin[k] = r.f32("volume.origin");
  v.spacing = r.f32("volume.spacing");
  std::vector<uint32_t> dense;
  r.arrayU32(dense, "volume voxels");
  field.settings.volumeSize = r.u32("settings.volumeSize");
  field.settings.tryVolume = r.u32("settings.tryVolume") != 0;
  r.arrayU32(v.bricks, "volume bricks");
  r.arrayU32(v.brickVoxels, "volume brick voxels");
  if (!dense.empty()) r.fail("volume has " + std::to_string(dense.size()) + " dense voxels; the grid is stored in bricks");
}

// ENCD: how the coefficients are to be decoded, and the bake's choices that go with it.
void readEncoding(SectionReader& r, Field& field) {
  field.encoding = static_cast<Encoding>(r.u32("encoding"));
  field.tableSize = r.u32("encoding.tableSize");
  field.components = r.u32("encoding.components");
  field.throughput = r.u32("encoding.throughput") != 0;
  BakeRecord& s = field.settings;
  s.encoding = static_cast<Encoding>(r.u32("settings.encoding"));
  s.tableSize = r.u32("settings.tableSize");
  s.components = r.u32("settings.components");
  s.throughput = r.u32("settings.throughput") != 0;
  s.pathRule = static_cast<PathRule>(r.u32("settings.pathRule"));
  s.maxBytesPerSample = r.f32("settings.maxBytesPerSample");
  r.arrayF32(field.basis, "basis");
  s.directionSampling = static_cast<DirectionSampling>(r.u32("settings.directionSampling"));
  field.jumpDistance = r.u32("encoding.jumpDistance") != 0;
  s.jumpDistance = field.jumpDistance;
  field.sampleFrameExits = r.u32("encoding.sampleFrameExits") != 0;
  s.exitFrame = field.sampleFrameExits ? ExitFrame::Sample : ExitFrame::Object;
  field.clustered = r.u32("encoding.clustered") != 0;
  r.arrayU16(field.clusterIndices, "cluster indices");
  s.clusters = r.u32("settings.clusters");
  // A clustered field's tables, binary16 (validateEncoding: the f32 basis above is then empty).
  std::vector<uint16_t> tables;
  r.arrayU16(tables, "cluster tables");
  s.shFit = static_cast<ShFit>(r.u32("settings.shFit"));
  readVolume(r, field);
  if (field.clustered && !field.basis.empty()) return r.fail("a clustered field has an f32 basis (its tables are binary16)");
  if (!field.clustered && !tables.empty()) return r.fail("cluster tables are stored, but the field is not clustered");
  if (!field.clustered) return;
  field.basis.resize(tables.size());
  for (size_t i = 0; i < tables.size(); ++i) field.basis[i] = halfToFloat(tables[i]);
}

void readAtlas(SectionReader& r, Field& field) {
  r.arrayU8(field.texelKinds, "texel kinds");
  r.arrayF32(field.frames, "frames");
  r.array(field.gutters, 16, "gutters", [](const uint8_t* p) {
    return GutterTexel{loadU32(p), loadU32(p + 4), loadU32(p + 8), loadU32(p + 12)};
  });
}

// The frame (magic, version, file size, trailing checksum) is the same in every version, so a
// corrupt file is told apart from a newer or an older one before the version is interpreted. Past
// it, the file is of the one version this reader reads.
Result<void> checkFrame(const uint8_t* data, size_t size, const std::string& name) {
  auto corrupt = [&](const std::string& problem) { return makeError(ErrorCode::CorruptData, name + ": " + problem); };
  if (size >= 4 && std::memcmp(data, kMagic.data(), 4) != 0)
    return corrupt("not a shrefract field: magic is " + hexBytes(data, 4) + ", expected \"SHRF\" (53 48 52 46)");
  if (size < kFrameBytes)
    return corrupt("truncated: file is " + std::to_string(size) + " bytes, the header alone needs " +
                   std::to_string(kHeaderBytes));
  const uint32_t version = loadU32(data + 4);
  const uint64_t fileSize = loadU64(data + 8);
  if (fileSize < kFrameBytes + kChecksumBytes)
    return corrupt("header gives a file size of " + std::to_string(fileSize) + " bytes, below the minimum of " +
                   std::to_string(kFrameBytes + kChecksumBytes));
  if (size < fileSize)
    return corrupt("truncated: file is " + std::to_string(size) + " bytes, header says " + std::to_string(fileSize));
  if (size > fileSize)
    return corrupt(std::to_string(size - fileSize) + " trailing bytes: file is " + std::to_string(size) +
                   " bytes, header says " + std::to_string(fileSize));
  const size_t body = size - kChecksumBytes;
  const uint32_t stored = loadU32(data + body);
  const uint32_t computed = crc32(data, body);
  if (stored != computed) return corrupt("checksum mismatch: stored " + hex32(stored) + ", computed " + hex32(computed));
  if (version == 0) return corrupt("format version 0 does not exist");
  if (version > kFieldFormatVersion)
    return makeError(ErrorCode::Unsupported, name + ": format version " + std::to_string(version) +
                                                 " is newer than this reader's version " +
                                                 std::to_string(kFieldFormatVersion));
  // Refused before the header is read, so no part of an old file is interpreted (field.h).
  if (version < kOldestReadFieldFormatVersion)
    return makeError(ErrorCode::Unsupported, name + ": field format version " + std::to_string(version) +
                                                 " is no longer read; bake the field again with this version of "
                                                 "shrefract");
  if (body < kHeaderBytes)
    return corrupt("truncated: file is " + std::to_string(size) + " bytes, the header alone needs " +
                   std::to_string(kHeaderBytes));
  return {};
}

// The header's atlas size, order, channels and quantization into `field`, after checking them and
// the section count.
Result<void> readHeader(const uint8_t* data, const std::string& name, Field& field) {
  auto corrupt = [&](const std::string& problem) { return makeError(ErrorCode::CorruptData, name + ": " + problem); };
  field.width = loadU32(data + 16);
  field.height = loadU32(data + 20);
  field.order = loadU32(data + 24);
  field.channels = loadU32(data + 28);
  field.quantization = static_cast<Quantization>(loadU32(data + 32));
  const uint32_t sectionCount = loadU32(data + 36);
  if (field.width == 0 || field.height == 0 || field.width > kMaxAtlasSize || field.height > kMaxAtlasSize)
    return corrupt("atlas is " + std::to_string(field.width) + "x" + std::to_string(field.height) + ", expected 1.." +
                   std::to_string(kMaxAtlasSize) + " texels per side");
  if (field.order > kMaxOrder)
    return corrupt("order " + std::to_string(field.order) + " is over the limit of " + std::to_string(kMaxOrder));
  if (sectionCount != kSectionCount)
    return corrupt("header lists " + std::to_string(sectionCount) + " sections, version " +
                   std::to_string(kFieldFormatVersion) + " has " + std::to_string(kSectionCount));
  return {};
}

// Section s's contents (kSections order) into `field`; failures are left in `r`.
void readSection(uint32_t s, SectionReader& r, uint64_t length, Field& field) {
  switch (s) {
    case 0:
      if (length < kSettingsFixedBytes)
        r.fail("truncated: settings section needs at least " + std::to_string(kSettingsFixedBytes) + " bytes, has " +
               std::to_string(length));
      readSettings(r, field.settings, field.statistics);
      break;
    case 1: readMedia(r, field.media); break;
    case 2: readMesh(r, field.mesh); break;
    case 3: readAtlas(r, field); break;
    case 4:
      r.arrayF32(field.scale, "scale");
      r.arrayF32(field.bias, "bias");
      break;
    case 5:
      r.arrayU8(field.coefficientsU8, "u8 coefficients");
      r.arrayU16(field.coefficientsF16, "f16 coefficients");
      break;
    default: readEncoding(r, field); break;
  }
}

// Every section, in order, each read to its exact length, up to the checksum.
Result<void> readSections(const uint8_t* data, size_t body, const std::string& name, Field& field) {
  auto corrupt = [&](const std::string& problem) { return makeError(ErrorCode::CorruptData, name + ": " + problem); };
  size_t pos = kHeaderBytes;
  for (uint32_t s = 0; s < kSectionCount; ++s) {
    const SectionInfo& info = kSections[s];
    if (body - pos < kSectionHeaderBytes)
      return corrupt(std::string("truncated: ") + info.label + " section header needs " +
                     std::to_string(kSectionHeaderBytes) + " bytes, " + std::to_string(body - pos) + " left");
    if (std::memcmp(data + pos, info.tag.data(), 4) != 0)
      return corrupt("section " + std::to_string(s) + " has tag " + hexBytes(data + pos, 4) + ", expected \"" +
                     std::string(info.tag.data(), 4) + "\" (" + info.label + ")");
    const uint64_t length = loadU64(data + pos + 4);
    pos += kSectionHeaderBytes;
    if (length > body - pos)
      return corrupt(std::string("truncated: ") + info.label + " section needs " + std::to_string(length) + " bytes, " +
                     std::to_string(body - pos) + " left");
    SectionReader r(data + pos, static_cast<size_t>(length), name, info.label);
    readSection(s, r, length, field);
    if (r.failed()) return makeError(ErrorCode::CorruptData, r.message());
    if (r.consumed() != length)
      return corrupt(std::string(info.label) + " section is " + std::to_string(length) + " bytes, its contents use " +
                     std::to_string(r.consumed()));
    pos += static_cast<size_t>(length);
  }
  if (pos != body)
    return corrupt(std::to_string(body - pos) + " unexpected bytes between the last section and the checksum");
  return {};
}

}  // namespace

Result<Field> parseField(const uint8_t* data, size_t size, const std::string& name) {
  if (auto r = checkFrame(data, size, name); !r) return r.error();
  Field field;
  if (auto r = readHeader(data, name, field); !r) return r.error();
  if (auto r = readSections(data, size - kChecksumBytes, name, field); !r) return r.error();
  if (auto r = validateField(field); !r) return makeError(ErrorCode::CorruptData, name + ": " + r.error().message);
  if (field.encoding == Encoding::Volume) {
    field.volume.convex = meshIsConvex(field.mesh);
    setVolumeFarReach(field.volume);
  }
  return field;
}

Result<Field> readField(const std::string& path) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) return makeError(ErrorCode::Io, path + ": cannot open: " + errnoMessage(errno));
  // Read to the end in chunks (works for pipes too); the size on disk is only a capacity hint.
  std::vector<uint8_t> bytes;
  bool readFailed = false;
  int error = 0;
  try {
    std::error_code ec;
    const std::uintmax_t hint = std::filesystem::file_size(path, ec);
    if (!ec && hint <= std::numeric_limits<size_t>::max()) bytes.reserve(static_cast<size_t>(hint));
    std::vector<uint8_t> chunk(size_t(1) << 20);
    for (;;) {
      const size_t got = std::fread(chunk.data(), 1, chunk.size(), file);
      bytes.insert(bytes.end(), chunk.begin(), chunk.begin() + static_cast<std::ptrdiff_t>(got));
      if (got < chunk.size()) break;
    }
    readFailed = std::ferror(file) != 0;
    error = errno;
  } catch (const std::bad_alloc&) {
    std::fclose(file);
    return makeError(ErrorCode::Io, path + ": the file does not fit in memory");
  }
  std::fclose(file);
  if (readFailed) return makeError(ErrorCode::Io, path + ": read failed: " + errnoMessage(error));
  return parseField(bytes.data(), bytes.size(), path);
}

}  // namespace shrefract
