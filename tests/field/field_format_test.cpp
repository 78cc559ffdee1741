// The .shrf format (docs/field-format.md): exact round trips, rejection of every truncation, of
// corrupted bytes and of newer and older versions, structural validation, coefficient quantization, and the
// atomic file write.
#include <shrefract/field.h>
#include <shrefract/field_decode.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace shrefract {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// An independent CRC-32 (bitwise, no table) so the tests check the spec, not the implementation.
uint32_t referenceCrc32(const uint8_t* data, size_t size) {
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) {
    c ^= data[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return ~c;
}

TEST(FieldFormatChecksum, ReferenceCrcMatchesTheCheckValue) {
  const std::string check = "123456789";
  EXPECT_EQ(referenceCrc32(reinterpret_cast<const uint8_t*>(check.data()), check.size()), 0xCBF43926u);
}

uint32_t getU32(const std::vector<uint8_t>& b, size_t at) {
  return static_cast<uint32_t>(b[at]) | (static_cast<uint32_t>(b[at + 1]) << 8) |
         (static_cast<uint32_t>(b[at + 2]) << 16) | (static_cast<uint32_t>(b[at + 3]) << 24);
}
uint64_t getU64(const std::vector<uint8_t>& b, size_t at) {
  return static_cast<uint64_t>(getU32(b, at)) | (static_cast<uint64_t>(getU32(b, at + 4)) << 32);
}
void putU32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
  for (size_t k = 0; k < 4; ++k) b[at + k] = static_cast<uint8_t>(v >> (8 * k));
}
void putU64(std::vector<uint8_t>& b, size_t at, uint64_t v) {
  for (size_t k = 0; k < 8; ++k) b[at + k] = static_cast<uint8_t>(v >> (8 * k));
}
// Recomputes the trailing checksum after a test edits the bytes on purpose.
void resign(std::vector<uint8_t>& b) { putU32(b, b.size() - 4, referenceCrc32(b.data(), b.size() - 4)); }

// Offset of the payload of the section with `tag` (docs: sections follow the 40-byte header,
// each as tag, u64 length, payload).
size_t sectionPayload(const std::vector<uint8_t>& b, const char* tag) {
  size_t pos = 40;
  while (pos + 12 <= b.size() - 4) {
    const uint64_t length = getU64(b, pos + 4);
    if (std::memcmp(&b[pos], tag, 4) == 0) return pos + 12;
    pos += 12 + static_cast<size_t>(length);
  }
  ADD_FAILURE() << "section " << tag << " not found";
  return 0;
}

// ---------------------------------------------------------------------------------------------
// A small synthetic field: 8x4 atlas, order 2 (9 layers), 3 gutter texels, 2 empty texels.

constexpr uint32_t kWidth = 8, kHeight = 4, kOrder = 2, kLayers = 9;
constexpr float kConstantLayer0Channel1 = 0.25f;  // a zero-range (layer, channel)

struct Variant {
  uint32_t channels;
  Quantization quantization;
};

std::vector<float> syntheticCoefficients(uint32_t channels) {
  const size_t texels = kWidth * kHeight;
  std::vector<float> v(kLayers * texels * channels);
  uint32_t state = 12345u;
  for (float& x : v) {
    state = state * 1664525u + 1013904223u;
    x = static_cast<float>(state >> 8) / static_cast<float>(1u << 24) - 0.5f;  // [-0.5, 0.5)
  }
  for (size_t t = 0; t < texels; ++t) v[t * channels + 1] = kConstantLayer0Channel1;
  return v;
}

Field makeField(Variant variant) {
  Field f;
  f.width = kWidth;
  f.height = kHeight;
  f.order = kOrder;
  f.channels = variant.channels;
  f.quantization = variant.quantization;

  const uint32_t texels = kWidth * kHeight;
  f.texelKinds.assign(texels, kTexelSample);
  f.frames.assign(texels * 12, 0.0f);
  f.texelKinds[7] = kTexelEmpty;
  f.texelKinds[15] = kTexelEmpty;
  for (uint32_t g : {14u, 23u, 31u}) f.texelKinds[g] = kTexelGutter;
  f.gutters = {{14, 12, 13, 5}, {23, 20, 21, 22}, {31, 28, 29, 30}};
  for (uint32_t t = 0; t < texels; ++t) {
    if (f.texelKinds[t] != kTexelSample) continue;
    const float x = static_cast<float>(t % kWidth), y = static_cast<float>(t / kWidth);
    const std::array<float, 12> rows{1.0f, 0.0f, 0.0f, -x, 0.0f, 0.6f, 0.8f, -y, 0.0f, -0.8f, 0.6f, 0.1f * x};
    std::copy(rows.begin(), rows.end(), f.frames.begin() + t * 12);
  }

  f.mesh.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0.5f};
  f.mesh.normals = {0, 0, 1, 0, 0, 1, 0, 0.6f, 0.8f, 0, 0, -1};
  f.mesh.uvs = {0.0f, 0.0f, 1.0f, 0.0f, 1.0f, 1.0f, 0.0625f, 0.875f};
  f.mesh.frontIor = {1.5f, 1.5f, 1.0f / 1.5f, 1.33f};
  f.mesh.indices = {0, 1, 2, 0, 2, 3};

  f.media.push_back({"air", 1.0f, 0.0f, {1.0f, 1.0f, 1.0f}});
  f.media.push_back({"glass \xC3\xA9", 1.5f, variant.channels == 4 ? 0.3f : 0.0f, {0.9f, 0.95f, 1.0f}});

  BakeRecord& s = f.settings;
  s.source = "builtin:test";
  s.order = kOrder;
  s.directionsTheta = 8;
  s.directionsPhi = 16;
  s.layout = SampleLayout::Split;
  s.sampleBudget = 123456789012ull;
  s.samplesPerUnitArea = 12.5f;
  s.maxBounces = 16;
  s.window = SmoothingWindow::Hann;
  s.spatialNeighbours = 3;
  s.quantization = variant.quantization;
  s.regularization = 1e-3f;
  s.threads = 7;

  BakeStatistics& t = f.statistics;
  t.samples = 27;
  t.uniqueSamples = 20;
  t.directions = 128;
  t.paths = 3456;
  t.rays = 99999;
  t.trappedPaths = 3;
  t.bakeSeconds = 0.1;
  t.traceSeconds = 5e-324;  // subnormal: must survive bit for bit
  t.fitSeconds = 1e300;
  t.raysPerSecond = 12345.678901234567;
  t.peakMemoryBytes = 1ull << 40;
  t.fitRmsDegrees = 0.1f;
  t.fitMaxDegrees = 1e-40f;  // subnormal float
  t.heldOutRmsDegrees = 2.5f;
  t.heldOutMaxDegrees = 7.25f;
  t.quantizationRmsDegrees = -0.0f;
  t.quantizationMaxDegrees = 3.0e38f;

  const Result<void> encoded = encodeCoefficients(f, syntheticCoefficients(variant.channels));
  EXPECT_TRUE(encoded.ok()) << encoded.error().message;
  return f;
}

std::vector<uint32_t> bits(const std::vector<float>& v) {
  std::vector<uint32_t> out(v.size());
  for (size_t i = 0; i < v.size(); ++i) out[i] = std::bit_cast<uint32_t>(v[i]);
  return out;
}
uint32_t bits(float v) { return std::bit_cast<uint32_t>(v); }
uint64_t bits(double v) { return std::bit_cast<uint64_t>(v); }

// Field for field, floats compared bit for bit.
void expectSameField(const Field& a, const Field& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.order, b.order);
  EXPECT_EQ(a.channels, b.channels);
  EXPECT_EQ(a.quantization, b.quantization);
  EXPECT_EQ(a.coefficientsU8, b.coefficientsU8);
  EXPECT_EQ(a.coefficientsF16, b.coefficientsF16);
  EXPECT_EQ(bits(a.scale), bits(b.scale));
  EXPECT_EQ(bits(a.bias), bits(b.bias));
  EXPECT_EQ(bits(a.frames), bits(b.frames));
  EXPECT_EQ(a.texelKinds, b.texelKinds);
  ASSERT_EQ(a.gutters.size(), b.gutters.size());
  for (size_t i = 0; i < a.gutters.size(); ++i) {
    EXPECT_EQ(a.gutters[i].target, b.gutters[i].target);
    EXPECT_EQ(a.gutters[i].a, b.gutters[i].a);
    EXPECT_EQ(a.gutters[i].b, b.gutters[i].b);
    EXPECT_EQ(a.gutters[i].c, b.gutters[i].c);
  }
  EXPECT_EQ(bits(a.mesh.positions), bits(b.mesh.positions));
  EXPECT_EQ(bits(a.mesh.normals), bits(b.mesh.normals));
  EXPECT_EQ(bits(a.mesh.uvs), bits(b.mesh.uvs));
  EXPECT_EQ(bits(a.mesh.frontIor), bits(b.mesh.frontIor));
  EXPECT_EQ(a.mesh.indices, b.mesh.indices);
  ASSERT_EQ(a.media.size(), b.media.size());
  for (size_t i = 0; i < a.media.size(); ++i) {
    EXPECT_EQ(a.media[i].name, b.media[i].name);
    EXPECT_EQ(bits(a.media[i].ior), bits(b.media[i].ior));
    EXPECT_EQ(bits(a.media[i].absorption), bits(b.media[i].absorption));
    for (size_t k = 0; k < 3; ++k) EXPECT_EQ(bits(a.media[i].color[k]), bits(b.media[i].color[k]));
  }
  const BakeRecord &s = a.settings, &u = b.settings;
  EXPECT_EQ(s.source, u.source);
  EXPECT_EQ(s.order, u.order);
  EXPECT_EQ(s.directionsTheta, u.directionsTheta);
  EXPECT_EQ(s.directionsPhi, u.directionsPhi);
  EXPECT_EQ(s.layout, u.layout);
  EXPECT_EQ(s.sampleBudget, u.sampleBudget);
  EXPECT_EQ(bits(s.samplesPerUnitArea), bits(u.samplesPerUnitArea));
  EXPECT_EQ(s.maxBounces, u.maxBounces);
  EXPECT_EQ(s.window, u.window);
  EXPECT_EQ(s.spatialNeighbours, u.spatialNeighbours);
  EXPECT_EQ(s.quantization, u.quantization);
  EXPECT_EQ(bits(s.regularization), bits(u.regularization));
  EXPECT_EQ(s.shFit, u.shFit);
  EXPECT_EQ(s.threads, u.threads);
  const BakeStatistics &t = a.statistics, &v = b.statistics;
  EXPECT_EQ(t.samples, v.samples);
  EXPECT_EQ(t.uniqueSamples, v.uniqueSamples);
  EXPECT_EQ(t.directions, v.directions);
  EXPECT_EQ(t.paths, v.paths);
  EXPECT_EQ(t.rays, v.rays);
  EXPECT_EQ(t.trappedPaths, v.trappedPaths);
  EXPECT_EQ(bits(t.bakeSeconds), bits(v.bakeSeconds));
  EXPECT_EQ(bits(t.traceSeconds), bits(v.traceSeconds));
  EXPECT_EQ(bits(t.fitSeconds), bits(v.fitSeconds));
  EXPECT_EQ(bits(t.raysPerSecond), bits(v.raysPerSecond));
  EXPECT_EQ(t.peakMemoryBytes, v.peakMemoryBytes);
  EXPECT_EQ(bits(t.fitRmsDegrees), bits(v.fitRmsDegrees));
  EXPECT_EQ(bits(t.fitMaxDegrees), bits(v.fitMaxDegrees));
  EXPECT_EQ(bits(t.heldOutRmsDegrees), bits(v.heldOutRmsDegrees));
  EXPECT_EQ(bits(t.heldOutMaxDegrees), bits(v.heldOutMaxDegrees));
  EXPECT_EQ(bits(t.quantizationRmsDegrees), bits(v.quantizationRmsDegrees));
  EXPECT_EQ(bits(t.quantizationMaxDegrees), bits(v.quantizationMaxDegrees));
}

