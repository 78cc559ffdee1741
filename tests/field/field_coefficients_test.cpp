// The coefficients (docs/field-format.md, "Dequantizing"): u8 and f16 encodings within their
// steps, exact zero ranges, refused input, and the per-texel form the bake uses.
#include <shrefract/field.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "field/field_test_support.h"

namespace shrefract {
namespace {

using namespace fieldtest;

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

}  // namespace
}  // namespace shrefract
