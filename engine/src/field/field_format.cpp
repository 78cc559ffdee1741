// The .shrf file (docs/field-format.md): serialization, parsing, structural validation and the
// coefficient quantization. Readers never trust a length: every count is checked against the
// bytes that remain before anything is allocated for it.
#include <shrefract/field.h>
#include <shrefract/gpu_layout.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <new>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#if defined(_WIN32)
#include <process.h>
#else
#include <unistd.h>
#endif

#include "core/half.h"

namespace shrefract {

const char* toString(SampleLayout layout) {
  switch (layout) {
    case SampleLayout::Split: return "split";
    case SampleLayout::Charts: return "charts";
  }
  return "unknown";
}

const char* toString(Quantization quantization) {
  switch (quantization) {
    case Quantization::U8: return "u8";
    case Quantization::F16: return "f16";
  }
  return "unknown";
}

const char* toString(SmoothingWindow window) {
  switch (window) {
    case SmoothingWindow::None: return "none";
    case SmoothingWindow::Hann: return "hann";
    case SmoothingWindow::Lanczos: return "lanczos";
  }
  return "unknown";
}

const char* toString(Encoding encoding) {
  switch (encoding) {
    case Encoding::Sh: return "sh";
    case Encoding::Table: return "table";
    case Encoding::Pca: return "pca";
    case Encoding::Volume: return "volume";
  }
  return "unknown";
}

const char* toString(DirectionSampling sampling) {
  switch (sampling) {
    case DirectionSampling::Grid: return "grid";
    case DirectionSampling::Nodes: return "nodes";
  }
  return "unknown";
}

const char* toString(ExitFrame frame) {
  switch (frame) {
    case ExitFrame::Object: return "object";
    case ExitFrame::Sample: return "sample";
    case ExitFrame::Auto: return "auto";
  }
  return "unknown";
}

const char* toString(ShFit fit) {
  switch (fit) {
    case ShFit::LeastSquares: return "least-squares";
    case ShFit::Robust: return "robust";
  }
  return "unknown";
}

const char* toString(PathRule rule) {
  switch (rule) {
    case PathRule::HighestEnergy: return "highest-energy";
    case PathRule::FirstRefraction: return "first-refraction";
  }
  return "unknown";
}

namespace {

// Limits of the format (docs/field-format.md, "Limits"). They bound what a hostile file can ask for.
constexpr uint32_t kMaxAtlasSize = 16384;      // texels per side
constexpr uint32_t kMaxOrder = 32;             // SH order
constexpr uint32_t kMaxStringBytes = 65536;    // any length-prefixed string
constexpr uint32_t kSectionCount = 7;
// Largest magnitude of a Pca basis value. Direction channels (x, y, z): with |weights| <=
// kMaxCoefficientMagnitude and at most kMaxComponents functions every decoded sum stays below
// 1e15 * 8 * 1024 = 8.2e18, so the squared length of (x, y, z) stays below 2.1e38, finite in
// float. tau and throughput are clamped after decoding; a bound of 1e6 keeps their sums finite.
// Baked bases hold unit eigenvectors (direction entries within 1).
constexpr float kMaxBasisDirectionMagnitude = 8.0f;
constexpr float kMaxBasisMagnitude = 1e6f;
constexpr size_t kHeaderBytes = 40;
constexpr size_t kFrameBytes = 16;             // magic, version, file size: fixed in every version
constexpr size_t kSectionHeaderBytes = 12;     // tag, u64 payload length
constexpr size_t kChecksumBytes = 4;
constexpr size_t kSettingsFixedBytes = 164;
constexpr std::array<char, 4> kMagic{'S', 'H', 'R', 'F'};
// Smallest float magnitude that binary16 round-to-nearest-even turns into Inf (65504 + half a ulp).
constexpr float kHalfOverflow = 65520.0f;

struct SectionInfo {
  std::array<char, 4> tag;
  const char* label;  // as used in messages
};
constexpr std::array<SectionInfo, kSectionCount> kSections{{
    {{'S', 'E', 'T', 'S'}, "settings"},
    {{'M', 'D', 'I', 'A'}, "media"},
    {{'M', 'E', 'S', 'H'}, "mesh"},
    {{'A', 'T', 'L', 'S'}, "atlas"},
    {{'Q', 'T', 'B', 'L'}, "quantization"},
    {{'C', 'O', 'E', 'F'}, "coefficient"},
    {{'E', 'N', 'C', 'D'}, "encoding"},
}};

// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, init and final xor 0xFFFFFFFF): the
// checksum of zlib, PNG and gzip, so any tool can verify a file.
constexpr std::array<uint32_t, 256> makeCrcTable() {
  std::array<uint32_t, 256> table{};
  for (uint32_t i = 0; i < 256; ++i) {
    uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
    table[i] = c;
  }
  return table;
}
constexpr std::array<uint32_t, 256> kCrcTable = makeCrcTable();

uint32_t crc32(const uint8_t* data, size_t size) {
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) c = kCrcTable[(c ^ data[i]) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

uint32_t loadU32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) | (static_cast<uint32_t>(p[2]) << 16) |
         (static_cast<uint32_t>(p[3]) << 24);
}

uint64_t loadU64(const uint8_t* p) {
  return static_cast<uint64_t>(loadU32(p)) | (static_cast<uint64_t>(loadU32(p + 4)) << 32);
}

std::string formatFloat(float value) {
  std::ostringstream out;
  out.precision(9);
  out << value;
  return out.str();
}

std::string hex32(uint32_t value) {
  char buffer[11];
  std::snprintf(buffer, sizeof buffer, "0x%08x", static_cast<unsigned>(value));
  return buffer;
}

// "89 50 4e 47": raw bytes for messages about a magic or a tag that is not what it should be.
std::string hexBytes(const uint8_t* p, size_t n) {
  std::string out;
  for (size_t i = 0; i < n; ++i) {
    char buffer[4];
    std::snprintf(buffer, sizeof buffer, "%02x", static_cast<unsigned>(p[i]));
    if (i) out += ' ';
    out += buffer;
  }
  return out;
}

std::string texelName(const Field& field, uint64_t texel) {
  return "texel " + std::to_string(texel) + " (x " + std::to_string(texel % field.width) + ", y " +
         std::to_string(texel / field.width) + ")";
}

// ---------------------------------------------------------------------------------------------
// Writing

class ByteWriter {
 public:
  void u8(uint8_t v) { bytes_.push_back(v); }
  void u16(uint16_t v) {
    u8(static_cast<uint8_t>(v & 0xFFu));
    u8(static_cast<uint8_t>(v >> 8));
  }
  void u32(uint32_t v) {
    for (int k = 0; k < 4; ++k) u8(static_cast<uint8_t>((v >> (8 * k)) & 0xFFu));
  }
  void u64(uint64_t v) {
    for (int k = 0; k < 8; ++k) u8(static_cast<uint8_t>((v >> (8 * k)) & 0xFFu));
  }
  void f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
  void f64(double v) { u64(std::bit_cast<uint64_t>(v)); }
  void tag(const std::array<char, 4>& t) {
    for (char c : t) u8(static_cast<uint8_t>(c));
  }
  void string(const std::string& s) {
    u32(static_cast<uint32_t>(s.size()));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
  }
  void arrayU8(const std::vector<uint8_t>& v) {
    u64(v.size());
    bytes_.insert(bytes_.end(), v.begin(), v.end());
  }
  void arrayU16(const std::vector<uint16_t>& v) {
    u64(v.size());
    for (uint16_t x : v) u16(x);
  }
  void arrayU32(const std::vector<uint32_t>& v) {
    u64(v.size());
    for (uint32_t x : v) u32(x);
  }
  void arrayF32(const std::vector<float>& v) {
    u64(v.size());
    for (float x : v) f32(x);
  }