Result<Field> parse(const std::vector<uint8_t>& bytes, const std::string& name) {
  return parseField(bytes.data(), bytes.size(), name);
}

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

// ---------------------------------------------------------------------------------------------
// Serialization, for each of channels 3/4 x u8/f16.

class FieldFormat : public ::testing::TestWithParam<Variant> {};

TEST_P(FieldFormat, SyntheticFieldIsValid) {
  const Field f = makeField(GetParam());
  const Result<void> r = validateField(f);
  EXPECT_TRUE(r.ok()) << r.error().message;
}

TEST_P(FieldFormat, RoundTripIsExact) {
  const Field f = makeField(GetParam());
  const std::vector<uint8_t> bytes = serializeField(f);
  const Result<Field> parsed = parse(bytes, "round.shrf");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  expectSameField(f, parsed.value());
  // Serialization is deterministic: the parsed field writes the same bytes.
  EXPECT_EQ(serializeField(parsed.value()), bytes);
}

TEST_P(FieldFormat, HeaderMatchesTheSpec) {
  const Field f = makeField(GetParam());
  const std::vector<uint8_t> b = serializeField(f);
  ASSERT_GE(b.size(), 44u);
  EXPECT_EQ(std::string(b.begin(), b.begin() + 4), "SHRF");
  EXPECT_EQ(getU32(b, 4), kFieldFormatVersion);
  EXPECT_EQ(getU64(b, 8), b.size());
  EXPECT_EQ(getU32(b, 16), kWidth);
  EXPECT_EQ(getU32(b, 20), kHeight);
  EXPECT_EQ(getU32(b, 24), kOrder);
  EXPECT_EQ(getU32(b, 28), GetParam().channels);
  EXPECT_EQ(getU32(b, 32), static_cast<uint32_t>(GetParam().quantization));
  EXPECT_EQ(getU32(b, 36), 7u);
  EXPECT_EQ(getU32(b, b.size() - 4), referenceCrc32(b.data(), b.size() - 4));
  // The file size formula of the spec.
  const uint64_t B = kLayers, T = kWidth * kHeight, C = GetParam().channels, V = f.mesh.positions.size() / 3;
  uint64_t media = 4;
  for (const FieldMedium& m : f.media) media += 24 + m.name.size();
  const uint64_t expected = 40 + 7 * 12 + (164 + 4 + f.settings.source.size() + 4) + media +
                            (5 * 8 + 4 * 9 * V + 4 * f.mesh.indices.size()) +
                            (8 + T + 8 + 48 * T + 8 + 16 * f.gutters.size()) +
                            (GetParam().quantization == Quantization::U8 ? 16 + 8 * B * C + 16 + B * T * C
                                                                         : 16 + 16 + 2 * B * T * C) +
                            (9 * 4 + 4 + 8 + 4 + 4 + 4 + 4 + 8 + 4 + 8 + 4) +  // ENCD: nine u32/f32, an
                                                                               // empty basis array, the sampling,
                                                                               // the jump distance, the exit frame,
                                                                               // clustered, no indices, the
                                                                               // clusters asked for, no binary16
                                                                               // tables, the SH fit
                            (4 + 12 + 4 + 8 + 4 + 4 + 8 + 8) +  // no volume: size 0, origin, spacing, no
                                                                // voxels, the size asked, not tried, no
                                                                // bricks, no brick voxels

                            4;
  EXPECT_EQ(b.size(), expected);
  // Sections in their fixed order, ending exactly at the checksum.
  size_t pos = 40;
  for (const char* tag : {"SETS", "MDIA", "MESH", "ATLS", "QTBL", "COEF", "ENCD"}) {
    ASSERT_LE(pos + 12, b.size() - 4);
    EXPECT_EQ(std::string(b.begin() + static_cast<std::ptrdiff_t>(pos), b.begin() + static_cast<std::ptrdiff_t>(pos) + 4), tag);
    pos += 12 + static_cast<size_t>(getU64(b, pos + 4));
  }
  EXPECT_EQ(pos, b.size() - 4);
  // The settings section: 164 fixed bytes, then the source string.
  const size_t sets = sectionPayload(b, "SETS");
  EXPECT_EQ(getU64(b, sets - 8), 164u + 4u + f.settings.source.size() + 4u);
  EXPECT_EQ(getU32(b, sets), kOrder);
  EXPECT_EQ(getU32(b, sets + 164), f.settings.source.size());
  // The coefficient section: u8 array, then f16 array, each with a u64 count.
  const size_t coef = sectionPayload(b, "COEF");
  const uint64_t count = uint64_t(kLayers) * kWidth * kHeight * GetParam().channels;
  if (GetParam().quantization == Quantization::U8) {
    EXPECT_EQ(getU64(b, coef), count);
    EXPECT_EQ(getU64(b, coef + 8 + count), 0u);
  } else {
    EXPECT_EQ(getU64(b, coef), 0u);
    EXPECT_EQ(getU64(b, coef + 8), count);
  }
}

TEST_P(FieldFormat, EveryTruncationIsRejected) {
  const std::vector<uint8_t> bytes = serializeField(makeField(GetParam()));
  for (size_t length = 0; length < bytes.size(); ++length) {
    // A copy of exactly `length` bytes, so a read past the end is a real overrun under sanitizers.
    const std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(length));
    const Result<Field> r = parseField(cut.data(), cut.size(), "cut.shrf");
    ASSERT_FALSE(r.ok()) << "length " << length;
    EXPECT_EQ(r.error().code, ErrorCode::CorruptData) << "length " << length;
    EXPECT_TRUE(contains(r.error().message, "cut.shrf")) << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos);
  }
}

TEST_P(FieldFormat, CorruptedBytesAreRejected) {
  const std::vector<uint8_t> bytes = serializeField(makeField(GetParam()));
  constexpr size_t kPositions = 200;
  for (size_t k = 0; k < kPositions; ++k) {
    const size_t at = k * (bytes.size() - 1) / (kPositions - 1);
    std::vector<uint8_t> bad = bytes;
    // Alternate between a single flipped bit and a fully inverted byte.
    bad[at] ^= (k % 2 == 0) ? static_cast<uint8_t>(1u << (k / 2 % 8)) : uint8_t{0xFF};
    const Result<Field> r = parse(bad, "flip.shrf");
    ASSERT_FALSE(r.ok()) << "byte " << at;
    EXPECT_EQ(r.error().code, ErrorCode::CorruptData) << "byte " << at << ": " << r.error().message;
    EXPECT_TRUE(contains(r.error().message, "flip.shrf")) << r.error().message;
  }
  // Past the header and its file size, the checksum is what catches a change.
  std::vector<uint8_t> bad = bytes;
  bad[bytes.size() / 2] ^= 0x10;
  const Result<Field> r = parse(bad, "flip.shrf");
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "checksum")) << r.error().message;
}

INSTANTIATE_TEST_SUITE_P(Variants, FieldFormat,
                         ::testing::Values(Variant{4, Quantization::U8}, Variant{3, Quantization::U8},
                                           Variant{4, Quantization::F16}, Variant{3, Quantization::F16}),
                         [](const ::testing::TestParamInfo<Variant>& p) {
                           return std::to_string(p.param.channels) + "ch_" + toString(p.param.quantization);
                         });

TEST(FieldFormatHeader, NewerVersionIsUnsupported) {
  std::vector<uint8_t> bytes = serializeField(makeField({4, Quantization::U8}));
  putU32(bytes, 4, kFieldFormatVersion + 1);
  resign(bytes);
  const Result<Field> r = parse(bytes, "future.shrf");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::Unsupported);
  EXPECT_TRUE(contains(r.error().message, "future.shrf")) << r.error().message;
  EXPECT_TRUE(contains(r.error().message, "version " + std::to_string(kFieldFormatVersion + 1))) << r.error().message;
  EXPECT_TRUE(contains(r.error().message, "version " + std::to_string(kFieldFormatVersion))) << r.error().message;

  // Unsigned: the checksum is verified first, so a damaged version field reads as corruption.
  putU32(bytes, bytes.size() - 4, getU32(bytes, bytes.size() - 4) ^ 1u);
  const Result<Field> damaged = parse(bytes, "future.shrf");
  ASSERT_FALSE(damaged.ok());
  EXPECT_EQ(damaged.error().code, ErrorCode::CorruptData);

  // Version 0 never existed.
  putU32(bytes, 4, 0);
  resign(bytes);
  const Result<Field> zero = parse(bytes, "zero.shrf");
  ASSERT_FALSE(zero.ok());
  EXPECT_EQ(zero.error().code, ErrorCode::CorruptData);
}

TEST(FieldFormatHeader, WrongMagicIsRejected) {
  std::vector<uint8_t> bytes = serializeField(makeField({4, Quantization::U8}));
  bytes[3] = 'G';
  resign(bytes);
  const Result<Field> r = parse(bytes, "magic.shrf");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::CorruptData);
  EXPECT_TRUE(contains(r.error().message, "magic.shrf")) << r.error().message;
  EXPECT_TRUE(contains(r.error().message, "magic")) << r.error().message;

  const std::vector<uint8_t> png{0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  const Result<Field> p = parse(png, "image.png");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().code, ErrorCode::CorruptData);
  EXPECT_TRUE(contains(p.error().message, "image.png")) << p.error().message;
}

TEST(FieldFormatHeader, TrailingBytesAreRejected) {
  std::vector<uint8_t> bytes = serializeField(makeField({4, Quantization::U8}));
  bytes.push_back(0);
  const Result<Field> r = parse(bytes, "long.shrf");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::CorruptData);
  EXPECT_TRUE(contains(r.error().message, "trailing")) << r.error().message;
}

