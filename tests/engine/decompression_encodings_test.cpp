// The decompression of the Table and Pca encodings (decompress_table.comp) and of fields with a
// throughput channel (both shaders) against the CPU reference (shrefract/cpu_reference.h, which
// decodes through field.h's evaluateSample): synthetic fields in both quantizations and every
// channel layout (3: x, y, z; 4: and tau; 4: x, y, z and throughput; 5: all), with empty texels
// and split-layout gutter rules, decompressed on the GPU for several eyes and read back. Also the
// storage-buffer read path of the coefficients (white box, as tests/perf/decompress_paths_test.cpp).
#include <gtest/gtest.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/decompressor.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "engine/distortion_check.h"
#include "engine/synthetic_field.h"
#include "object/object_impl.h"

namespace shrefract {
namespace {

using testing::SyntheticFieldOptions;

// Tolerances, as for SH (tests/engine/decompression_test.cpp). Both sides pick the hemi-octahedral
// cell and weights in the same float operations (the GPU's division by |x| + |y| + z may differ by
// 2.5 ulp, moving a weight by ~1e-7; where that moves the point across a cell border the other cell
// gives the same value, bilinear interpolation being continuous) and sum the same dequantized
// values (U8: bias + scale * q / 255 on both sides) in the same order: 4 terms (Table) or 4 K
// terms (Pca) of magnitude ~3, so the sums differ by ~1e-6. Both results are then stored as
// binary16, whose half-ulp (2.4e-4 below 1) the two sides can straddle: one ulp, 4.9e-4, plus
// float noise. A throughput only scales the unit direction down. Gutter texels are a + b - c of
// three stored values, rounded once more: 3 x 1e-3 plus one ulp of the result.
constexpr testing::DistortionTolerance kTolerance{/*direction=*/1e-3f, /*tauRelative=*/1e-3f, /*gutter=*/3e-3f};
// The jump image (R32F, no rounding): the eye's distance in cells, from the corners' distances and
// the sides' cosines, continuous in both, summed in the same order: float noise, ~1e-6.
constexpr float kJumpTolerance = 1e-4f;
// The Volume trace: both sides march and bisect in the same float operations, so a crossing moves
// only by the float noise of the trilinear weights; but its optical depth is a path length of tens
// of voxels times the absorption, stored as binary16 (one ulp is 2e-3 at 2 to 4), and the gutter
// rules add and subtract three such values.
constexpr testing::DistortionTolerance kVolumeTolerance{/*direction=*/1e-3f, /*tauRelative=*/1e-3f, /*gutter=*/3e-2f};

struct ChannelLayout {
  uint32_t channels;
  bool throughput;
};
constexpr ChannelLayout kLayouts[] = {{3, false}, {4, false}, {4, true}, {5, true}};

// Eyes: above the band, to the side, grazing, and below most samples' tangent planes (horizon clamp).
constexpr std::array<std::array<float, 3>, 4> kEyes{
    {{0.3f, 0.8f, 3.0f}, {-2.5f, -0.4f, 1.0f}, {0.0f, 0.05f, 1.2f}, {0.2f, -3.0f, 0.1f}}};

std::string describe(const SyntheticFieldOptions& o) {
  std::string s = std::string(toString(o.encoding)) + " " + toString(o.quantization) + " channels " +
                  std::to_string(o.channels) + (o.throughput ? " (throughput)" : "");
  if (o.sampleFrameExits) s += " sample frame";
  if (o.encoding == Encoding::Sh) return s + " order " + std::to_string(o.order);
  if (o.encoding == Encoding::Volume) return s + " " + std::to_string(o.volumeSize) + "^3 ior " + std::to_string(o.frontIor);
  s += " N " + std::to_string(o.tableSize) + (o.jumpDistance ? " jump distance" : "");
  return o.encoding == Encoding::Pca ? s + " K " + std::to_string(o.components) + (o.clustered ? " clustered" : "") : s;
}

// Lengths of the xyz of the sample texels, sorted: with a throughput they spread below 1.
std::vector<float> sampleLengths(const Field& field, const std::vector<float>& image) {
  std::vector<float> lengths;
  for (uint64_t t = 0; t < field.texelCount(); ++t)
    if (field.texelKinds[t] == kTexelSample)
      lengths.push_back(std::sqrt(image[t * 4] * image[t * 4] + image[t * 4 + 1] * image[t * 4 + 1] +
                                  image[t * 4 + 2] * image[t * 4 + 2]));
  std::sort(lengths.begin(), lengths.end());
  return lengths;
}

class DecompressionEncodings : public ::testing::Test {
 protected:
  void SetUp() override {
    h = testing::harnessOrSkip();
    ASSERT_TRUE(h);
    auto c = testing::createContext(*h);
    ASSERT_TRUE(c.ok()) << c.error().message;
    context = std::move(c).value();
    auto d = Decompressor::create(*context);
    ASSERT_TRUE(d.ok()) << d.error().message;
    decompressor = std::move(d).value();
  }
  void TearDown() override {
    decompressor.reset();
    if (context) context->releaseDeferred();
    context.reset();
    testing::expectNoMessagesThroughDestruction(h);
  }