  // Sections: beginSection writes the tag and a placeholder length that endSection patches.
  void beginSection(const std::array<char, 4>& t) {
    tag(t);
    sectionStart_ = bytes_.size();
    u64(0);
  }
  void endSection() { patchU64(sectionStart_, bytes_.size() - sectionStart_ - 8); }

  void patchU64(size_t at, uint64_t v) {
    for (int k = 0; k < 8; ++k) bytes_[at + static_cast<size_t>(k)] = static_cast<uint8_t>((v >> (8 * k)) & 0xFFu);
  }
  std::vector<uint8_t>& bytes() { return bytes_; }

 private:
  std::vector<uint8_t> bytes_;
  size_t sectionStart_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Reading

// Reads one section's payload. Errors are sticky: after the first failure every read returns zero
// and allocates nothing, so a section parser checks failed() once at the end.
class SectionReader {
 public:
  SectionReader(const uint8_t* data, size_t size, const std::string& name, const char* section)
      : data_(data), size_(size), name_(name), section_(section) {}

  bool failed() const { return failed_; }
  const std::string& message() const { return message_; }
  size_t remaining() const { return size_ - pos_; }
  size_t consumed() const { return pos_; }

  void fail(const std::string& problem) {
    if (failed_) return;
    failed_ = true;
    message_ = name_ + ": " + problem;
  }