// Lengths that a correctly checksummed but hostile file could carry: each is rejected before
// anything is allocated for it.
TEST(FieldFormatHeader, HostileLengthsAreRejected) {
  const std::vector<uint8_t> good = serializeField(makeField({4, Quantization::F16}));
  struct Edit {
    const char* label;
    std::function<void(std::vector<uint8_t>&)> apply;
    const char* expected;  // part of the message
  };
  const std::vector<Edit> edits{
      {"u8 coefficient count", [](auto& b) { putU64(b, sectionPayload(b, "COEF"), 1ull << 62); }, "truncated"},
      {"f16 coefficient count", [](auto& b) { putU64(b, sectionPayload(b, "COEF") + 8, ~0ull); }, "truncated"},
      {"frame count", [](auto& b) { putU64(b, sectionPayload(b, "ATLS") + 8 + kWidth * kHeight, 1ull << 40); }, "truncated"},
      {"gutter count", [](auto& b) {
         const size_t at = sectionPayload(b, "ATLS") + 8 + kWidth * kHeight;
         putU64(b, at + 8 + 4 * getU64(b, at), 1ull << 60);
       }, "truncated"},
      {"mesh positions", [](auto& b) { putU64(b, sectionPayload(b, "MESH"), 1ull << 61); }, "truncated"},
      {"media count", [](auto& b) { putU32(b, sectionPayload(b, "MDIA"), 0xFFFFFFFFu); }, "truncated"},
      {"source length", [](auto& b) { putU32(b, sectionPayload(b, "SETS") + 164, 0x7FFFFFFFu); }, "cap"},
      {"section length", [](auto& b) { putU64(b, sectionPayload(b, "COEF") - 8, 1ull << 50); }, "truncated"},
      {"section length short", [](auto& b) { putU64(b, sectionPayload(b, "SETS") - 8, 100); }, "settings"},
      {"width", [](auto& b) { putU32(b, 16, 16385); }, "16384"},
      {"height", [](auto& b) { putU32(b, 20, 0); }, "atlas"},
      {"order", [](auto& b) { putU32(b, 24, 1000); }, "order"},
      {"section count", [](auto& b) { putU32(b, 36, 8); }, "sections"},
      {"section tag", [](auto& b) { b[sectionPayload(b, "MESH") - 12] = 'X'; }, "tag"},
  };
  for (const Edit& edit : edits) {
    std::vector<uint8_t> bad = good;
    edit.apply(bad);
    resign(bad);
    const Result<Field> r = parse(bad, "hostile.shrf");
    ASSERT_FALSE(r.ok()) << edit.label;
    EXPECT_EQ(r.error().code, ErrorCode::CorruptData) << edit.label;
    EXPECT_TRUE(contains(r.error().message, "hostile.shrf")) << edit.label << ": " << r.error().message;
    EXPECT_TRUE(contains(r.error().message, edit.expected)) << edit.label << ": " << r.error().message;
  }
}

// ---------------------------------------------------------------------------------------------
// Validation: each case breaks one rule of a valid field. The broken field must fail
// validateField and, serialized anyway, fail parseField as corrupt data naming the file.

struct Breakage {
  const char* label;
  Variant variant;
  std::function<void(Field&)> apply;
  const char* expected;  // part of the message
};

class FieldValidation : public ::testing::TestWithParam<Breakage> {};

TEST_P(FieldValidation, IsRejected) {
  const Breakage& b = GetParam();
  Field f = makeField(b.variant);
  ASSERT_TRUE(validateField(f).ok());
  b.apply(f);
  const Result<void> r = validateField(f);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::CorruptData);
  EXPECT_TRUE(contains(r.error().message, b.expected)) << r.error().message;
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos);

  const Result<Field> parsed = parse(serializeField(f), "broken.shrf");
  ASSERT_FALSE(parsed.ok());
  EXPECT_EQ(parsed.error().code, ErrorCode::CorruptData);
  EXPECT_TRUE(contains(parsed.error().message, "broken.shrf")) << parsed.error().message;
  EXPECT_TRUE(contains(parsed.error().message, b.expected)) << parsed.error().message;
}

constexpr Variant kU8{4, Quantization::U8};
constexpr Variant kF16{4, Quantization::F16};
const float kNaN = std::numeric_limits<float>::quiet_NaN();
const float kInf = std::numeric_limits<float>::infinity();

INSTANTIATE_TEST_SUITE_P(
    Rules, FieldValidation,
    ::testing::Values(
        Breakage{"NaNInFrames", kU8, [](Field& f) { f.frames[12 * 3 + 5] = kNaN; }, "frame is not finite"},
        Breakage{"InfInFrames", kU8, [](Field& f) { f.frames[11] = -kInf; }, "frame is not finite"},
        Breakage{"EmptyTexelWithFrame", kU8, [](Field& f) { f.frames[12 * 7 + 3] = 1.0f; }, "empty"},
        Breakage{"SampleTexelWithZeroFrame", kU8,
                 [](Field& f) { std::fill(f.frames.begin() + 12 * 2, f.frames.begin() + 12 * 3, 0.0f); }, "zero"},
        Breakage{"NaNCoefficientF16", kF16, [](Field& f) { f.coefficientsF16[40] = 0x7E00; }, "NaN"},
        Breakage{"InfCoefficientF16", kF16, [](Field& f) { f.coefficientsF16[41] = 0x7C00; }, "Inf"},
        Breakage{"NegativeInfCoefficientF16", kF16, [](Field& f) { f.coefficientsF16.back() = 0xFC00; }, "Inf"},
        Breakage{"NaNScale", kU8, [](Field& f) { f.scale[3] = kNaN; }, "scale/bias"},
        Breakage{"InfBias", kU8, [](Field& f) { f.bias[0] = kInf; }, "scale/bias"},
        Breakage{"DecodedOverflow", kU8,
                 [](Field& f) {
                   f.bias[2] = 3e38f;
                   f.scale[2] = 3e38f;
                 },
                 "scale/bias"},
        Breakage{"IndexOutOfRange", kU8, [](Field& f) { f.mesh.indices[4] = 4; }, "out of range"},
        Breakage{"IndicesNotTriangles", kU8, [](Field& f) { f.mesh.indices.push_back(0); }, "multiple of 3"},
        Breakage{"UvAboveOne", kU8, [](Field& f) { f.mesh.uvs[3] = 1.0001f; }, "outside [0,1]"},
        Breakage{"UvBelowZero", kU8, [](Field& f) { f.mesh.uvs[0] = -0.25f; }, "outside [0,1]"},
        Breakage{"UvNaN", kU8, [](Field& f) { f.mesh.uvs[5] = kNaN; }, "outside [0,1]"},
        Breakage{"NormalNaN", kU8, [](Field& f) { f.mesh.normals[4] = kNaN; }, "normal"},
        Breakage{"PositionInf", kU8, [](Field& f) { f.mesh.positions[0] = kInf; }, "position"},
        Breakage{"FrontIorZero", kU8, [](Field& f) { f.mesh.frontIor[1] = 0.0f; }, "frontIor"},
        Breakage{"MeshSizes", kU8, [](Field& f) { f.mesh.normals.pop_back(); }, "mesh.normals"},
        Breakage{"GutterSourceEmpty", kU8, [](Field& f) { f.gutters[1].a = 7; }, "does not hold a sample"},
        Breakage{"GutterSourceGutter", kU8, [](Field& f) { f.gutters[1].c = 14; }, "does not hold a sample"},
        Breakage{"GutterTargetEmpty", kU8, [](Field& f) { f.gutters[0].target = 15; }, "not a gutter texel"},
        Breakage{"GutterOutOfRange", kU8, [](Field& f) { f.gutters[2].b = 32; }, "out of range"},
        Breakage{"GutterWithoutRule", kU8, [](Field& f) { f.gutters.pop_back(); }, "no rule"},
        Breakage{"GutterTwoRules", kU8, [](Field& f) { f.gutters.push_back(f.gutters[0]); }, "two rules"},
        Breakage{"TexelKindInvalid", kU8, [](Field& f) { f.texelKinds[3] = 3; }, "kind 3"},
        Breakage{"CoefficientCountU8", kU8, [](Field& f) { f.coefficientsU8.pop_back(); }, "coefficientsU8"},
        Breakage{"CoefficientCountF16", kF16, [](Field& f) { f.coefficientsF16.push_back(0); }, "coefficientsF16"},
        Breakage{"OtherArrayNotEmpty", kF16, [](Field& f) { f.coefficientsU8.push_back(0); }, "coefficientsU8"},
        Breakage{"ScaleInF16", kF16, [](Field& f) { f.scale.push_back(1.0f); }, "scale/bias"},
        Breakage{"ScaleCount", kU8, [](Field& f) { f.bias.pop_back(); }, "scale/bias"},
        Breakage{"FrameCount", kU8, [](Field& f) { f.frames.resize(f.frames.size() - 12); }, "frames"},
        Breakage{"TexelKindCount", kU8, [](Field& f) { f.texelKinds.push_back(0); }, "texelKinds"},
        Breakage{"OrderOver32", kU8,
                 [](Field& f) {
                   f.order = 33;
                   f.settings.order = 33;
                 },
                 "order 33"},
        Breakage{"WidthZero", kU8, [](Field& f) { f.width = 0; }, "atlas"},
        Breakage{"WidthOverCap", kU8, [](Field& f) { f.width = 16385; }, "16384"},
        Breakage{"Channels", kU8, [](Field& f) { f.channels = 5; }, "channels"},
        Breakage{"SettingsOrder", kU8, [](Field& f) { f.settings.order = 3; }, "settings.order"},
        Breakage{"SettingsDirections", kU8, [](Field& f) { f.settings.directionsPhi = 0; }, "direction grid"},
        Breakage{"SettingsSpatial", kU8, [](Field& f) { f.settings.spatialNeighbours = 4; }, "spatialNeighbours"},
        Breakage{"SettingsLayout", kU8, [](Field& f) { f.settings.layout = static_cast<SampleLayout>(7); }, "layout"},
        Breakage{"SettingsWindow", kU8, [](Field& f) { f.settings.window = static_cast<SmoothingWindow>(3); }, "window"},
        Breakage{"SettingsQuantization", kU8, [](Field& f) { f.settings.quantization = Quantization::F16; },
                 "settings.quantization"},
        Breakage{"StatisticsNaN", kU8, [](Field& f) { f.statistics.fitSeconds = std::nan(""); }, "fitSeconds"},
        Breakage{"StatisticsInf", kU8, [](Field& f) { f.statistics.heldOutMaxDegrees = kInf; }, "heldOutMaxDegrees"},
        Breakage{"NoMedia", kU8, [](Field& f) { f.media.clear(); }, "media"},
        Breakage{"IorZero", kU8, [](Field& f) { f.media[1].ior = 0.0f; }, "ior"},
        Breakage{"IorNaN", kU8, [](Field& f) { f.media[0].ior = kNaN; }, "ior"},
        Breakage{"AbsorptionNegative", kU8, [](Field& f) { f.media[1].absorption = -0.5f; }, "absorption"},
        Breakage{"AbsorptionInf", kU8, [](Field& f) { f.media[1].absorption = kInf; }, "absorption"},
        Breakage{"ColorNaN", kU8, [](Field& f) { f.media[1].color[2] = kNaN; }, "color"},
        Breakage{"AbsorbingWithThreeChannels", Variant{3, Quantization::U8},
                 [](Field& f) { f.media[1].absorption = 0.1f; }, "3 channels"}),
    [](const ::testing::TestParamInfo<Breakage>& p) { return std::string(p.param.label); });