  // Decompresses a field built from `o` for every eye and compares with the CPU reference;
  // `forceCoefficientsStorage` reads the coefficients from the storage buffer instead of the texel
  // buffer (lavapipe's limits never call for it).
  void check(const SyntheticFieldOptions& o, bool forceCoefficientsStorage = false,
             const testing::DistortionTolerance& tolerance = kTolerance) {
    SCOPED_TRACE(describe(o));
    const Field field = testing::makeSyntheticField(o);
    ASSERT_TRUE(validateField(field).ok()) << validateField(field).error().message;
    auto object = testing::uploadFieldNow(*context, field);
    ASSERT_TRUE(object.ok()) << object.error().message;
    ObjectAccess::impl(*object.value()).field->coefficientsStorage |= forceCoefficientsStorage;
    testing::DistortionStats stats;
    std::vector<std::vector<float>> perEye;
    uint32_t nearJump = 0;
    for (const auto& eye : kEyes) {
      auto gpu = testing::decompressAndRead(*h, *decompressor, *object.value(), eye);
      ASSERT_TRUE(gpu.ok()) << gpu.error().message;
      const reference::DistortionImage cpu = reference::decompress(field, eye);
      ASSERT_NO_FATAL_FAILURE(testing::compareDistortion(field, gpu.value(), cpu, tolerance, stats));
      auto jump = testing::readJumpImage(*h, *object.value());
      ASSERT_TRUE(jump.ok()) << jump.error().message;
      ASSERT_NO_FATAL_FAILURE(testing::compareJumpImage(field, jump.value(), cpu, kJumpTolerance, nearJump));
      perEye.push_back(std::move(gpu).value());
    }
    // The jump image holds distances only where the field stores them.
    if (o.jumpDistance) EXPECT_GT(nearJump, 50u) << "no sample's view lies within a cell of a jump";
    else EXPECT_EQ(nearJump, 0u);
    EXPECT_GT(testing::countChanged(perEye[0], perEye[1]), 100u) << "the decoded field does not follow the eye";
    EXPECT_GT(stats.samples, 0u);
    EXPECT_GT(stats.gutters, 0u);
    EXPECT_GT(stats.empty, 0u);
    const std::vector<float> lengths = sampleLengths(field, perEye[0]);
    if (o.throughput) {
      EXPECT_LT(lengths[lengths.size() / 10], 0.9f) << "the throughput does not scale the directions";
    } else {
      EXPECT_NEAR(lengths.front(), 1.0f, 1e-3f);
      EXPECT_NEAR(lengths.back(), 1.0f, 1e-3f);
    }
    std::printf("%-40s%s: max |direction diff| %.2e, max tau rel diff %.2e, max gutter diff %.2e, |xyz| %.3f..%.3f "
                "(%u sample, %u gutter, %u empty texel checks; %u sample views within a cell of a jump)\n",
                describe(o).c_str(), forceCoefficientsStorage ? " storage" : "", double(stats.maxDirection),
                double(stats.maxTau), double(stats.maxGutter), double(lengths.front()), double(lengths.back()),
                stats.samples, stats.gutters, stats.empty, nearJump);
    object.value().reset();
    context->releaseDeferred();
  }