  // Whether `bytes` more bytes are there; fails with a truncation message naming `what` if not.
  bool need(uint64_t bytes, const char* what) {
    if (failed_) return false;
    if (bytes > remaining()) {
      fail(std::string("truncated: ") + section_ + " section: " + what + " needs " + std::to_string(bytes) +
           " bytes, " + std::to_string(remaining()) + " left");
      return false;
    }
    return true;
  }

  uint32_t u32(const char* what) {
    if (!need(4, what)) return 0;
    const uint32_t v = loadU32(data_ + pos_);
    pos_ += 4;
    return v;
  }
  uint64_t u64(const char* what) {
    if (!need(8, what)) return 0;
    const uint64_t v = loadU64(data_ + pos_);
    pos_ += 8;
    return v;
  }
  float f32(const char* what) { return std::bit_cast<float>(u32(what)); }
  double f64(const char* what) { return std::bit_cast<double>(u64(what)); }

  void string(std::string& out, const char* what) {
    const uint32_t length = u32(what);
    if (failed_) return;
    if (length > kMaxStringBytes) {
      fail(std::string(section_) + " section: " + what + " is " + std::to_string(length) + " bytes, over the cap of " +
           std::to_string(kMaxStringBytes));
      return;
    }
    if (!need(length, what)) return;
    out.assign(reinterpret_cast<const char*>(data_ + pos_), length);
    pos_ += length;
  }