// ---------------------------------------------------------------------------------------------
// Quantization.

TEST(EncodeCoefficients, U8ErrorIsHalfAStep) {
  for (uint32_t channels : {3u, 4u}) {
    const Field f = makeField({channels, Quantization::U8});
    const std::vector<float> v = syntheticCoefficients(channels);
    const uint64_t texels = f.texelCount();
    ASSERT_EQ(f.scale.size(), kLayers * channels);
    for (uint32_t layer = 0; layer < kLayers; ++layer)
      for (uint64_t t = 0; t < texels; ++t)
        for (uint32_t c = 0; c < channels; ++c) {
          const float value = v[(layer * texels + t) * channels + c];
          const float scale = f.scale[layer * channels + c];
          // Rounding to the nearest of 256 levels: half a step, plus float rounding of the decode.
          const float tolerance = scale / 510.0f + 1e-7f;
          EXPECT_LE(std::fabs(fieldCoefficient(f, layer, t, c) - value), tolerance)
              << "layer " << layer << " texel " << t << " channel " << c;
        }
    // The extremes of each (layer, channel) are the levels 0 and 255.
    for (size_t i = 0; i < f.scale.size(); ++i) {
      if (f.scale[i] == 0.0f) continue;
      const uint32_t layer = static_cast<uint32_t>(i / channels), c = static_cast<uint32_t>(i % channels);
      uint8_t lo = 255, hi = 0;
      for (uint64_t t = 0; t < texels; ++t) {
        const uint8_t q = f.coefficientsU8[(layer * texels + t) * channels + c];
        lo = std::min(lo, q);
        hi = std::max(hi, q);
      }
      EXPECT_EQ(lo, 0);
      EXPECT_EQ(hi, 255);
    }
  }
}

TEST(EncodeCoefficients, U8ZeroRangeDecodesExactly) {
  const Field f = makeField({4, Quantization::U8});
  EXPECT_EQ(f.scale[1], 0.0f);
  EXPECT_EQ(f.bias[1], kConstantLayer0Channel1);
  for (uint64_t t = 0; t < f.texelCount(); ++t) {
    EXPECT_EQ(f.coefficientsU8[t * 4 + 1], 0);
    EXPECT_EQ(bits(fieldCoefficient(f, 0, t, 1)), bits(kConstantLayer0Channel1));
  }
  // A whole field of one value, zero included: no division by zero, exact decode.
  Field g = makeField({3, Quantization::U8});
  for (float constant : {0.0f, -3.5f, 1e-30f}) {
    ASSERT_TRUE(encodeCoefficients(g, std::vector<float>(kLayers * 32 * 3, constant)).ok());
    for (uint32_t layer = 0; layer < kLayers; ++layer)
      EXPECT_EQ(bits(fieldCoefficient(g, layer, 9, 2)), bits(constant));
  }
}

TEST(EncodeCoefficients, F16ErrorWithinHalfPrecision) {
  Field f = makeField({4, Quantization::F16});
  std::vector<float> v = syntheticCoefficients(4);
  // Values across the half range: subnormal halves, exact halves, the largest finite half and
  // values that round down to it.
  const std::array<float, 12> special{0.0f, -0.0f, 1e-7f, -3e-6f, 6.1e-5f, 1.0f / 3.0f, 1000.1f, -2049.0f,
                                      65504.0f, -65504.0f, 65519.0f, 1e-12f};
  std::copy(special.begin(), special.end(), v.begin() + 100);
  ASSERT_TRUE(encodeCoefficients(f, v).ok());
  EXPECT_TRUE(f.coefficientsU8.empty());
  EXPECT_TRUE(f.scale.empty() && f.bias.empty());
  ASSERT_TRUE(validateField(f).ok());
  const uint64_t texels = f.texelCount();
  for (size_t i = 0; i < v.size(); ++i) {
    const float decoded = fieldCoefficient(f, static_cast<uint32_t>(i / (texels * 4)), (i / 4) % texels,
                                           static_cast<uint32_t>(i % 4));
    // Round to nearest: half a unit in the last place, 2^-11 relative for normal halves and
    // 2^-25 absolute (half the spacing 2^-24) for subnormal ones.
    const float tolerance = std::max(std::fabs(v[i]) * 0x1p-11f, 0x1p-25f);
    EXPECT_LE(std::fabs(decoded - v[i]), tolerance) << "value " << v[i];
  }
  EXPECT_EQ(fieldCoefficient(f, 0, 100 / 4 % texels, 100 % 4), 0.0f);
  EXPECT_EQ(f.coefficientsF16[101], 0x8000);  // -0 keeps its sign
  EXPECT_EQ(f.coefficientsF16[108], 0x7BFF);  // 65504
  EXPECT_EQ(f.coefficientsF16[110], 0x7BFF);  // 65519 rounds to 65504, not Inf
}

TEST(EncodeCoefficients, OutOfHalfRangeIsRejected) {
  for (float big : {65520.0f, -70000.0f, 1e30f}) {
    Field f = makeField({4, Quantization::F16});
    const std::vector<uint16_t> before = f.coefficientsF16;
    std::vector<float> v = syntheticCoefficients(4);
    const size_t at = 2 * 32 * 4 + 7;  // layer 2
    v[at] = big;
    const Result<void> r = encodeCoefficients(f, v);
    ASSERT_FALSE(r.ok()) << big;
    EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument);
    EXPECT_TRUE(contains(r.error().message, "layer 2")) << r.error().message;
    EXPECT_EQ(f.coefficientsF16, before);  // unchanged on error
  }
}

TEST(EncodeCoefficients, BadInputIsRejected) {
  for (Quantization q : {Quantization::U8, Quantization::F16}) {
    Field f = makeField({4, q});
    for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
      std::vector<float> v = syntheticCoefficients(4);
      v[17] = bad;
      const Result<void> r = encodeCoefficients(f, v);
      ASSERT_FALSE(r.ok());
      EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument);
      EXPECT_TRUE(contains(r.error().message, "not finite")) << r.error().message;
    }
    std::vector<float> shortList = syntheticCoefficients(4);
    shortList.pop_back();
    const Result<void> r = encodeCoefficients(f, shortList);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument);
  }
  // U8 with a range wider than float.
  Field f = makeField({3, Quantization::U8});
  std::vector<float> v = syntheticCoefficients(3);
  v[0] = 3e38f;
  v[3] = -3e38f;
  const Result<void> r = encodeCoefficients(f, v);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "layer 0")) << r.error().message;
}

TEST(EncodeCoefficients, SwitchingQuantizationClearsTheOtherArrays) {
  Field f = makeField({4, Quantization::U8});
  f.quantization = Quantization::F16;
  f.settings.quantization = Quantization::F16;
  ASSERT_TRUE(encodeCoefficients(f, syntheticCoefficients(4)).ok());
  EXPECT_TRUE(f.coefficientsU8.empty() && f.scale.empty() && f.bias.empty());
  EXPECT_TRUE(validateField(f).ok());
}

// The per-texel form (what the bake uses: texels share per-sample data, empty texels read as
// nullptr) encodes the same bytes as the array form of the same coefficients; layers are read
// layerStride floats apart, with padding after each texel's layers that must not be read.
TEST(EncodeCoefficients, PerTexelFormMatchesTheArrayForm) {
  for (Quantization q : {Quantization::U8, Quantization::F16}) {
    Field byArray = makeField({3, q});
    Field byTexel = byArray;
    const uint64_t texels = byArray.texelCount(), values = 3, stride = kLayers * values + 2;
    // Per texel: texel t's layer i at [t * stride + i * values]; the two padding floats are huge,
    // so reading them would break the u8 ranges. Texels that are not samples are all zeros.
    std::vector<float> perTexel(texels * stride, 1e30f);
    std::vector<float> array(kLayers * texels * values, 0.0f);
    const std::vector<float> v = syntheticCoefficients(3);
    for (uint64_t t = 0; t < texels; ++t) {
      if (byArray.texelKinds[t] != kTexelSample) continue;
      for (uint32_t i = 0; i < kLayers; ++i)
        for (uint64_t c = 0; c < values; ++c) {
          // Positive values only, so the empty texels' zeros set each u8 range's lower end.
          const float x = std::fabs(v[(i * texels + t) * values + c]) + 0.125f;
          perTexel[t * stride + i * values + c] = x;
          array[(i * texels + t) * values + c] = x;
        }
    }
    ASSERT_TRUE(encodeCoefficients(byArray, array).ok());
    const Result<void> r = encodeCoefficients(
        byTexel,
        [&](uint64_t t) -> const float* {
          return byTexel.texelKinds[t] == kTexelSample ? perTexel.data() + t * stride : nullptr;
        },
        values);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(byTexel.coefficientsU8, byArray.coefficientsU8);
    EXPECT_EQ(byTexel.coefficientsF16, byArray.coefficientsF16);
    EXPECT_EQ(byTexel.scale, byArray.scale);
    EXPECT_EQ(byTexel.bias, byArray.bias);
    if (q == Quantization::U8) {
      EXPECT_EQ(byTexel.bias[1], 0.0f);  // the empty texels' zeros count
    }
    EXPECT_EQ(serializeField(byTexel), serializeField(byArray));
  }
  // A stride below the values per layer would read the next layer's values: refused.
  Field f = makeField({3, Quantization::U8});
  const std::vector<float> zeros(kLayers * 3, 0.0f);
  const Result<void> r = encodeCoefficients(f, [&](uint64_t) { return zeros.data(); }, 2);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "layer stride 2")) << r.error().message;
}

TEST(FieldEnums, ToString) {
  EXPECT_STREQ(toString(SampleLayout::Split), "split");
  EXPECT_STREQ(toString(SampleLayout::Charts), "charts");
  EXPECT_STREQ(toString(Quantization::U8), "u8");
  EXPECT_STREQ(toString(Quantization::F16), "f16");
  EXPECT_STREQ(toString(SmoothingWindow::None), "none");
  EXPECT_STREQ(toString(SmoothingWindow::Hann), "hann");
  EXPECT_STREQ(toString(SmoothingWindow::Lanczos), "lanczos");
  EXPECT_STREQ(toString(static_cast<Quantization>(9)), "unknown");
}

// ---------------------------------------------------------------------------------------------
// Files.

class FieldFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device random;
    dir_ = fs::temp_directory_path() /
           ("shrefract_field_test_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) +
            "_" + std::to_string(random()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  // Every file in the directory, so a leftover temporary is noticed.
  std::vector<std::string> listing() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
  fs::path dir_;
};

TEST_F(FieldFiles, WriteThenReadRoundTrips) {
  const std::string path = (dir_ / "field.shrf").string();
  for (Variant variant : {Variant{4, Quantization::U8}, Variant{3, Quantization::F16}}) {
    const Field f = makeField(variant);
    const Result<void> w = writeField(path, f);  // the second pass replaces the first file
    ASSERT_TRUE(w.ok()) << w.error().message;
    EXPECT_EQ(listing(), std::vector<std::string>{"field.shrf"});
    EXPECT_EQ(fs::file_size(path), serializeField(f).size());
    const Result<Field> r = readField(path);
    ASSERT_TRUE(r.ok()) << r.error().message;
    expectSameField(f, r.value());
  }
}

TEST_F(FieldFiles, WriteToMissingDirectoryFails) {
  const fs::path missing = dir_ / "no" / "such" / "dir";
  const std::string path = (missing / "field.shrf").string();
  const Result<void> r = writeField(path, makeField({4, Quantization::U8}));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::Io);
  EXPECT_TRUE(contains(r.error().message, path)) << r.error().message;
  EXPECT_FALSE(fs::exists(missing));
  EXPECT_TRUE(listing().empty());
}

TEST_F(FieldFiles, WriteOfInvalidFieldLeavesNoFile) {
  Field f = makeField({4, Quantization::U8});
  f.mesh.indices[0] = 99;
  const std::string path = (dir_ / "bad.shrf").string();
  const Result<void> r = writeField(path, f);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument);
  EXPECT_TRUE(contains(r.error().message, path)) << r.error().message;
  EXPECT_TRUE(listing().empty());
}

TEST_F(FieldFiles, WriteOntoADirectoryFailsAndCleansUp) {
  // The rename cannot replace a non-empty directory: the temporary must not remain.
  const fs::path target = dir_ / "occupied";
  fs::create_directories(target / "child");
  const Result<void> r = writeField(target.string(), makeField({4, Quantization::U8}));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::Io);
  EXPECT_TRUE(contains(r.error().message, target.string())) << r.error().message;
  EXPECT_EQ(listing(), std::vector<std::string>{"occupied"});
}

TEST_F(FieldFiles, ReadOfMissingFileFails) {
  const std::string path = (dir_ / "absent.shrf").string();
  const Result<Field> r = readField(path);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::Io);
  EXPECT_TRUE(contains(r.error().message, path)) << r.error().message;
}

TEST_F(FieldFiles, ReadOfDirectoryFails) {
  const Result<Field> r = readField(dir_.string());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::Io);
  EXPECT_TRUE(contains(r.error().message, dir_.string())) << r.error().message;
}

// An older version read from disk: one line naming the path, and nothing else happens.
TEST_F(FieldFiles, ReadOfAnOlderVersionSaysToBakeAgain) {
  std::vector<uint8_t> bytes = serializeField(makeField({4, Quantization::U8}));
  putU32(bytes, 4, kOldestReadFieldFormatVersion - 1);
  resign(bytes);
  const std::string path = (dir_ / "old.shrf").string();
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
  const Result<Field> r = readField(path);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::Unsupported);
  EXPECT_EQ(r.error().message, path + ": field format version " + std::to_string(kOldestReadFieldFormatVersion - 1) +
                                   " is no longer read; bake the field again with this version of shrefract");
  EXPECT_EQ(listing(), std::vector<std::string>{"old.shrf"});
}

TEST_F(FieldFiles, ReadOfTruncatedFileNamesIt) {
  const std::vector<uint8_t> bytes = serializeField(makeField({4, Quantization::U8}));
  const std::string path = (dir_ / "short.shrf").string();
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size() / 2));
  }
  const Result<Field> r = readField(path);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::CorruptData);
  EXPECT_TRUE(contains(r.error().message, path + ": truncated")) << r.error().message;
}

// ---------------------------------------------------------------------------------------------
// The Table and Pca encodings and the throughput channel.

// makeField's atlas with a Table (N = 3) or Pca (N = 3, K = 5) encoding, optionally with throughput.
// jumpDistance: a 12x12 table (the smallest decoded jump-aware) with the jump distance channel.
// sampleFrameExits: the exits read in each sample's frame.
Field makeEncodedField(Encoding encoding, Quantization q, bool throughput, bool jumpDistance = false,
                       bool sampleFrameExits = false, bool clustered = false) {
  Field f = makeField({4, q});
  f.encoding = f.settings.encoding = encoding;
  f.order = f.settings.order = 0;
  f.tableSize = f.settings.tableSize = jumpDistance ? 12 : 3;
  f.components = f.settings.components = encoding == Encoding::Pca ? 5 : 0;
  f.throughput = f.settings.throughput = throughput;
  f.jumpDistance = f.settings.jumpDistance = jumpDistance;
  f.sampleFrameExits = sampleFrameExits;
  f.settings.exitFrame = sampleFrameExits ? ExitFrame::Sample : ExitFrame::Object;
  f.channels = (throughput ? 5 : 4) + (jumpDistance ? 1 : 0);
  f.settings.pathRule = PathRule::FirstRefraction;
  f.settings.maxBytesPerSample = 324.0f;
  f.settings.directionSampling = DirectionSampling::Nodes;
  if (encoding == Encoding::Pca) {
    f.basis.resize(size_t(f.components) * f.tableSize * f.tableSize * f.channels);
    for (size_t i = 0; i < f.basis.size(); ++i) f.basis[i] = std::sin(0.37f * float(i));
  }
  f.clustered = clustered;
  f.settings.clusters = encoding == Encoding::Pca ? 7 : 0;
  std::vector<float> c(size_t(f.layerCount()) * f.texelCount() * f.valuesPerLayer());
  for (size_t i = 0; i < c.size(); ++i)
    c[i] = !clustered ? std::cos(0.11f * float(i)) * 0.5f + 0.5f
                      : f.texelKinds[i] == kTexelSample ? float(i * 7 % f.components) : 0.0f;  // one index a texel
  const Result<void> encoded = encodeCoefficients(f, c);
  EXPECT_TRUE(encoded.ok()) << encoded.error().message;
  return f;
}

struct EncodedVariant {
  Encoding encoding;
  Quantization quantization;
  bool throughput;
  bool jumpDistance = false;
  bool sampleFrameExits = false;
  bool clustered = false;
};

class FieldEncodings : public ::testing::TestWithParam<EncodedVariant> {
 protected:
  Field field() const {
    return makeEncodedField(GetParam().encoding, GetParam().quantization, GetParam().throughput,
                            GetParam().jumpDistance, GetParam().sampleFrameExits, GetParam().clustered);
  }
};

TEST_P(FieldEncodings, RoundTripIsExact) {
  const Field f = field();
  ASSERT_TRUE(validateField(f).ok()) << validateField(f).error().message;
  const std::vector<uint8_t> bytes = serializeField(f);
  const Result<Field> parsed = parse(bytes, "encoded.shrf");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  const Field& g = parsed.value();
  expectSameField(f, g);
  EXPECT_EQ(g.encoding, f.encoding);
  EXPECT_EQ(g.tableSize, f.tableSize);
  EXPECT_EQ(g.components, f.components);
  EXPECT_EQ(g.throughput, f.throughput);
  EXPECT_EQ(g.jumpDistance, f.jumpDistance);
  EXPECT_EQ(g.settings.jumpDistance, f.jumpDistance);
  EXPECT_EQ(g.sampleFrameExits, f.sampleFrameExits);
  EXPECT_EQ(g.settings.exitFrame, f.settings.exitFrame);
  EXPECT_EQ(g.clustered, f.clustered);
  EXPECT_EQ(g.clusterIndices, f.clusterIndices);
  EXPECT_EQ(g.settings.clusters, f.settings.clusters);
  EXPECT_EQ(g.decodedChannels(), f.channels - (f.jumpDistance ? 1u : 0u));
  EXPECT_EQ(bits(g.basis), bits(f.basis));
  EXPECT_EQ(g.settings.pathRule, PathRule::FirstRefraction);
  EXPECT_EQ(g.settings.directionSampling, DirectionSampling::Nodes);
  EXPECT_EQ(bits(g.settings.maxBytesPerSample), bits(324.0f));
  EXPECT_EQ(serializeField(g), bytes);
}

TEST_P(FieldEncodings, EveryTruncationIsRejected) {
  const std::vector<uint8_t> bytes = serializeField(field());
  for (size_t size = 0; size < bytes.size(); ++size) {
    const std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(size));
    const Result<Field> r = parse(cut, "cut.shrf");
    ASSERT_FALSE(r.ok()) << "a file cut to " << size << " of " << bytes.size() << " bytes was accepted";
  }
}

TEST_P(FieldEncodings, BytesPerSampleCountsTheStoredCoefficients) {
  const Field f = field();
  const uint32_t perValue = GetParam().quantization == Quantization::U8 ? 1 : 2;
  const uint32_t expected = GetParam().encoding == Encoding::Table ? f.tableSize * f.tableSize * f.channels * perValue
                            : GetParam().clustered                ? 2  // the index
                                                                  : 5 * perValue;
  EXPECT_EQ(f.bytesPerSample(), expected);
}

