// The Table, Pca (weights and clustered) and Volume encodings through the file: exact round trips,
// every truncation rejected, bytes per sample, and decoding after dequantizing once.
#include <shrefract/field.h>
#include <shrefract/field_decode.h>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "field/field_test_support.h"

namespace shrefract {
namespace {

using namespace fieldtest;

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

}  // namespace
}  // namespace shrefract