  // Array: u64 element count, then the elements. The count is checked against the remaining
  // bytes before anything is allocated.
  template <class T, class Decode>
  void array(std::vector<T>& out, size_t elementBytes, const char* what, Decode decode) {
    const uint64_t count = u64(what);
    if (failed_) return;
    if (count > remaining() / elementBytes) {
      fail(std::string("truncated: ") + section_ + " section: " + what + " (" + std::to_string(count) +
           " elements) needs " + std::to_string(count) + " x " + std::to_string(elementBytes) + " bytes, " +
           std::to_string(remaining()) + " left");
      return;
    }
    out.resize(static_cast<size_t>(count));
    const uint8_t* p = data_ + pos_;
    for (size_t i = 0; i < out.size(); ++i) out[i] = decode(p + i * elementBytes);
    pos_ += static_cast<size_t>(count) * elementBytes;
  }
  void arrayU8(std::vector<uint8_t>& out, const char* what) {
    array(out, 1, what, [](const uint8_t* p) { return p[0]; });
  }
  void arrayU16(std::vector<uint16_t>& out, const char* what) {
    array(out, 2, what, [](const uint8_t* p) {
      return static_cast<uint16_t>(static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8));
    });
  }
  void arrayU32(std::vector<uint32_t>& out, const char* what) { array(out, 4, what, loadU32); }
  void arrayF32(std::vector<float>& out, const char* what) {
    array(out, 4, what, [](const uint8_t* p) { return std::bit_cast<float>(loadU32(p)); });
  }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
  const std::string& name_;
  const char* section_;
  bool failed_ = false;
  std::string message_;
};

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

void writeMesh(ByteWriter& w, const FieldMesh& mesh) {
  w.arrayF32(mesh.positions);
  w.arrayF32(mesh.normals);
  w.arrayF32(mesh.uvs);
  w.arrayF32(mesh.frontIor);
  w.arrayU32(mesh.indices);
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

void readAtlas(SectionReader& r, Field& field) {
  r.arrayU8(field.texelKinds, "texel kinds");
  r.arrayF32(field.frames, "frames");
  r.array(field.gutters, 16, "gutters", [](const uint8_t* p) {
    return GutterTexel{loadU32(p), loadU32(p + 4), loadU32(p + 8), loadU32(p + 12)};
  });
}

// ---------------------------------------------------------------------------------------------
// Validation helpers

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

// The encoding's parameters, channels and (Pca) basis: what every decoder relies on.
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

  const BakeStatistics& t = field.statistics;
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

Result<void> validateCoefficients(const Field& field) {
  if (field.clustered) return validateClusterIndices(field);
  if (!field.clusterIndices.empty())
    return invalid("cluster indices has " + std::to_string(field.clusterIndices.size()) +
                   " entries but the field is not clustered");
  const uint64_t texels = field.texelCount();
  const uint32_t values = field.valuesPerLayer();
  const uint64_t tables = uint64_t(field.layerCount()) * values;
  const uint64_t count = tables * texels;
  if (field.quantization == Quantization::U8) {
    if (field.coefficientsU8.size() != count)
      return invalid("coefficientsU8 has " + std::to_string(field.coefficientsU8.size()) + " entries, expected " +
                     std::to_string(count) + " (layers x texels x values)");
    if (!field.coefficientsF16.empty())
      return invalid("coefficientsF16 has " + std::to_string(field.coefficientsF16.size()) +
                     " entries but the field is quantized to u8");
    if (field.scale.size() != tables || field.bias.size() != tables)
      return invalid("scale/bias have " + std::to_string(field.scale.size()) + "/" + std::to_string(field.bias.size()) +
                     " entries, expected " + std::to_string(tables) + " (layers x values)");
    for (size_t i = 0; i < tables; ++i) {
      const float top = field.bias[i] + field.scale[i];  // the decoded value of q = 255
      if (!std::isfinite(field.scale[i]) || !std::isfinite(field.bias[i]) || !std::isfinite(top))
        return invalid("scale/bias of layer " + std::to_string(i / values) + " value " +
                       std::to_string(i % values) + " (" + formatFloat(field.scale[i]) + ", " +
                       formatFloat(field.bias[i]) + ") do not decode to finite values");
      // Every level lies between bias and top; bounding both keeps every SH sum finite in float.
      if (!(std::fabs(field.bias[i]) <= kMaxCoefficientMagnitude) || !(std::fabs(top) <= kMaxCoefficientMagnitude))
        return invalid("scale/bias of layer " + std::to_string(i / values) + " value " +
                       std::to_string(i % values) + " (" + formatFloat(field.scale[i]) + ", " +
                       formatFloat(field.bias[i]) + ") decode beyond +-" + formatFloat(kMaxCoefficientMagnitude));
    }
  } else {
    if (field.coefficientsF16.size() != count)
      return invalid("coefficientsF16 has " + std::to_string(field.coefficientsF16.size()) + " entries, expected " +
                     std::to_string(count) + " (layers x texels x values)");
    if (!field.coefficientsU8.empty())
      return invalid("coefficientsU8 has " + std::to_string(field.coefficientsU8.size()) +
                     " entries but the field is quantized to f16");
    if (!field.scale.empty() || !field.bias.empty())
      return invalid("scale/bias have " + std::to_string(field.scale.size()) + "/" + std::to_string(field.bias.size()) +
                     " entries but the field is quantized to f16 (expected none)");
    for (size_t i = 0; i < count; ++i) {
      const uint16_t h = field.coefficientsF16[i];
      if ((h & 0x7C00u) == 0x7C00u) {
        const uint64_t perLayer = texels * values;
        return invalid("coefficientsF16[" + std::to_string(i) + "] (layer " + std::to_string(i / perLayer) + ", " +
                       texelName(field, (i % perLayer) / values) + ", value " +
                       std::to_string(i % values) + ") is " + ((h & 0x3FFu) ? "NaN" : "Inf") + " (bits " +
                       hex32(h) + ")");
      }
    }
  }
  return {};
}

std::string errnoMessage(int error) { return std::generic_category().message(error); }

}  // namespace

// -------------------------------------------------------------------------------------------------

float fieldCoefficient(const Field& field, uint32_t layer, uint64_t texel, uint32_t value) {
  if (field.clustered) return static_cast<float>(field.clusterIndices[texel]);
  const uint32_t values = field.valuesPerLayer();
  const size_t index = static_cast<size_t>((uint64_t(layer) * field.texelCount() + texel) * values + value);
  if (field.quantization == Quantization::F16) return halfToFloat(field.coefficientsF16[index]);
  const size_t table = size_t(layer) * values + value;
  return field.bias[table] + field.scale[table] * (static_cast<float>(field.coefficientsU8[index]) / 255.0f);
}

namespace {

// What encodeCoefficients needs of the field before it reads a coefficient. A clustered field's
// tables are stored as binary16: they are rounded first, so that the checks read what is stored.
Result<void> checkEncodable(Field& field) {
  if (field.clustered)
    for (float& v : field.basis) v = halfToFloat(floatToHalf(v));
  if (auto r = validateEncoding(field); !r)
    return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: " + r.error().message);
  if (field.width > kMaxAtlasSize || field.height > kMaxAtlasSize)
    return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: order " + std::to_string(field.order) + " or atlas " +
                                                     std::to_string(field.width) + "x" + std::to_string(field.height) +
                                                     " beyond the format's limits");
  if (field.quantization != Quantization::U8 && field.quantization != Quantization::F16)
    return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: unknown quantization " +
                                                     std::to_string(static_cast<uint32_t>(field.quantization)));
  return {};
}

}  // namespace

