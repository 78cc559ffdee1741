// Hand-made fields at the edges of what the format allows, decoded by the CPU reference of the
// engine's passes (shrefract/cpu_reference.h): channels of zero range (U8 scale 0), direction sums
// of zero or near-zero length (the kMinDirectionLength2 rule of gpu_layout.h), and coefficients as
// large as validateField accepts. The GPU side of the same fields is stability_gpu_test.cpp.
#include <gtest/gtest.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/field.h>
#include <shrefract/sh.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "engine/synthetic_field.h"
#include "stability/stability_fields.h"

namespace shrefract::stability {
namespace {

// A smooth lat-long environment (width x width / 2), linear RGBA.
std::vector<float> smoothLatLong(uint32_t width) {
  const uint32_t height = width / 2;
  std::vector<float> rgba(size_t(width) * height * 4);
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      float* p = &rgba[(size_t(y) * width + x) * 4];
      p[0] = 0.2f + 0.6f * float(x) / float(width);
      p[1] = 0.2f + 0.6f * float(y) / float(height);
      p[2] = 0.5f + 0.3f * std::sin(0.2f * float(x + y));
      p[3] = 1.0f;
    }
  return rgba;
}

bool finite(const reference::Vec4& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]) && std::isfinite(v[3]);
}

TEST(StabilityField, ZeroRangeChannelsDecodeExactly) {
  for (Quantization q : {Quantization::U8, Quantization::F16}) {
    const ZeroRangeField z = makeZeroRangeField(q);
    ASSERT_TRUE(validateField(z.field).ok());
    if (q == Quantization::U8) {
      for (const auto& [layer, channel, value] : z.constants)
        EXPECT_EQ(z.field.scale[size_t(layer) * z.field.channels + channel], 0.0f) << layer << "," << channel;
    }
    for (const auto& [layer, channel, value] : z.constants)
      for (uint64_t t = 0; t < z.field.texelCount(); ++t)
        ASSERT_EQ(fieldCoefficient(z.field, layer, t, channel), value) << "layer " << layer << " channel " << channel;
    // The file round trip keeps the zero scales, and the decode stays finite from every side.
    const std::vector<uint8_t> bytes = serializeField(z.field);
    auto parsed = parseField(bytes.data(), bytes.size(), "zero-range");
    ASSERT_TRUE(parsed.ok()) << parsed.error().message;
    EXPECT_EQ(parsed.value().scale, z.field.scale);
    for (const auto& eye : testEyes()) {
      const reference::DistortionImage d = reference::decompress(z.field, eye);
      for (float v : d.rgba) ASSERT_TRUE(std::isfinite(v));
      // tau is the constant 1.25 times Y_0 on every sample texel.
      for (uint64_t t = 0; t < z.field.texelCount(); ++t) {
        if (z.field.texelKinds[t] != kTexelSample) continue;
        EXPECT_NEAR(d.rgba[t * 4 + 3], 1.25f * 0.2820948f, 1e-3f);
      }
    }
  }
}

TEST(StabilityField, ZeroAndNearZeroDirectionSums) {
  const NearZeroField z = makeNearZeroField();
  ASSERT_TRUE(validateField(z.field).ok()) << validateField(z.field).error().message;
  size_t counted[4] = {0, 0, 0, 0};
  float smallestCancelled = 1e9f;
  for (uint64_t t = 0; t < z.field.texelCount(); ++t) {
    if (z.field.texelKinds[t] != kTexelSample) continue;
    const reference::Vec4 v = reference::decodeTexel(z.field, t, z.eye);
    ASSERT_TRUE(finite(v)) << "texel " << t;
    const float len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    const int kind = z.kind[t];
    ++counted[kind];
    if (kind == kZeroSum) {
      EXPECT_EQ(len, 0.0f) << "texel " << t << ": a zero sum decodes to the zero vector";
    } else {
      EXPECT_NEAR(len, 1.0f, 1e-5f) << "texel " << t << " (class " << kind << ") must be normalized";
    }
    if (kind == kCancellingSum) {
      // The length of the sum before normalization, to show how close to zero it came.
      const float* m = &z.field.frames[t * 12];
      float w[3];
      for (int k = 0; k < 3; ++k)
        w[k] = m[4 * k] * z.eye[0] + m[4 * k + 1] * z.eye[1] + m[4 * k + 2] * z.eye[2] + m[4 * k + 3];
      w[2] = std::max(w[2], 0.0f);
      float y[9];
      sh::evaluate(2, w[0], w[1], w[2], y);
      float sum2 = 0.0f;
      for (uint32_t ch = 0; ch < 3; ++ch) {
        float sum = 0.0f;
        for (uint32_t i = 0; i < 9; ++i) sum += fieldCoefficient(z.field, i, t, ch) * y[i];
        sum2 += sum * sum;
      }
      smallestCancelled = std::min(smallestCancelled, std::sqrt(sum2));
    }
  }
  for (int k = 0; k < 4; ++k) EXPECT_GT(counted[k], 0u) << "texel class " << k;
  std::printf("cancelling sums: the shortest is %.3g long (coefficients about 0.5)\n", double(smallestCancelled));
  EXPECT_LT(smallestCancelled, 1e-2f);

  // A sum below the threshold that is not exactly zero: |s|^2 = 2.4e-23.
  const Field below = makeConstantDirectionField(1e-11f);
  ASSERT_TRUE(validateField(below).ok());
  for (uint64_t t = 0; t < below.texelCount(); ++t) {
    const reference::Vec4 v = reference::decodeTexel(below, t, z.eye);
    ASSERT_TRUE(finite(v));
    EXPECT_EQ(v[0], 0.0f);
    EXPECT_EQ(v[1], 0.0f);
    EXPECT_EQ(v[2], 0.0f);
  }

  // The raster pass treats a zero direction as "look straight through": the view direction.
  const std::vector<float> envPixels = smoothLatLong(64);
  const reference::LatLongImage env{64, 32, envPixels.data()};
  reference::SurfacePoint point;
  point.position = {0.0f, 0.0f, 1.0f};
  point.normal = {0.0f, 0.0f, 1.0f};
  point.uv = {0.5f, 0.5f};
  point.frontIor = 1.5f;
  float view[3], len = 0.0f;
  for (int k = 0; k < 3; ++k) {
    view[k] = point.position[size_t(k)] - z.eye[size_t(k)];
    len += view[k] * view[k];
  }
  for (float& v : view) v /= std::sqrt(len);
  const reference::DistortionImage zero{1, 1, {0.0f, 0.0f, 0.0f, 0.5f}};
  const reference::DistortionImage straight{1, 1, {view[0], view[1], view[2], 0.5f}};
  const reference::Vec3 a = reference::shadeField(zero, env, point, z.eye, ObjectShading{});
  const reference::Vec3 b = reference::shadeField(straight, env, point, z.eye, ObjectShading{});
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_TRUE(std::isfinite(a[k]));
    EXPECT_NEAR(a[k], b[k], 1e-6f);
  }

  // The whole image stays finite.
  const reference::DistortionImage d = reference::decompress(z.field, z.eye);
  for (float v : d.rgba) ASSERT_TRUE(std::isfinite(v));
  const reference::RenderedImage image = reference::render({{&z.field.mesh, &d, ObjectShading{}}}, env, z.camera, 48, 36);
  size_t covered = 0;
  for (int32_t o : image.object) covered += o >= 0 ? 1 : 0;
  EXPECT_GT(covered, 200u);
  for (float v : image.rgba) ASSERT_TRUE(std::isfinite(v));
}

