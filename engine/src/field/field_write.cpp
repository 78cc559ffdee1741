// Writing a .shrf file (docs/field-format.md): each section's writer mirrors its reader in
// field_read.cpp, and writeField replaces the file only once it is whole.
#include <shrefract/field.h>

#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#if defined(_WIN32)
#include <process.h>
#else
#include <unistd.h>
#endif

#include "core/half.h"
#include "field/byte_writer.h"
#include "field/field_file.h"

namespace shrefract {
using namespace fieldfile;  // the layout and helpers every part of the format shares (field_file.h)

namespace {

void writeSettings(ByteWriter& w, const BakeRecord& s, const BakeStatistics& t) {
  w.u32(s.order);
  w.u32(s.directionsTheta);
  w.u32(s.directionsPhi);
  w.u32(static_cast<uint32_t>(s.layout));
  w.u64(s.sampleBudget);
  w.f32(s.samplesPerUnitArea);
  w.u32(s.maxBounces);
  w.u32(static_cast<uint32_t>(s.window));
  w.u32(s.spatialNeighbours);
  w.u32(static_cast<uint32_t>(s.quantization));
  w.f32(s.regularization);
  w.u32(s.threads);
  w.u64(t.samples);
  w.u64(t.uniqueSamples);
  w.u64(t.directions);
  w.u64(t.paths);
  w.u64(t.rays);
  w.u64(t.trappedPaths);
  w.f64(t.bakeSeconds);
  w.f64(t.traceSeconds);
  w.f64(t.fitSeconds);
  w.f64(t.raysPerSecond);
  w.u64(t.peakMemoryBytes);
  w.f32(t.fitRmsDegrees);
  w.f32(t.fitMaxDegrees);
  w.f32(t.heldOutRmsDegrees);
  w.f32(t.heldOutMaxDegrees);
  w.f32(t.quantizationRmsDegrees);
  w.f32(t.quantizationMaxDegrees);
  w.string(s.source);
  w.f32(s.maxErrorDegrees);
}

void writeMedia(ByteWriter& w, const std::vector<FieldMedium>& media) {
  w.u32(static_cast<uint32_t>(media.size()));
  for (const FieldMedium& m : media) {
    w.f32(m.ior);
    w.f32(m.absorption);
    for (float c : m.color) w.f32(c);
    w.string(m.name);
  }
}

void writeMesh(ByteWriter& w, const FieldMesh& mesh) {
  w.arrayF32(mesh.positions);
  w.arrayF32(mesh.normals);
  w.arrayF32(mesh.uvs);
  w.arrayF32(mesh.frontIor);
  w.arrayU32(mesh.indices);
}

void writeVolume(ByteWriter& w, const Field& field) {
  const FieldVolume& v = field.volume;
  w.u32(v.size);
  for (float o : v.origin) w.f32(o);
  w.f32(v.spacing);
  w.arrayU32({});  // no dense voxels: the grid is in bricks
  w.u32(field.settings.volumeSize);
  w.u32(field.settings.tryVolume ? 1u : 0u);
  w.arrayU32(v.bricks);
  w.arrayU32(v.brickVoxels);
}

void writeEncoding(ByteWriter& w, const Field& field) {
  w.u32(static_cast<uint32_t>(field.encoding));
  w.u32(field.tableSize);
  w.u32(field.components);
  w.u32(field.throughput ? 1u : 0u);
  const BakeRecord& s = field.settings;
  w.u32(static_cast<uint32_t>(s.encoding));
  w.u32(s.tableSize);
  w.u32(s.components);
  w.u32(s.throughput ? 1u : 0u);
  w.u32(static_cast<uint32_t>(s.pathRule));
  w.f32(s.maxBytesPerSample);
  static const std::vector<float> kNoBasis;  // a clustered field's tables are binary16, at the end
  w.arrayF32(field.clustered ? kNoBasis : field.basis);  // both lvalues: the basis is not copied
  w.u32(static_cast<uint32_t>(s.directionSampling));
  w.u32(field.jumpDistance ? 1u : 0u);
  w.u32(field.sampleFrameExits ? 1u : 0u);
  w.u32(field.clustered ? 1u : 0u);
  w.arrayU16(field.clusterIndices);
  w.u32(s.clusters);
  std::vector<uint16_t> tables;
  if (field.clustered)
    for (float v : field.basis) tables.push_back(floatToHalf(v));
  w.arrayU16(tables);
  w.u32(static_cast<uint32_t>(s.shFit));
  writeVolume(w, field);
}

void writeAtlas(ByteWriter& w, const Field& field) {
  w.arrayU8(field.texelKinds);
  w.arrayF32(field.frames);
  w.u64(field.gutters.size());
  for (const GutterTexel& g : field.gutters) {
    w.u32(g.target);
    w.u32(g.a);
    w.u32(g.b);
    w.u32(g.c);
  }
}

}  // namespace

std::vector<uint8_t> serializeField(const Field& field) {
  ByteWriter w;
  w.tag(kMagic);
  w.u32(kFieldFormatVersion);
  w.u64(0);  // file size, patched below
  w.u32(field.width);
  w.u32(field.height);
  w.u32(field.order);
  w.u32(field.channels);
  w.u32(static_cast<uint32_t>(field.quantization));
  w.u32(kSectionCount);

  // The sections in kSections order, each the mirror of its reader in parseField.
  w.beginSection(kSections[0].tag);
  writeSettings(w, field.settings, field.statistics);
  w.endSection();
  w.beginSection(kSections[1].tag);
  writeMedia(w, field.media);
  w.endSection();
  w.beginSection(kSections[2].tag);
  writeMesh(w, field.mesh);
  w.endSection();
  w.beginSection(kSections[3].tag);
  writeAtlas(w, field);
  w.endSection();
  w.beginSection(kSections[4].tag);
  w.arrayF32(field.scale);
  w.arrayF32(field.bias);
  w.endSection();
  w.beginSection(kSections[5].tag);
  w.arrayU8(field.coefficientsU8);
  w.arrayU16(field.coefficientsF16);
  w.endSection();
  w.beginSection(kSections[6].tag);
  writeEncoding(w, field);
  w.endSection();

  std::vector<uint8_t>& bytes = w.bytes();
  w.patchU64(8, bytes.size() + kChecksumBytes);
  w.u32(crc32(bytes.data(), bytes.size()));
  return std::move(bytes);
}

Result<void> writeField(const std::string& path, const Field& field) {
  if (auto r = validateField(field); !r)
    return makeError(ErrorCode::InvalidArgument, path + ": refusing to write an invalid field: " + r.error().message);
  const std::vector<uint8_t> bytes = serializeField(field);
#if defined(_WIN32)
  const long pid = static_cast<long>(_getpid());
#else
  const long pid = static_cast<long>(getpid());
#endif
  const std::string temporary = path + ".tmp-" + std::to_string(pid);

  std::FILE* file = std::fopen(temporary.c_str(), "wb");
  if (!file)
    return makeError(ErrorCode::Io, path + ": cannot create temporary file " + temporary + ": " + errnoMessage(errno));
  const size_t written = std::fwrite(bytes.data(), 1, bytes.size(), file);
  const int writeError = errno;
  const bool closed = std::fclose(file) == 0;
  const int closeError = errno;
  std::error_code ignored;
  if (written != bytes.size() || !closed) {
    std::filesystem::remove(temporary, ignored);
    return makeError(ErrorCode::Io, path + ": writing " + temporary + " failed: " +
                                        errnoMessage(written != bytes.size() ? writeError : closeError));
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary, ignored);
    return makeError(ErrorCode::Io, path + ": cannot rename " + temporary + " into place: " + ec.message());
  }
  return {};
}

}  // namespace shrefract