// dequantizeSample holds fieldCoefficient's values in evaluateCoefficients' order, so a sample
// dequantized once decodes at every direction as evaluateSample does, bit for bit (the bake's
// quantization check relies on it).
TEST_P(FieldEncodings, DequantizedOnceDecodesAsEvaluateSample) {
  const Field f = field();
  std::vector<float> a;
  for (uint64_t texel = 0; texel < f.texelCount(); ++texel) {
    if (f.texelKinds[texel] != kTexelSample) continue;
    dequantizeSample(f, texel, a);
    ASSERT_EQ(a.size(), size_t(f.layerCount()) * f.valuesPerLayer());
    for (uint32_t i = 0; i < f.layerCount(); ++i)
      for (uint32_t v = 0; v < f.valuesPerLayer(); ++v)
        ASSERT_EQ(a[size_t(i) * f.valuesPerLayer() + v], fieldCoefficient(f, i, texel, v)) << i << " " << v;
    for (const std::array<float, 3>& w : {std::array<float, 3>{0.3f, -0.2f, 0.93f}, std::array<float, 3>{0.0f, 0.0f, 1.0f},
                                          std::array<float, 3>{-0.7f, 0.7f, 0.1f}}) {
      float once[kMaxFieldChannels] = {}, each[kMaxFieldChannels] = {};
      evaluateCoefficients(f.shape(), a.data(), f.basis.data(), w, once, &f.frames[texel * 12]);
      evaluateSample(f, texel, w, each);
      for (uint32_t c = 0; c < f.decodedChannels(); ++c) EXPECT_EQ(once[c], each[c]) << "texel " << texel << " channel " << c;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Encodings, FieldEncodings,
                         ::testing::Values(EncodedVariant{Encoding::Table, Quantization::U8, false},
                                           EncodedVariant{Encoding::Table, Quantization::F16, true},
                                           EncodedVariant{Encoding::Pca, Quantization::U8, true},
                                           EncodedVariant{Encoding::Pca, Quantization::F16, false},
                                           EncodedVariant{Encoding::Pca, Quantization::U8, false, true},
                                           EncodedVariant{Encoding::Table, Quantization::F16, true, true},
                                           EncodedVariant{Encoding::Pca, Quantization::U8, false, true, true},
                                           EncodedVariant{Encoding::Table, Quantization::U8, true, false, true},
                                           EncodedVariant{Encoding::Pca, Quantization::U8, false, true, true, true},
                                           EncodedVariant{Encoding::Pca, Quantization::F16, true, false, false, true}),
                         [](const ::testing::TestParamInfo<EncodedVariant>& p) {
                           return std::string(toString(p.param.encoding)) + "_" + toString(p.param.quantization) +
                                  (p.param.throughput ? "_throughput" : "") +
                                  (p.param.jumpDistance ? "_jump_distance" : "") +
                                  (p.param.sampleFrameExits ? "_sample_frame" : "") +
                                  (p.param.clustered ? "_clustered" : "");
                         });

// ---------------------------------------------------------------------------------------------
// The Volume encoding (a grid at the end of ENCD, no coefficients).

// makeField's atlas as a Volume field over an 8^3 grid of varied distance levels and normals.
// A 12^3 grid, 2^3 bricks of which the last ones lie partly beyond it: voxels with x >= 8 beyond
// the band outside, those with y >= 8 (and x < 8) beyond it inside, the others varied; its bricks
// (1, *, *) are entries outside, (0, 1, *) inside, and (0, 0, 0) and (0, 0, 1) stored.
constexpr uint32_t kVolumeFieldSize = 12;
std::vector<uint32_t> volumeFieldVoxels() {
  const uint32_t n = kVolumeFieldSize;
  std::vector<uint32_t> dense;
  for (uint32_t i = 0; i < n * n * n; ++i) {
    const uint32_t x = i % n, y = (i / n) % n;
    dense.push_back(x >= 8   ? volumeFarWord(false)
                    : y >= 8 ? volumeFarWord(true)
                             : packVolumeVoxel(4.0f * std::sin(0.7f * float(i)),
                                               {std::cos(0.3f * float(i)), std::sin(0.3f * float(i)), 0.5f}));
  }
  return dense;
}

Field makeVolumeField(Quantization q, bool throughput) {
  Field f = makeField({4, q});
  f.encoding = f.settings.encoding = Encoding::Volume;
  f.order = f.settings.order = 0;
  f.throughput = f.settings.throughput = throughput;
  f.channels = throughput ? 5 : 4;
  f.coefficientsU8.clear();
  f.coefficientsF16.clear();
  f.scale.clear();
  f.bias.clear();
  f.settings.pathRule = PathRule::FirstRefraction;
  f.settings.tryVolume = q == Quantization::F16;  // chosen by a default bake, or asked for
  FieldVolume& v = f.volume;
  v.size = f.settings.volumeSize = kVolumeFieldSize;
  v.origin = {-1.25f, -0.5f, 0.75f};
  v.spacing = 0.375f;
  setVolumeVoxels(v, volumeFieldVoxels());
  return f;
}

TEST(FieldVolume, RoundTripIsExactAndEveryTruncationIsRejected) {
  for (Quantization q : {Quantization::U8, Quantization::F16})
    for (bool throughput : {false, true}) {
      const Field f = makeVolumeField(q, throughput);
      ASSERT_TRUE(validateField(f).ok()) << validateField(f).error().message;
      EXPECT_EQ(f.bytesPerSample(), 0u);
      const std::vector<uint8_t> bytes = serializeField(f);
      const Result<Field> parsed = parse(bytes, "volume.shrf");
      ASSERT_TRUE(parsed.ok()) << parsed.error().message;
      const Field& g = parsed.value();
      expectSameField(f, g);
      EXPECT_EQ(g.encoding, Encoding::Volume);
      EXPECT_EQ(g.volume.size, kVolumeFieldSize);
      EXPECT_EQ(g.settings.volumeSize, kVolumeFieldSize);
      EXPECT_EQ(g.settings.tryVolume, f.settings.tryVolume);
      EXPECT_EQ(bits(std::vector<float>(g.volume.origin.begin(), g.volume.origin.end())),
                bits(std::vector<float>(f.volume.origin.begin(), f.volume.origin.end())));
      EXPECT_EQ(bits(std::vector<float>{g.volume.spacing}), bits(std::vector<float>{f.volume.spacing}));
      EXPECT_EQ(g.volume.bricks, f.volume.bricks);
      EXPECT_EQ(g.volume.brickVoxels, f.volume.brickVoxels);
      EXPECT_EQ(serializeField(g), bytes);
      for (size_t size = 0; size < bytes.size(); ++size) {
        const std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(size));
        ASSERT_FALSE(parse(cut, "cut.shrf").ok()) << "a volume file cut to " << size << " of " << bytes.size()
                                                  << " bytes was accepted";
      }
    }
}

// setVolumeVoxels keeps every voxel: a brick wholly of one far word becomes its entry (partial
// bricks too, their voxels beyond the grid ignored), every other brick is stored in brick order.
TEST(FieldVolume, BricksReadBackEveryVoxel) {
  const std::vector<uint32_t> dense = volumeFieldVoxels();
  FieldVolume v;
  v.size = kVolumeFieldSize;
  setVolumeVoxels(v, dense);
  const uint32_t in = kVolumeBrickInside, out = kVolumeBrickOutside;
  EXPECT_EQ(v.bricks, (std::vector<uint32_t>{0, out, in, out, 1, out, in, out}));
  EXPECT_EQ(v.brickVoxels.size(), 2 * size_t(kVolumeBrickWords));
  const uint32_t n = kVolumeFieldSize;
  size_t wrong = 0;
  for (uint32_t z = 0; z < n; ++z)
    for (uint32_t y = 0; y < n; ++y)
      for (uint32_t x = 0; x < n; ++x) wrong += volumeVoxel(v, x, y, z) != dense[(size_t(z) * n + y) * n + x];
  EXPECT_EQ(wrong, 0u);
  EXPECT_EQ(volumeGridBytes(v), 4 * (8 + 2 * uint64_t(kVolumeBrickWords)));
  // One varied voxel keeps its brick: the far outside brick (1, 0, 0) is stored once it differs.
  std::vector<uint32_t> touched = dense;
  touched[(size_t(3) * n + 2) * n + 9] = packVolumeVoxel(3.5f, {0.0f, 0.0f, 1.0f});
  setVolumeVoxels(v, touched);
  EXPECT_EQ(v.bricks[1], 1u);
  EXPECT_EQ(v.brickVoxels.size(), 3 * size_t(kVolumeBrickWords));
  EXPECT_EQ(volumeVoxel(v, 9, 2, 3), touched[(size_t(3) * n + 2) * n + 9]);
}

// What the trace reads is bounded: a grid of the right size, within the band, finite and
// not degenerate, two media, a bounded bounce cap; and only a Volume field has a grid.
TEST(FieldVolume, BrokenVolumesAreRejected) {
  const std::vector<std::pair<std::string, std::function<void(Field&)>>> cases = {
      {"volume size 4", [](Field& f) { f.volume.size = f.settings.volumeSize = 4; }},
      {"volume has 7 bricks, expected 2^3", [](Field& f) { f.volume.bricks.pop_back(); }},
      {"not a whole number of 512-voxel bricks", [](Field& f) { f.volume.brickVoxels.pop_back(); }},
      {"brick 0 refers to stored brick 2 of 2", [](Field& f) { f.volume.bricks[0] = 2; }},
      {"distance level 255", [](Field& f) { f.volume.brickVoxels[7] |= 0xffu; }},
      {"volume spacing", [](Field& f) { f.volume.spacing = 0.0f; }},
      {"volume spacing", [](Field& f) { f.volume.spacing = std::numeric_limits<float>::quiet_NaN(); }},
      {"volume spacing", [](Field& f) { f.volume.spacing = 1e-30f; }},
      {"volume origin", [](Field& f) { f.volume.origin[1] = std::numeric_limits<float>::infinity(); }},
      {"3 media", [](Field& f) { f.media.push_back(f.media[1]); }},
      {"maxBounces 2000", [](Field& f) { f.settings.maxBounces = 2000; }},
      {"settings.volumeSize 16", [](Field& f) { f.settings.volumeSize = 16; }},
      {"a volume field has", [](Field& f) { f.tableSize = f.settings.tableSize = 3; }},
  };
  // Only a Pca bake tries the volume: an SH field that says it did is refused.
  Field tried = makeField({4, Quantization::U8});
  tried.settings.tryVolume = true;
  ASSERT_FALSE(validateField(tried).ok());
  EXPECT_TRUE(contains(validateField(tried).error().message, "tryVolume")) << validateField(tried).error().message;
  for (const auto& [what, breakIt] : cases) {
    Field f = makeVolumeField(Quantization::U8, false);
    breakIt(f);
    const Result<void> r = validateField(f);
    ASSERT_FALSE(r.ok()) << what;
    EXPECT_TRUE(contains(r.error().message, what)) << what << ": " << r.error().message;
  }
  Field sh = makeField({4, Quantization::U8});
  sh.volume = makeVolumeField(Quantization::U8, false).volume;
  const Result<void> r = validateField(sh);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "has a volume grid")) << r.error().message;
}

