// The format's versions (docs/field-format.md, "Versioning"): a newer version and every version
// before kOldestReadFieldFormatVersion are refused as Unsupported, with one line naming the file.
#include <shrefract/field.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "field/field_test_support.h"

namespace shrefract {
namespace {

using namespace fieldtest;

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

}  // namespace
}  // namespace shrefract
