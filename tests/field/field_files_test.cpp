// Field files on disk: writeField replaces a file only once it is whole and leaves nothing on
// failure; readField names the path in every error.
#include <shrefract/field.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "field/field_test_support.h"

namespace shrefract {
namespace {

using namespace fieldtest;

namespace fs = std::filesystem;

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

}  // namespace
}  // namespace shrefract