TEST(StabilityField, LargestAcceptedCoefficientsStayFinite) {
  // validateField accepts U8 tables whose every level decodes finite. Summed over many layers
  // with |Y| up to about 2, the largest such coefficients could overflow float (an infinite or
  // NaN sum, or |s|^2 overflowing to Inf and the direction collapsing to zero). Either validation
  // rejects them, or the decoded image stays finite.
  // Since the bound (kMaxCoefficientMagnitude, field.h) validation rejects the overflowing ones.
  for (uint32_t order : {0u, 2u, 8u, 32u})
    for (float magnitude : {1e15f, 1e19f, 1e30f, 3e38f}) {
      const Field f = makeHugeField(order, magnitude);
      const auto valid = validateField(f);
      std::printf("order %u, coefficients %g: %s\n", order, double(magnitude),
                  valid ? "accepted" : valid.error().message.c_str());
      EXPECT_EQ(valid.ok(), magnitude <= kMaxCoefficientMagnitude) << order << ", " << magnitude;
      if (!valid) continue;
      size_t bad = 0, zero = 0;
      for (const auto& eye : testEyes()) {
        const reference::DistortionImage d = reference::decompress(f, eye);
        for (size_t i = 0; i < d.rgba.size(); i += 4) {
          for (size_t k = 0; k < 4; ++k) bad += std::isfinite(d.rgba[i + k]) ? 0 : 1;
          zero += (d.rgba[i] == 0.0f && d.rgba[i + 1] == 0.0f && d.rgba[i + 2] == 0.0f) ? 1 : 0;
        }
      }
      EXPECT_EQ(bad, 0u) << "order " << order << ", " << magnitude << ": NaN/Inf in the distortion image";
      EXPECT_EQ(zero, 0u) << "order " << order << ", " << magnitude << ": a huge sum lost its direction";
    }
}

TEST(StabilityField, FrameEntriesAreBounded) {
  // Found by fuzzing (tests/fuzz/corpus/field/regression-frame-1e35.bin): a finite frame entry of
  // 1e35 made M_s (eye, 1) overflow and the decode NaN. validateField now bounds frame entries by
  // kMaxFrameMagnitude, within which every eye up to 1e22 from the origin decodes finite.
  testing::SyntheticFieldOptions o;
  o.order = 2;
  Field f = testing::makeSyntheticField(o);
  ASSERT_TRUE(validateField(f).ok());
  f.frames[0] = 1e35f;
  const auto rejected = validateField(f);
  ASSERT_FALSE(rejected.ok());
  EXPECT_NE(rejected.error().message.find("frame"), std::string::npos) << rejected.error().message;
  for (uint64_t t = 0; t < f.texelCount(); ++t)
    for (size_t k = 0; k < 12; ++k) f.frames[t * 12 + k] = (k % 2 ? -1.0f : 1.0f) * kMaxFrameMagnitude;
  ASSERT_TRUE(validateField(f).ok());
  for (const reference::Vec3& eye : std::vector<reference::Vec3>{{1e22f, -1e22f, 1e22f}, {-1e22f, 1e22f, -1e22f},
                                                                  {0.0f, 0.0f, 0.0f}, {1.0f, 2.0f, 3.0f}})
    for (uint64_t t = 0; t < f.texelCount(); ++t) ASSERT_TRUE(finite(reference::decodeTexel(f, t, eye))) << t;
}

}  // namespace
}  // namespace shrefract::stability
