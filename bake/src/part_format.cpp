// The part file of a sharded bake (.shrfpart, shard.h) and the checks that parts belong together.
#include <shrefract/bake/shard.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <unistd.h>

#include "fnv1a.h"

namespace shrefract::bake {
namespace {

constexpr char kMagic[8] = {'S', 'H', 'R', 'F', 'P', 'A', 'R', 'T'};
// 2: the settings name the direction sampling; 3: the jump distance; 4: the frame of the exits;
// 5: the frames of the polar cap of a curved surface (sample_frame.h frameAt): an older part traced
// those samples in frames its merge would no longer store; 6: the clusters a Pca bake tries; 7: how
// an SH bake fits; 8: the volume size and whether the merge tries the volume.
constexpr uint32_t kPartVersion = 10;  // 9: BakeSettings::volumeDensify; 10: moreClusters
constexpr size_t kHeaderBytes = 8 + 4 + 8 + 8;  // magic, version, payload size, checksum

uint64_t fnv1a(const uint8_t* data, size_t size) {
  Fnv1a h;
  h.add(data, size);
  return h.value();
}

class Writer {
 public:
  std::vector<uint8_t> bytes;
  void u32(uint32_t v) { put(v, 4); }
  void u64(uint64_t v) { put(v, 8); }
  void f32(float v) { u32(std::bit_cast<uint32_t>(v)); }
  void f64(double v) { u64(std::bit_cast<uint64_t>(v)); }
  void text(const std::string& s) {
    u64(s.size());
    bytes.insert(bytes.end(), s.begin(), s.end());
  }
  void floats(const std::vector<float>& v) {
    u64(v.size());
    for (float f : v) f32(f);
  }