TEST(FieldClustered, BrokenIndicesAreRejected) {
  const auto emptyTexel = [](const Field& f) {
    return uint64_t(std::find(f.texelKinds.begin(), f.texelKinds.end(), kTexelEmpty) - f.texelKinds.begin());
  };
  const std::vector<std::pair<std::string, std::function<void(Field&)>>> cases = {
      {"is not below the 5 components", [](Field& f) { f.clusterIndices[0] = 5; }},
      {"the texel holds no sample", [&](Field& f) { f.clusterIndices[emptyTexel(f)] = 1; }},
      {"cluster indices has", [](Field& f) { f.clusterIndices.pop_back(); }},
      {"quantized coefficients", [](Field& f) { f.coefficientsU8.assign(f.texelCount(), 0); }},
      {"not a pca field", [](Field& f) {
         f.encoding = f.settings.encoding = Encoding::Table;
         f.components = f.settings.components = 0;
         f.basis.clear();
       }},
      {"not clustered", [](Field& f) { f.clustered = false; }},  // the indices left behind
      {"settings.clusters", [](Field& f) { f.settings.clusters = kMaxClusters + 1; }},
      {"not a binary16 value", [](Field& f) { f.basis[3] = 0.1f; }},  // the tables are stored as binary16
      {"(clustered)", [](Field& f) {  // more tables than an index may name
         f.components = f.settings.components = kMaxClusters + 1;
         f.basis.resize(size_t(f.components) * f.tableSize * f.tableSize * f.channels);
       }},
  };
  for (const auto& [what, breakIt] : cases) {
    Field f = makeEncodedField(Encoding::Pca, Quantization::U8, false, false, false, true);
    ASSERT_TRUE(validateField(f).ok()) << validateField(f).error().message;
    ASSERT_LT(emptyTexel(f), f.texelCount());
    breakIt(f);
    const Result<void> r = validateField(f);
    ASSERT_FALSE(r.ok()) << what;
    EXPECT_TRUE(contains(r.error().message, what)) << what << ": " << r.error().message;
  }
  // Only whole indices below the components encode.
  for (float bad : {0.5f, 5.0f, -1.0f, std::numeric_limits<float>::quiet_NaN()}) {
    Field f = makeEncodedField(Encoding::Pca, Quantization::U8, false, false, false, true);
    std::vector<float> c(f.texelCount(), 0.0f);
    c[0] = bad;
    const Result<void> r = encodeCoefficients(f, c);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_TRUE(contains(r.error().message, "encodeCoefficients: ")) << r.error().message;
  }
}

TEST(FieldEncodingValidation, BrokenEncodingsAreRejected) {
  const std::vector<std::pair<std::string, std::function<void(Field&)>>> cases = {
      {"table size", [](Field& f) { f.tableSize = f.settings.tableSize = 1; }},
      {"components", [](Field& f) { f.components = f.settings.components = 0; }},
      {"basis", [](Field& f) { f.basis.pop_back(); }},
      {"basis", [](Field& f) { f.basis[3] = std::numeric_limits<float>::quiet_NaN(); }},
      {"basis", [](Field& f) { f.basis[3] = 1e30f; }},
      {"channels", [](Field& f) { f.throughput = f.settings.throughput = false; }},  // 5 channels, no throughput
      {"settings", [](Field& f) { f.settings.encoding = Encoding::Table; }},
      {"SH order", [](Field& f) { f.order = f.settings.order = 2; }},
      {"path rule", [](Field& f) { f.settings.pathRule = static_cast<PathRule>(7); }},
      {"directionSampling", [](Field& f) { f.settings.directionSampling = static_cast<DirectionSampling>(2); }},
      {"encoding", [](Field& f) { f.encoding = f.settings.encoding = static_cast<Encoding>(9); }},
  };
  for (const auto& [what, breakIt] : cases) {
    Field f = makeEncodedField(Encoding::Pca, Quantization::U8, true);
    breakIt(f);
    const Result<void> r = validateField(f);
    ASSERT_FALSE(r.ok()) << what;
    EXPECT_TRUE(contains(r.error().message, what)) << what << ": " << r.error().message;
  }
  // SH is fitted to a grid: an SH field cannot claim its directions were table nodes.
  Field sh = makeField({4, Quantization::U8});
  sh.settings.directionSampling = DirectionSampling::Nodes;
  const Result<void> r = validateField(sh);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "directionSampling")) << r.error().message;
}

// The file without the last `bytes` of ENCD, labelled `version`.
std::vector<uint8_t> withShorterEncoding(const Field& f, uint64_t bytes, uint32_t version) {
  std::vector<uint8_t> b = serializeField(f);
  const size_t encd = sectionPayload(b, "ENCD");
  const uint64_t encdLength = getU64(b, encd - 8);
  b.erase(b.begin() + static_cast<std::ptrdiff_t>(encd + encdLength - bytes),
          b.begin() + static_cast<std::ptrdiff_t>(encd + encdLength));
  putU64(b, encd - 8, encdLength - bytes);
  putU32(b, 4, version);
  putU64(b, 8, b.size());
  resign(b);
  return b;
}

// What version 6 appends to ENCD for a field that is not clustered: the flag, an empty array of
// indices, the clusters asked for and an empty array of binary16 tables.
constexpr uint64_t kClusteredBytes = 4 + 8 + 4 + 8;
// What version 7 appends after them: how an SH field was fitted.
constexpr uint64_t kShFitBytes = 4;
// What version 8 appends after it for a field that is not a Volume field: the grid's size, origin
// and spacing, an empty array of voxels, the size asked for and whether the volume was tried; and
// what version 9 appends after them: empty arrays of bricks and of their voxels.
constexpr uint64_t kVolumeV8Bytes = 4 + 12 + 4 + 8 + 4 + 4;
constexpr uint64_t kBrickBytes = 8 + 8;
constexpr uint64_t kVolumeBytes = kVolumeV8Bytes + kBrickBytes;

// A clustered field's tables are binary16 at the end of ENCD and its f32 basis is empty; a file
// that says clustered beside an f32 basis is refused, and so is a non-clustered one's flag set.
TEST(FieldClustered, TablesAreBinary16AtTheEndOfTheEncoding) {
  const Field clustered = makeEncodedField(Encoding::Pca, Quantization::U8, false, false, false, true);
  const Field weights = makeEncodedField(Encoding::Pca, Quantization::U8, false);
  const std::vector<uint8_t> a = serializeField(clustered), b = serializeField(weights);
  // The same basis size: 4 bytes a value as weights' f32, 2 as binary16.
  ASSERT_EQ(clustered.basis.size(), weights.basis.size());
  const size_t encdA = sectionPayload(a, "ENCD"), encdB = sectionPayload(b, "ENCD");
  EXPECT_EQ(getU64(a, encdA - 8) + 2 * clustered.basis.size(),
            getU64(b, encdB - 8) + 2 * clustered.texelCount());  // a's indices, b's wider basis
  std::vector<uint8_t> flagged = b;
  const size_t flag = encdB + getU64(b, encdB - 8) - kClusteredBytes - kShFitBytes - kVolumeBytes;  // version 6's first value
  ASSERT_EQ(getU32(flagged, flag), 0u);
  putU32(flagged, flag, 1);
  resign(flagged);
  const Result<Field> r = parse(flagged, "flagged.shrf");
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "has an f32 basis")) << r.error().message;
}

TEST(FieldJumpDistance, OnlyWhereTheDecodeIsJumpAware) {
  const std::vector<std::pair<std::string, std::function<void(Field&)>>> cases = {
      {"jump distance", [](Field& f) { f.settings.directionSampling = DirectionSampling::Grid; }},
      {"jump distance", [](Field& f) {
         f.tableSize = f.settings.tableSize = 11;
         f.basis.resize(size_t(f.components) * 11 * 11 * f.channels);
       }},
      {"channels", [](Field& f) { f.channels = 6; }},  // 5 decoded without throughput
  };
  for (const auto& [what, breakIt] : cases) {
    Field f = makeEncodedField(Encoding::Pca, Quantization::F16, false, true);
    ASSERT_TRUE(validateField(f).ok()) << validateField(f).error().message;
    breakIt(f);
    const Result<void> r = validateField(f);
    ASSERT_FALSE(r.ok()) << what;
    EXPECT_TRUE(contains(r.error().message, what)) << what << ": " << r.error().message;
  }
  // The flag set on a field without the channel takes the exit's z as a distance: the absorbing
  // media then have no optical depth to read.
  Field f = makeEncodedField(Encoding::Pca, Quantization::F16, false);
  f.tableSize = f.settings.tableSize = 12;
  f.basis.resize(size_t(f.components) * 12 * 12 * f.channels);
  f.jumpDistance = true;
  const Result<void> r = validateField(f);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error().message, "no optical depth")) << r.error().message;
}

// A file of another layout than this version's: the dense voxel words (`dense`) that ENCD's array
// before the settings never holds in this version, the grid in bricks after them as usual.
std::vector<uint8_t> withDenseVoxels(const Field& f, const std::vector<uint32_t>& dense) {
  std::vector<uint8_t> b = serializeField(f);
  const size_t encd = sectionPayload(b, "ENCD");
  const uint64_t length = getU64(b, encd - 8);
  const uint64_t bricks = 8 + 4 * (f.volume.bricks.size() + f.volume.brickVoxels.size()) + 8;
  const size_t denseAt = size_t(encd + length - bricks - 4 - 4 - 8);  // its count, then the two u32
  EXPECT_EQ(getU64(b, denseAt), 0u);
  std::vector<uint8_t> words(4 * dense.size());
  for (size_t i = 0; i < dense.size(); ++i)
    for (size_t k = 0; k < 4; ++k) words[4 * i + k] = uint8_t(dense[i] >> (8 * k));
  putU64(b, denseAt, dense.size());
  b.insert(b.begin() + static_cast<std::ptrdiff_t>(denseAt + 8), words.begin(), words.end());
  putU64(b, encd - 8, length + words.size());
  putU64(b, 8, b.size());
  resign(b);
  return b;
}

// The grid is stored in bricks only: dense voxels in this version's file are refused.
TEST(FieldVolume, DenseVoxelsAreRefused) {
  const Field f = makeVolumeField(Quantization::U8, false);
  const Result<Field> r = parse(withDenseVoxels(f, volumeFieldVoxels()), "dense.shrf");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::CorruptData);
  EXPECT_TRUE(contains(r.error().message, "dense.shrf: volume has 1728 dense voxels")) << r.error().message;
}

// The line every refused version gets: the file, the version, and what to do about it.
std::string refusal(const std::string& name, uint32_t version) {
  return name + ": field format version " + std::to_string(version) +
         " is no longer read; bake the field again with this version of shrefract";
}

// Versions before kOldestReadFieldFormatVersion are refused whole, as Unsupported, with one line,
// before any of the file is interpreted: the same bytes read as this version's file when labelled
// so, and every older label gets the refusal line.
TEST(FieldFormatVersion, OlderVersionsAreRefusedWithOneLine) {
  const std::vector<Field> fields = {makeField({4, Quantization::U8}), makeEncodedField(Encoding::Pca, Quantization::F16, true),
                                     makeVolumeField(Quantization::U8, false)};
  for (const Field& f : fields)
    for (uint32_t version = 1; version < kOldestReadFieldFormatVersion; ++version) {
      std::vector<uint8_t> b = serializeField(f);
      putU32(b, 4, version);
      resign(b);
      const Result<Field> r = parse(b, "old.shrf");
      ASSERT_FALSE(r.ok()) << "version " << version;
      EXPECT_EQ(r.error().code, ErrorCode::Unsupported) << "version " << version;
      EXPECT_EQ(r.error().message, refusal("old.shrf", version));
    }
}