Result<void> encodeCoefficients(Field& field, const std::vector<float>& coefficients) {
  if (auto r = checkEncodable(field); !r) return r;
  const uint64_t values = field.valuesPerLayer(), perLayer = field.texelCount() * values;
  const uint64_t count = perLayer * field.layerCount();
  if (coefficients.size() != count)
    return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: " + std::to_string(coefficients.size()) +
                                                     " coefficients, expected " + std::to_string(count) +
                                                     " (layers x texels x values)");
  const float* data = coefficients.data();
  return encodeCoefficients(field, [data, values](uint64_t t) { return data + t * values; }, perLayer);
}

namespace {

// The coefficients encodeCoefficients reads: value c of layer `layer` at texel t, zero for a texel
// without values. Every loop over them below visits them in the quantized arrays' order (layers x
// texels x values); i is the index there.
struct CoefficientSource {
  std::vector<const float*> rows;  // per texel
  uint64_t layerStride = 0;
  uint32_t layers = 0;
  uint64_t texels = 0;
  uint32_t channels = 0;  // the stored values per layer (Pca: one weight)

  float value(uint32_t layer, uint64_t t, uint32_t c) const {
    return rows[t] ? rows[t][layer * layerStride + c] : 0.0f;
  }
};

// Every coefficient finite, within the format's magnitude and, for F16, the half-float range.
Result<void> checkCoefficients(const Field& field, const CoefficientSource& src) {
  for (size_t i = 0, layer = 0; layer < src.layers; ++layer)
    for (uint64_t t = 0; t < src.texels; ++t)
      for (uint32_t c = 0; c < src.channels; ++c, ++i) {
        const float v = src.value(uint32_t(layer), t, c);
        const auto refuse = [&](const std::string& why) {
          return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: coefficient " + std::to_string(i) +
                                                           " (layer " + std::to_string(layer) + ", channel " +
                                                           std::to_string(c) + ")" + why);
        };
        if (!std::isfinite(v)) return refuse(" is not finite");
        if (!(std::fabs(v) <= kMaxCoefficientMagnitude))
          return refuse(" = " + formatFloat(v) + " is beyond +-" + formatFloat(kMaxCoefficientMagnitude));
        if (field.quantization == Quantization::F16 && !(std::fabs(v) < kHalfOverflow))
          return refuse(" = " + formatFloat(v) + " is beyond the half-float range (|v| < 65520)");
      }
  return {};
}

void encodeF16(Field& field, const CoefficientSource& src) {
  std::vector<uint16_t> out(size_t(src.layers) * src.texels * src.channels);
  for (size_t i = 0, layer = 0; layer < src.layers; ++layer)
    for (uint64_t t = 0; t < src.texels; ++t)
      for (uint32_t c = 0; c < src.channels; ++c) out[i++] = floatToHalf(src.value(uint32_t(layer), t, c));
  field.coefficientsF16 = std::move(out);
  field.coefficientsU8.clear();
  field.scale.clear();
  field.bias.clear();
}

// U8: per (layer, channel) range over all texels, into `scale` and `bias`. The range is taken in
// double so that a span wider than float can be reported instead of turning into Inf.
Result<void> u8Ranges(const CoefficientSource& src, std::vector<float>& scale, std::vector<float>& bias) {
  const size_t tables = size_t(src.layers) * src.channels;
  scale.assign(tables, 0.0f);
  bias.assign(tables, 0.0f);
  for (uint32_t layer = 0; layer < src.layers; ++layer) {
    for (uint32_t c = 0; c < src.channels; ++c) {
      float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
      for (uint64_t t = 0; t < src.texels; ++t) {
        const float v = src.value(layer, t, c);
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
      const float range = static_cast<float>(static_cast<double>(hi) - static_cast<double>(lo));
      if (!std::isfinite(range) || !std::isfinite(lo + range))
        return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: layer " + std::to_string(layer) + " channel " +
                                                         std::to_string(c) + ": range [" + formatFloat(lo) + ", " +
                                                         formatFloat(hi) + "] does not fit a float scale");
      scale[size_t(layer) * src.channels + c] = range;
      bias[size_t(layer) * src.channels + c] = lo;
    }
  }
  return {};
}