 private:
  void put(uint64_t v, int n) {  // little endian, whatever the host
    for (int i = 0; i < n; ++i) bytes.push_back(static_cast<uint8_t>(v >> (8 * i)));
  }
};

// Reads what Writer wrote; past the end it sets `failed` and returns zeros.
class Reader {
 public:
  Reader(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  bool failed = false;
  bool atEnd() const { return pos_ == size_; }
  uint32_t u32() { return static_cast<uint32_t>(get(4)); }
  uint64_t u64() { return get(8); }
  float f32() { return std::bit_cast<float>(u32()); }
  double f64() { return std::bit_cast<double>(u64()); }
  std::string text() {
    const uint64_t n = u64();
    if (!have(n)) return {};
    std::string s(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return s;
  }
  std::vector<float> floats() {
    const uint64_t n = u64();
    if (n > (size_ - pos_) / 4 || !have(n * 4)) return {};
    std::vector<float> v(n);
    for (float& f : v) f = f32();
    return v;
  }
  // Into a field, as visitPartBody calls them (Writer's take the value).
  void u32(uint32_t& v) { v = u32(); }
  void u64(uint64_t& v) { v = u64(); }
  void f64(double& v) { v = f64(); }
  void floats(std::vector<float>& v) { v = floats(); }

 private:
  bool have(uint64_t n) {
    if (failed || n > size_ - pos_) failed = true;
    return !failed;
  }
  uint64_t get(int n) {
    if (!have(uint64_t(n))) return 0;
    uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= uint64_t(data_[pos_ + size_t(i)]) << (8 * i);
    pos_ += size_t(n);
    return v;
  }
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
};

// Every field of BakeSettings, named, in file order: the one list that writes, reads and compares
// them (a new BakeSettings field belongs here too). `v` gets (name, reference); enums carry their
// largest valid value.
template <class S, class V>
void visitSettings(S& s, V& v) {
  v.text("source", s.source);
  v.u32("order", s.order);
  v.u32("directions rows", s.directionsTheta);
  v.u32("directions columns", s.directionsPhi);
  v.enumeration("layout", s.layout, 1);
  v.enumeration("encoding", s.encoding, 2);
  v.u32("table size", s.tableSize);
  v.u32("components", s.components);
  v.u32("clusters", s.clusters);
  v.enumeration("path rule", s.pathRule, 1);
  v.boolean("throughput", s.throughput);
  v.enumeration("direction sampling", s.directionSampling, 1);
  v.boolean("jump distance", s.jumpDistance);
  v.enumeration("exit frame", s.exitFrame, 2);
  v.f32("max bytes per sample", s.maxBytesPerSample);
  v.u64("sample budget", s.sampleBudget);
  v.f32("density", s.samplesPerUnitArea);
  v.u32("max bounces", s.maxBounces);
  v.enumeration("window", s.window, 2);
  v.u32("spatial", s.spatialNeighbours);
  v.enumeration("quantization", s.quantization, 1);
  v.f32("regularization", s.regularization);
  v.enumeration("sh fit", s.shFit, 1);
  v.u32("volume size", s.volumeSize);
  v.boolean("try volume", s.tryVolume);
  v.boolean("volume densify", s.volumeDensify);  // a merge densifies the volume it keeps as the bake would
  v.boolean("more clusters", s.moreClusters);  // and tries the clusters the bake would
  v.f32("max error", s.maxErrorDegrees);
  v.u32("threads", s.threads);
}

// The fields after the settings, in file order: the one list that writes and reads them. `io` is a
// Writer or a Reader.
template <class P, class IO>
void visitPartBody(P& p, IO& io) {
  io.u32(p.heldOutDirections);
  io.u32(p.shard.index);
  io.u32(p.shard.count);
  io.u64(p.sampleCount);
  io.u64(p.sceneHash);
  io.u32(p.channels);
  io.u32(p.directions);
  io.u64(p.stride);
  io.u64(p.rays);
  io.u64(p.paths);
  io.u64(p.trappedPaths);
  io.f64(p.timings.bakeSeconds);
  io.f64(p.timings.traceWallSeconds);
  io.f64(p.timings.threadTraceSeconds);
  io.f64(p.timings.threadFitSeconds);
  io.u64(p.timings.peakMemoryBytes);
  io.floats(p.coefficients);
  io.floats(p.heldOut);
  io.floats(p.gridExits);
}

struct SettingsWriter {
  Writer& w;
  // Byte ranges of each field, for comparisons by name.
  std::vector<std::pair<const char*, std::vector<uint8_t>>> fields;
  void mark(const char* name, size_t from) {
    fields.emplace_back(name, std::vector<uint8_t>(w.bytes.begin() + std::ptrdiff_t(from), w.bytes.end()));
  }
  void text(const char* n, const std::string& v) { const size_t at = w.bytes.size(); w.text(v); mark(n, at); }
  void u32(const char* n, uint32_t v) { const size_t at = w.bytes.size(); w.u32(v); mark(n, at); }
  void u64(const char* n, uint64_t v) { const size_t at = w.bytes.size(); w.u64(v); mark(n, at); }
  void f32(const char* n, float v) { const size_t at = w.bytes.size(); w.f32(v); mark(n, at); }
  void boolean(const char* n, bool v) { u32(n, v ? 1u : 0u); }
  template <class E>
  void enumeration(const char* n, E v, uint32_t) { u32(n, static_cast<uint32_t>(v)); }
};

struct SettingsReader {
  Reader& r;
  std::string bad;  // the first field out of range
  void text(const char*, std::string& v) { v = r.text(); }
  void u32(const char*, uint32_t& v) { v = r.u32(); }
  void u64(const char*, uint64_t& v) { v = r.u64(); }
  void f32(const char* n, float& v) {
    v = r.f32();
    if (!std::isfinite(v) && bad.empty()) bad = n;
  }
  void boolean(const char* n, bool& v) {
    const uint32_t x = r.u32();
    if (x > 1 && bad.empty()) bad = n;
    v = x != 0;
  }
  template <class E>
  void enumeration(const char* n, E& v, uint32_t largest) {
    const uint32_t x = r.u32();
    if (x > largest && bad.empty()) bad = n;
    v = static_cast<E>(std::min(x, largest));
  }
};

// The first setting (threads aside: they never change the data) in which a and b differ, or "".
std::string settingsDifference(const BakeSettings& a, const BakeSettings& b) {
  Writer wa, wb;
  SettingsWriter va{wa, {}}, vb{wb, {}};
  visitSettings(a, va);
  visitSettings(b, vb);
  for (size_t i = 0; i < va.fields.size(); ++i)
    if (std::strcmp(va.fields[i].first, "threads") != 0 && va.fields[i].second != vb.fields[i].second)
      return va.fields[i].first;
  return {};
}

Error corrupt(const std::string& name, const std::string& what) {
  return makeError(ErrorCode::CorruptData, name + ": not a valid bake part: " + what);
}

std::string shardText(Shard s) { return std::to_string(s.index) + "/" + std::to_string(s.count); }

// Sizes of the data arrays against the header's counts, and every float finite. Errors name `name`.
Result<void> checkPartData(const BakePart& p, const std::string& name) {
  if (p.shard.count < 1 || p.shard.count > kMaxShards || p.shard.index >= p.shard.count)
    return corrupt(name, "shard " + shardText(p.shard) + " out of range");
  if (p.channels < 3 || p.channels > kMaxEncodedChannels || p.directions < 1 || p.stride < 1 || p.stride > (1u << 24) ||
      p.heldOutDirections > 1024 || p.sampleCount > (uint64_t(1) << 40))
    return corrupt(name, "counts out of range");
  const uint64_t count = shardSampleCount(p.sampleCount, p.shard);
  uint64_t gridSamples = 0;
  for (uint64_t s = p.shard.index; s < p.sampleCount; s += p.shard.count) gridSamples += s % kGridCheckStride == 0 ? 1 : 0;
  if (p.coefficients.size() != count * p.stride || p.heldOut.size() != count * p.heldOutDirections * 6 ||
      p.gridExits.size() != gridSamples * p.directions * 3)
    return corrupt(name, "data sizes disagree with its sample count");
  for (const auto* v : {&p.coefficients, &p.heldOut, &p.gridExits})
    if (!std::all_of(v->begin(), v->end(), [](float f) { return std::isfinite(f); }))
      return corrupt(name, "a value is not finite");
  return {};
}

}  // namespace

Result<Shard> parseShard(const std::string& text) {
  unsigned long long i = 0, n = 0;
  char tail = 0;
  if (text.find_first_not_of("0123456789/") != std::string::npos ||
      std::sscanf(text.c_str(), "%llu/%llu%c", &i, &n, &tail) != 2 || n < 1 || n > kMaxShards || i >= n)
    return makeError(ErrorCode::InvalidArgument, "--shard must be I/N with 0 <= I < N <= " +
                                                     std::to_string(kMaxShards) + ", got '" + text + "'");
  return Shard{static_cast<uint32_t>(i), static_cast<uint32_t>(n)};
}

std::vector<uint8_t> serializePart(const BakePart& p) {
  Writer w;
  SettingsWriter sw{w, {}};
  visitSettings(p.settings, sw);
  visitPartBody(p, w);
  Writer out;
  out.bytes.assign(kMagic, kMagic + 8);
  out.u32(kPartVersion);
  out.u64(w.bytes.size());
  out.u64(fnv1a(w.bytes.data(), w.bytes.size()));
  out.bytes.insert(out.bytes.end(), w.bytes.begin(), w.bytes.end());
  return out.bytes;
}

Result<BakePart> parsePart(const uint8_t* data, size_t size, const std::string& name) {
  if (size < kHeaderBytes || std::memcmp(data, kMagic, 8) != 0) return corrupt(name, "no part header");
  Reader header(data + 8, kHeaderBytes - 8);
  const uint32_t version = header.u32();
  const uint64_t payload = header.u64(), checksum = header.u64();
  if (version != kPartVersion)
    return makeError(ErrorCode::Unsupported, name + ": part version " + std::to_string(version) + ", this tool reads " +
                                                 std::to_string(kPartVersion));
  if (payload != size - kHeaderBytes)
    return corrupt(name, "truncated (" + std::to_string(size - kHeaderBytes) + " of " + std::to_string(payload) +
                             " payload bytes)");
  if (fnv1a(data + kHeaderBytes, payload) != checksum) return corrupt(name, "checksum mismatch");
  Reader r(data + kHeaderBytes, payload);
  BakePart p;
  p.name = name;
  SettingsReader sr{r, {}};
  visitSettings(p.settings, sr);
  if (!sr.bad.empty()) return corrupt(name, "setting '" + sr.bad + "' out of range");
  visitPartBody(p, r);
  if (r.failed || !r.atEnd()) return corrupt(name, "sections disagree with the payload size");
  if (auto ok = checkPartData(p, name); !ok) return ok.error();
  return p;
}

Result<BakePart> readPart(const std::string& path) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) return makeError(ErrorCode::Io, path + ": cannot open: " + std::strerror(errno));
  std::vector<uint8_t> bytes;
  uint8_t buffer[1 << 16];
  for (size_t n; (n = std::fread(buffer, 1, sizeof buffer, file)) > 0;) bytes.insert(bytes.end(), buffer, buffer + n);
  const bool failed = std::ferror(file) != 0;
  std::fclose(file);
  if (failed) return makeError(ErrorCode::Io, path + ": read failed");
  return parsePart(bytes.data(), bytes.size(), path);
}

Result<void> writePart(const std::string& path, const BakePart& part) {
  // What parsePart would refuse (a NaN from a degenerate fit, say) never reaches a file.
  if (auto ok = checkPartData(part, path); !ok)
    return makeError(ErrorCode::InvalidArgument, "refusing to write " + ok.error().message);
  const std::vector<uint8_t> bytes = serializePart(part);
  const std::string temporary = path + ".tmp-" + std::to_string(static_cast<long>(getpid()));
  std::FILE* file = std::fopen(temporary.c_str(), "wb");
  if (!file) return makeError(ErrorCode::Io, path + ": cannot create " + temporary + ": " + std::strerror(errno));
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
  const bool closed = std::fclose(file) == 0;
  std::error_code ec;
  if (written && closed) std::filesystem::rename(temporary, path, ec);
  if (!written || !closed || ec) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    return makeError(ErrorCode::Io, path + ": writing failed" + (ec ? ": " + ec.message() : std::string()));
  }
  return {};
}

