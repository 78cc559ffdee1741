// Structural validation (docs/field-format.md, "Validation"): each case breaks one rule of a valid
// field, which validateField and parseField then refuse, naming the rule.
#include <shrefract/field.h>
#include <shrefract/field_decode.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <utility>
#include <string>
#include <vector>

#include "field/field_test_support.h"

namespace shrefract {
namespace {

using namespace fieldtest;

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