// Files of the older layouts themselves (ENCD shorter by what later versions appended, a version 1
// file without ENCD) get the same line: the layout is never looked at.
TEST(FieldFormatVersion, OlderLayoutsAreRefusedWithOneLine) {
  const Field sh = makeField({4, Quantization::U8});
  const std::vector<std::pair<uint32_t, uint64_t>> shorter = {
      {8, kBrickBytes}, {7, kVolumeBytes}, {6, kShFitBytes + kVolumeBytes},
      {5, kClusteredBytes + kShFitBytes + kVolumeBytes}, {4, 4 + kClusteredBytes + kShFitBytes + kVolumeBytes},
      {3, 8 + kClusteredBytes + kShFitBytes + kVolumeBytes}, {2, 12 + kClusteredBytes + kShFitBytes + kVolumeBytes}};
  for (const auto& [version, bytes] : shorter) {
    const Result<Field> r = parse(withShorterEncoding(sh, bytes, version), "old.shrf");
    ASSERT_FALSE(r.ok()) << "version " << version;
    EXPECT_EQ(r.error().message, refusal("old.shrf", version));
  }
  std::vector<uint8_t> v1 = serializeField(sh);
  const size_t encd = sectionPayload(v1, "ENCD") - 12;
  v1.erase(v1.begin() + static_cast<std::ptrdiff_t>(encd), v1.end() - 4);
  putU32(v1, 4, 1);
  putU32(v1, 36, 6);
  putU64(v1, 8, v1.size());
  resign(v1);
  const Result<Field> r = parse(v1, "v1.shrf");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::Unsupported);
  EXPECT_EQ(r.error().message, refusal("v1.shrf", 1));
}

// The hemi-octahedral map: nodes map back to their grid positions, the border is the horizon, and
// evaluateSample at a node direction returns that node's value exactly (bilinear weight 1).
TEST(HemiOctahedral, NodesRoundTripAndTheBorderIsTheHorizon) {
  const uint32_t n = 9;
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      const std::array<float, 3> w = hemiOctDirection(i, j, n);
      EXPECT_NEAR(std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]), 1.0f, 1e-6f);
      EXPECT_GE(w[2], 0.0f);
      if (i == 0 || j == 0 || i == n - 1 || j == n - 1) {
        EXPECT_NEAR(w[2], 0.0f, 1e-6f);
      }
      const HemiOctCoordinates uv = hemiOctFromDirection(w[0], w[1], w[2]);
      EXPECT_NEAR(uv.u, float(i) / float(n - 1), 1e-6f);
      EXPECT_NEAR(uv.v, float(j) / float(n - 1), 1e-6f);
    }
  const std::array<float, 3> pole = hemiOctDirection(4, 4, 9);
  EXPECT_NEAR(pole[2], 1.0f, 1e-6f);
}

TEST(HemiOctahedral, EvaluateSampleReturnsNodeValuesAtNodes) {
  for (Encoding e : {Encoding::Table, Encoding::Pca}) {
    const Field f = makeEncodedField(e, Quantization::U8, false);
    const uint64_t texel = 3;
    for (uint32_t j = 0; j < 3; ++j)
      for (uint32_t i = 0; i < 3; ++i) {
        const uint32_t node = j * 3 + i;
        float out[4];
        evaluateSample(f, texel, hemiOctDirection(i, j, 3), out);
        for (uint32_t c = 0; c < 4; ++c) {
          float expected = 0.0f;
          if (e == Encoding::Table) expected = fieldCoefficient(f, node, texel, c);
          else
            for (uint32_t k = 0; k < f.components; ++k)
              expected += fieldCoefficient(f, k, texel, 0) * f.basis[(k * 9 + node) * 4 + c];
          EXPECT_NEAR(out[c], expected, 1e-5f) << toString(e) << " node " << node << " channel " << c;
        }
      }
  }
}

// A node-sampled table of exits that are a linear map of the direction (a slab's straight-through
// exit -w, and a rotation of it) decodes to the exit at w itself inside a quadrant's cells: the
// exits blend by b_j |o_j| (field_decode.cpp interpolateCorners). Plain bilinear weights, which a
// least-squares table keeps, err there by up to 0.09 deg at N = 32.
TEST(HemiOctahedral, NodeSampledLinearExitsDecodeExactlyInsideQuadrants) {
  const uint32_t n = 32;
  const float c = std::cos(0.4f), s = std::sin(0.4f);  // a rotation about x
  const auto exitOf = [&](const std::array<float, 3>& w, bool rotated) {
    const std::array<float, 3> e{-w[0], -w[1], -w[2]};
    return rotated ? std::array<float, 3>{e[0], c * e[1] - s * e[2], s * e[1] + c * e[2]} : e;
  };
  for (bool rotated : {false, true}) {
    std::vector<float> table(size_t(n) * n * 3);
    for (uint32_t node = 0; node < n * n; ++node) {
      const std::array<float, 3> e = exitOf(hemiOctDirection(node % n, node / n, n), rotated);
      std::copy(e.begin(), e.end(), table.begin() + node * 3);
    }
    EncodingShape shape;
    shape.encoding = Encoding::Table;
    shape.tableSize = n;
    shape.channels = 3;
    shape.sampleFrameExits = true;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    float worstNodes = 0.0f, worstBilinear = 0.0f;
    for (int i = 0; i < 20000; ++i) {
      std::array<float, 3> w{uniform(rng), uniform(rng), std::fabs(uniform(rng))};
      const float len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
      if (!(len > 0.1f) || w[2] / len < 0.05f) continue;
      for (float& x : w) x /= len;
      // Cells that a quadrant boundary (x = 0 or y = 0, the grid's diagonals) crosses are not linear.
      const HemiOctCoordinates uv = hemiOctFromDirection(w[0], w[1], w[2]);
      const uint32_t ci = std::min(uint32_t(uv.u * float(n - 1)), n - 2), cj = std::min(uint32_t(uv.v * float(n - 1)), n - 2);
      if (ci == cj || ci + cj + 2 == n) continue;
      const std::array<float, 3> exact = exitOf(w, rotated);
      for (bool nodeSampled : {true, false}) {
        shape.jumpAware = nodeSampled;
        float out[3];
        evaluateCoefficients(shape, table.data(), nullptr, w, out);
        // atan2 of the cross product's length and the dot: acos near 1 resolves only ~0.02 deg.
        const float cx = out[1] * exact[2] - out[2] * exact[1], cy = out[2] * exact[0] - out[0] * exact[2],
                    cz = out[0] * exact[1] - out[1] * exact[0];
        const float degrees = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz),
                                         out[0] * exact[0] + out[1] * exact[1] + out[2] * exact[2]) * 57.29578f;
        float& worst = nodeSampled ? worstNodes : worstBilinear;
        worst = std::max(worst, degrees);
      }
    }
    // Measured: 3e-5 deg (float rounding) against 0.087 for plain bilinear weights.
    EXPECT_LT(worstNodes, 1e-3f) << "rotated " << rotated;
    EXPECT_GT(worstBilinear, 0.05f) << "rotated " << rotated;
  }
}

// A cell that a jump crosses, three corners on the eye's side: the side's exits are the
// straight-through exit (-w in the sample's frame) tilted by a term linear across the grid, as a
// prism's side face bends them, so its estimate at w is the plane through its three corners
// (field_decode.cpp sideCoefficients), exact to rounding; their blend moved by the
// straight-through correction alone errs by a degree there.
TEST(HemiOctahedral, JumpCellSideExtrapolatesItsOwnCorners) {
  const uint32_t n = 16;  // jump-aware (>= gpu::kJumpMinTableSize)
  const float jump = 16.5f;  // the jump: grid coordinates with i + j = 16.5
  const auto sideA = [n](float i, float j) {
    const std::array<float, 3> w = hemiOctDirectionAt(i, j, n);
    return std::array<float, 3>{-w[0] - 0.3f + 0.08f * i, -w[1] + 0.1f + 0.06f * j, -w[2]};
  };
  std::vector<float> table(size_t(n) * n * 4);
  for (uint32_t node = 0; node < n * n; ++node) {
    const float i = float(node % n), j = float(node / n);
    const std::array<float, 3> e = i + j < jump ? sideA(i, j) : std::array<float, 3>{0.8f, 0.0f, -0.6f};
    const float cells = std::min(std::fabs(i + j - jump) / std::sqrt(2.0f), 1.0f);  // to the jump
    std::copy(e.begin(), e.end(), table.begin() + node * 4);
    table[node * 4 + 3] = cells * 3.14159265f / float(n - 1);  // the channel's scale (gpu_layout.h)
  }
  EncodingShape shape;
  shape.encoding = Encoding::Table;
  shape.tableSize = n;
  shape.channels = 4;
  shape.jumpAware = shape.jumpDistance = shape.sampleFrameExits = true;
  // Cell (7, 8): corners (7, 8), (8, 8), (7, 9) on side A, (8, 9) beyond the jump with bilinear
  // weight >= 1 / gpu::kJumpBlendGain, so that the jump-aware estimate replaces the bilinear blend.
  float worst = 0.0f;
  for (const auto& [gi, gj] : {std::pair{7.4f, 8.3f}, std::pair{7.2f, 8.6f}, std::pair{7.7f, 8.1f}, std::pair{7.5f, 8.5f}}) {
    float out[3];
    evaluateCoefficients(shape, table.data(), nullptr, hemiOctDirectionAt(gi, gj, n), out);
    const std::array<float, 3> exact = sideA(gi, gj);
    const float cx = out[1] * exact[2] - out[2] * exact[1], cy = out[2] * exact[0] - out[0] * exact[2],
                cz = out[0] * exact[1] - out[1] * exact[0];
    const float degrees = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz),
                                     out[0] * exact[0] + out[1] * exact[1] + out[2] * exact[2]) * 57.29578f;
    worst = std::max(worst, degrees);
  }
  // Measured: 0.0075 deg (the slopes' ridge); the blend of the side's corners moved by the
  // straight-through correction (the decode before the plane fit): 0.69 deg.
  EXPECT_LT(worst, 0.05f);
}

// Extreme but valid: weights at the coefficient bound and direction basis values at theirs decode
// to finite sums whose squared length is finite too (the bound of validateField).
TEST(FieldEncodingValidation, ExtremePcaFieldDecodesFinite) {
  Field f = makeEncodedField(Encoding::Pca, Quantization::U8, false);
  for (size_t i = 0; i < f.basis.size(); ++i) f.basis[i] = i % f.channels < 3 ? 8.0f : 1e6f;
  std::vector<float> w(size_t(f.components) * f.texelCount(), 1e15f);
  ASSERT_TRUE(encodeCoefficients(f, w).ok());
  ASSERT_TRUE(validateField(f).ok()) << validateField(f).error().message;
  float out[4];
  evaluateSample(f, 3, {0.3f, -0.2f, 0.9f}, out);
  const float len2 = out[0] * out[0] + out[1] * out[1] + out[2] * out[2];
  EXPECT_TRUE(std::isfinite(len2)) << len2;
  for (float v : out) EXPECT_TRUE(std::isfinite(v));
  f.basis[0] = 8.5f;  // just past the bound
  EXPECT_FALSE(validateField(f).ok());
}

}  // namespace
}  // namespace shrefract