Result<void> checkParts(const std::vector<BakePart>& parts) {
  if (parts.empty()) return makeError(ErrorCode::InvalidArgument, "merge: no parts given");
  const BakePart& a = parts.front();
  auto bad = [&](const BakePart& p, const std::string& what) {
    return makeError(ErrorCode::InvalidArgument, p.name + ": not a part of the same bake as " + a.name + " (" + what + ")");
  };
  std::map<uint32_t, const BakePart*> seen;
  for (const BakePart& p : parts) {
    if (const std::string d = settingsDifference(a.settings, p.settings); !d.empty())
      return bad(p, "setting '" + d + "' differs");
    if (p.shard.count != a.shard.count)
      return bad(p, "shard " + shardText(p.shard) + " against " + shardText(a.shard));
    if (p.heldOutDirections != a.heldOutDirections) return bad(p, "held-out directions differ");
    if (p.sceneHash != a.sceneHash || p.sampleCount != a.sampleCount || p.channels != a.channels ||
        p.directions != a.directions || p.stride != a.stride)
      return bad(p, "baked from another scene or layout");
    if (auto [it, fresh] = seen.emplace(p.shard.index, &p); !fresh)
      return makeError(ErrorCode::InvalidArgument,
                       p.name + ": shard " + shardText(p.shard) + " given twice (also " + it->second->name + ")");
  }
  for (uint32_t i = 0; i < a.shard.count; ++i)
    if (!seen.count(i))
      return makeError(ErrorCode::InvalidArgument, "merge: shard " + shardText({i, a.shard.count}) +
                                                       " is missing (" + std::to_string(parts.size()) + " of " +
                                                       std::to_string(a.shard.count) + " parts given)");
  return {};
}

}  // namespace shrefract::bake
