// The .shrf bytes (docs/field-format.md): exact round trips, a header and sections as the spec lays
// them out, rejection of every truncation, of corrupted bytes and of hostile lengths.
#include <shrefract/field.h>

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "field/field_test_support.h"

namespace shrefract {
namespace {

using namespace fieldtest;

TEST(FieldFormatChecksum, ReferenceCrcMatchesTheCheckValue) {
  const std::string check = "123456789";
  EXPECT_EQ(referenceCrc32(reinterpret_cast<const uint8_t*>(check.data()), check.size()), 0xCBF43926u);
}

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

}  // namespace
}  // namespace shrefract