Result<void> encodeU8(Field& field, const CoefficientSource& src) {
  std::vector<float> scale, bias;
  if (auto r = u8Ranges(src, scale, bias); !r) return r;
  std::vector<uint8_t> out(size_t(src.layers) * src.texels * src.channels);
  for (size_t i = 0, layer = 0; layer < src.layers; ++layer)
    for (uint64_t t = 0; t < src.texels; ++t)
      for (uint32_t c = 0; c < src.channels; ++c, ++i) {
        const size_t table = layer * src.channels + c;
        if (scale[table] == 0.0f) {
          out[i] = 0;
          continue;
        }
        const double level = (static_cast<double>(src.value(uint32_t(layer), t, c)) - static_cast<double>(bias[table])) /
                             static_cast<double>(scale[table]) * 255.0;
        out[i] = static_cast<uint8_t>(std::clamp(std::floor(level + 0.5), 0.0, 255.0));
      }
  field.coefficientsU8 = std::move(out);
  field.scale = std::move(scale);
  field.bias = std::move(bias);
  field.coefficientsF16.clear();
  return {};
}

// A clustered field: each texel's one value is its function's index, stored exactly.
Result<void> encodeIndices(Field& field, const CoefficientSource& src) {
  std::vector<uint16_t> out(src.texels);
  for (uint64_t t = 0; t < src.texels; ++t) {
    const float v = src.value(0, t, 0);
    if (!(v >= 0.0f && v < float(field.components) && v == std::floor(v)))
      return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: texel " + std::to_string(t) + "'s value " +
                                                       formatFloat(v) + " is not a function index below " +
                                                       std::to_string(field.components));
    out[t] = static_cast<uint16_t>(v);
  }
  field.clusterIndices = std::move(out);
  field.coefficientsU8.clear();
  field.coefficientsF16.clear();
  field.scale.clear();
  field.bias.clear();
  return {};
}

}  // namespace

Result<void> encodeCoefficients(Field& field, const std::function<const float*(uint64_t texel)>& texelValues,
                                uint64_t layerStride) {
  if (auto r = checkEncodable(field); !r) return r;
  CoefficientSource src;
  src.layerStride = layerStride;
  src.layers = field.layerCount();
  src.texels = field.texelCount();
  src.channels = field.valuesPerLayer();
  if (layerStride < src.channels)
    return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: layer stride " + std::to_string(layerStride) +
                                                     " is below the " + std::to_string(src.channels) +
                                                     " values per layer");
  src.rows.resize(src.texels);
  for (uint64_t t = 0; t < src.texels; ++t) src.rows[t] = texelValues(t);
  if (auto r = checkCoefficients(field, src); !r) return r;
  if (field.clustered) return encodeIndices(field, src);
  field.clusterIndices.clear();
  if (field.quantization == Quantization::F16) {
    encodeF16(field, src);
    return {};
  }
  return encodeU8(field, src);
}

Result<void> validateField(const Field& field) {
  if (field.width == 0 || field.height == 0 || field.width > kMaxAtlasSize || field.height > kMaxAtlasSize)
    return invalid("atlas is " + std::to_string(field.width) + "x" + std::to_string(field.height) + ", expected 1.." +
                   std::to_string(kMaxAtlasSize) + " texels per side");
  if (auto r = validateEncoding(field); !r) return r;
  if (field.quantization != Quantization::U8 && field.quantization != Quantization::F16)
    return invalid("quantization " + std::to_string(static_cast<uint32_t>(field.quantization)) +
                   " is neither u8 (0) nor f16 (1)");
  if (auto r = validateSettings(field); !r) return r;
  if (auto r = validateMedia(field); !r) return r;
  if (auto r = validateMesh(field.mesh); !r) return r;
  if (auto r = validateAtlas(field); !r) return r;
  return validateCoefficients(field);
}

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

namespace {

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
  if (field.encoding == Encoding::Volume) field.volume.convex = meshIsConvex(field.mesh);
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