  std::unique_ptr<harness::Harness> h;
  std::unique_ptr<Context> context;
  std::unique_ptr<Decompressor> decompressor;
};

TEST_F(DecompressionEncodings, TableAndPcaMatchCpuReference) {
  std::printf("device: %s\n", h->deviceName().c_str());
  uint32_t seed = 100;
  for (Encoding encoding : {Encoding::Table, Encoding::Pca})
    for (Quantization q : {Quantization::U8, Quantization::F16})
      for (size_t l = 0; l < std::size(kLayouts); ++l) {
        SyntheticFieldOptions o;
        o.encoding = encoding;
        o.quantization = q;
        o.channels = kLayouts[l].channels;
        o.throughput = kLayouts[l].throughput;
        // The smallest grid (one cell) and larger ones; few and many components.
        o.tableSize = encoding == Encoding::Table ? (l % 2 ? 7 : 2) : (l % 2 ? 6 : 3);
        o.components = q == Quantization::U8 ? 9 : 4;
        o.emptyAndGutters = true;
        o.seed = ++seed;
        ASSERT_NO_FATAL_FAILURE(check(o));
      }
}

// Jump-aware corners (field_decode.cpp interpolateCorners): node-sampled tables of N >= 12 whose
// every fifth node points the other way. The CPU decode must differ from the plain bilinear one
// (the same coefficients read as grid-fitted) at many samples, so the GPU's agreement covers it.
TEST_F(DecompressionEncodings, JumpAwareCornersMatchCpuReference) {
  uint32_t seed = 400;
  for (Encoding encoding : {Encoding::Table, Encoding::Pca})
    for (Quantization q : {Quantization::U8, Quantization::F16})
      for (const ChannelLayout& layout : {kLayouts[1], kLayouts[3]}) {
        SyntheticFieldOptions o;
        o.encoding = encoding;
        o.quantization = q;
        o.channels = layout.channels;
        o.throughput = layout.throughput;
        o.tableSize = q == Quantization::U8 ? 16 : 12;  // 12: gpu_layout.h kJumpMinTableSize
        o.components = 7;
        o.emptyAndGutters = true;
        o.nodeSampled = o.jumps = true;
        o.seed = ++seed;
        SCOPED_TRACE(describe(o));
        Field plain = testing::makeSyntheticField(o);
        ASSERT_TRUE(plain.shape().jumpAware);
        plain.settings.directionSampling = DirectionSampling::Grid;
        const reference::Vec3 eye{kEyes[0][0], kEyes[0][1], kEyes[0][2]};
        const reference::DistortionImage jumpAware = reference::decompress(testing::makeSyntheticField(o), eye);
        const reference::DistortionImage bilinear = reference::decompress(plain, eye);
        EXPECT_GT(testing::countChanged(jumpAware.rgba, bilinear.rgba), 50u) << "no corner was discounted";
        ASSERT_NO_FATAL_FAILURE(check(o));
      }
}

// The jump distance channel (EncodingShape::jumpDistance): the same fields with distances that
// move the side of every disagreeing cell. The CPU decode must differ from the one without the
// channel at many samples (where the distances put the eye on the side w^p did not pick), so the
// GPU's agreement covers the signed distances; 5 and 6 encoded channels (the vec4 basis reads end
// at 4).
TEST_F(DecompressionEncodings, JumpDistanceMatchesCpuReference) {
  uint32_t seed = 500;
  for (Encoding encoding : {Encoding::Table, Encoding::Pca})
    for (Quantization q : {Quantization::U8, Quantization::F16})
      for (const ChannelLayout& layout : {kLayouts[0], kLayouts[1], kLayouts[3]}) {
        SyntheticFieldOptions o;
        o.encoding = encoding;
        o.quantization = q;
        o.channels = layout.channels;
        o.throughput = layout.throughput;
        o.tableSize = q == Quantization::U8 ? 16 : 12;
        o.components = 7;
        o.emptyAndGutters = true;
        o.nodeSampled = o.jumps = true;
        o.seed = ++seed;
        SCOPED_TRACE(describe(o));
        const reference::Vec3 eye{kEyes[0][0], kEyes[0][1], kEyes[0][2]};
        const reference::DistortionImage without = reference::decompress(testing::makeSyntheticField(o), eye);
        o.jumpDistance = true;
        const Field field = testing::makeSyntheticField(o);
        ASSERT_TRUE(field.shape().jumpDistance);
        const reference::DistortionImage with = reference::decompress(field, eye);
        EXPECT_GT(testing::countChanged(with.rgba, without.rgba), 50u) << "the distances moved no side";
        ASSERT_NO_FATAL_FAILURE(check(o));
      }
}

// Exits in the sample's frame (EncodingShape::sampleFrameExits): every encoding rotates its sum
// by the frame's rows, and the jump-aware blend compares against -w. The CPU decode must differ
// from the same coefficients read in object space at most samples, so the GPU's agreement covers
// the rotation.
TEST_F(DecompressionEncodings, SampleFrameExitsMatchCpuReference) {
  uint32_t seed = 600;
  for (Encoding encoding : {Encoding::Sh, Encoding::Table, Encoding::Pca})
    for (Quantization q : {Quantization::U8, Quantization::F16}) {
      SyntheticFieldOptions o;
      o.encoding = encoding;
      o.quantization = q;
      o.order = 4;
      o.channels = 4;
      // Pca u8 at 32x32 tables (the former default), Pca f16 at 64x64 (bake::kDefaultPcaTableSize,
      // the default field's, and bake::kMaxBakeTableSize).
      o.tableSize = encoding != Encoding::Pca ? 12 : q == Quantization::U8 ? 32 : 64;
      o.components = 7;
      o.emptyAndGutters = true;
      o.nodeSampled = o.jumps = o.jumpDistance = encoding != Encoding::Sh;
      o.seed = ++seed;
      SCOPED_TRACE(describe(o));
      const reference::Vec3 eye{kEyes[1][0], kEyes[1][1], kEyes[1][2]};
      const reference::DistortionImage object = reference::decompress(testing::makeSyntheticField(o), eye);
      o.sampleFrameExits = true;
      const Field field = testing::makeSyntheticField(o);
      ASSERT_TRUE(field.shape().sampleFrameExits);
      const reference::DistortionImage sample = reference::decompress(field, eye);
      EXPECT_GT(testing::countChanged(sample.rgba, object.rgba), 100u) << "the frame rotated nothing";
      ASSERT_NO_FATAL_FAILURE(check(o));
    }
}

TEST_F(DecompressionEncodings, ShWithThroughputMatchesCpuReference) {
  uint32_t seed = 200;
  // Order 20 with 5 channels reads its scale/bias table from the storage buffer (gpu_layout.h).
  for (uint32_t order : {1u, 4u, 8u, 20u})
    for (Quantization q : {Quantization::U8, Quantization::F16})
      for (const ChannelLayout& layout : {kLayouts[2], kLayouts[3]}) {
        SyntheticFieldOptions o;
        o.order = order;
        o.quantization = q;
        o.channels = layout.channels;
        o.throughput = true;
        o.emptyAndGutters = true;
        o.seed = ++seed;
        ASSERT_NO_FATAL_FAILURE(check(o));
      }
}

TEST_F(DecompressionEncodings, StorageCoefficientsMatchCpuReference) {
  uint32_t seed = 300;
  for (Encoding encoding : {Encoding::Table, Encoding::Pca})
    for (Quantization q : {Quantization::U8, Quantization::F16}) {
      SyntheticFieldOptions o;
      o.encoding = encoding;
      o.quantization = q;
      o.channels = 5;
      o.throughput = true;
      o.tableSize = 4;
      o.components = 5;
      o.emptyAndGutters = true;
      o.seed = ++seed;
      ASSERT_NO_FATAL_FAILURE(check(o, /*forceCoefficientsStorage=*/true));
    }
}

// The Volume encoding (decompress_volume.comp): every sample's path traced through the grid of the
// band's sphere, in every channel layout and under both path rules, against the CPU trace
// (volume_trace.cpp), which does the same float operations in the same order. With the
// throughput, a denser glass (ior 2.4) so that the exit's transmission (at most 0.83) shows.
TEST_F(DecompressionEncodings, VolumeMatchesCpuReference) {
  for (size_t l = 0; l < std::size(kLayouts); ++l)
    for (PathRule rule : {PathRule::FirstRefraction, PathRule::HighestEnergy}) {
      SyntheticFieldOptions o;
      o.encoding = Encoding::Volume;
      o.quantization = l % 2 ? Quantization::F16 : Quantization::U8;  // recorded only: nothing is quantized
      o.channels = kLayouts[l].channels;
      o.throughput = kLayouts[l].throughput;
      o.frontIor = o.throughput ? 2.4f : 1.5f;
      o.volumeSize = l % 2 ? 24 : 40;
      o.emptyAndGutters = true;
      o.pathRule = rule;
      SCOPED_TRACE(toString(rule));
      Field field = testing::makeSyntheticField(o);
      EXPECT_EQ(field.bytesPerSample(), 0u);
      ASSERT_NO_FATAL_FAILURE(check(o, false, kVolumeTolerance));
    }
}

// Clustered Pca (EncodingShape::clustered): each sample reads its one 16-bit index, two to a word,
// and decodes that function whole. Odd and even samples, both quantizations (the index is exact
// in both), plain and jump-aware corners, both frames, texel and storage reads; the CPU decode
// must differ from the same basis read as K weights of 1 (the one-hot form it replaces, which
// here sums every table), so the GPU's agreement covers the index.
TEST_F(DecompressionEncodings, ClusteredPcaMatchesCpuReference) {
  uint32_t seed = 700;
  for (Quantization q : {Quantization::U8, Quantization::F16})
    for (bool jumpAware : {false, true}) {
      SyntheticFieldOptions o;
      o.encoding = Encoding::Pca;
      o.quantization = q;
      o.channels = q == Quantization::U8 ? 4 : 5;
      o.throughput = q == Quantization::F16;
      o.tableSize = jumpAware ? 16 : 5;
      o.components = 11;
      o.emptyAndGutters = true;
      o.nodeSampled = o.jumps = o.jumpDistance = jumpAware;
      o.sampleFrameExits = jumpAware;
      o.clustered = true;
      o.seed = ++seed;
      SCOPED_TRACE(describe(o));
      const Field field = testing::makeSyntheticField(o);
      ASSERT_TRUE(field.clustered);
      ASSERT_TRUE(validateField(field).ok()) << validateField(field).error().message;
      EXPECT_EQ(field.bytesPerSample(), 2u);
      std::vector<bool> used(o.components, false);
      for (uint64_t t = 0; t < field.texelCount(); ++t)
        if (field.texelKinds[t] == kTexelSample) used[field.clusterIndices[t]] = true;
      EXPECT_EQ(std::count(used.begin(), used.end(), true), std::ptrdiff_t(o.components)) << "not every index is used";
      Field summed = field;  // every sample weighs every table by 1
      summed.clustered = false;
      summed.clusterIndices.clear();
      ASSERT_TRUE(encodeCoefficients(summed, std::vector<float>(size_t(o.components) * field.texelCount(), 1.0f)).ok());
      const reference::Vec3 eye{kEyes[0][0], kEyes[0][1], kEyes[0][2]};
      EXPECT_GT(testing::countChanged(reference::decompress(field, eye).rgba, reference::decompress(summed, eye).rgba),
                100u);
      ASSERT_NO_FATAL_FAILURE(check(o));
      ASSERT_NO_FATAL_FAILURE(check(o, /*forceCoefficientsStorage=*/true));
    }
}

}  // namespace
}  // namespace shrefract
