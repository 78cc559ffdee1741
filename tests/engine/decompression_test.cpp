// The decompression compute pass against the CPU reference (shrefract/cpu_reference.h): synthetic
// fields of SH orders 0, 1, 2, 4, 8 and 16, both quantizations, 3 and 4 channels, with empty
// texels and split-layout gutter rules, decompressed on the GPU for several eyes and read back.
#include <gtest/gtest.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/decompressor.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "engine/engine_test_support.h"
#include "engine/synthetic_field.h"

namespace shrefract {
namespace {

using testing::SyntheticFieldOptions;

// Tolerances. The GPU and the CPU run the same float operations on the same dequantized
// coefficients (U8: bias + scale * q / 255 on both sides), in a different summation order, with
// the GPU's own inversesqrt; both results are then stored as binary16 (half an ulp: 2.4e-4 below
// 1), so sample texels may differ by one half-ulp plus float noise.
constexpr float kDirectionTolerance = 1e-3f;  // the bound, per component of the unit direction
constexpr float kTauRelative = 1e-3f;         // optical depth: relative (binary16 ulp is 2^-10 relative)
// Gutter texels are a + b - c of three stored values (each within the tolerance above), rounded
// once more: 3 x 1e-3 plus one ulp of the result.
constexpr float kGutterTolerance = 3e-3f;

struct Stats {
  float maxDirection = 0.0f, maxTau = 0.0f, maxGutter = 0.0f;
  uint32_t samples = 0, gutters = 0, empty = 0;
};

TEST(Decompression, GpuMatchesCpuReference) {
  auto h = testing::harnessOrSkip();
  ASSERT_TRUE(h);
  std::printf("device: %s\n", h->deviceName().c_str());
  auto context = testing::createContext(*h);
  ASSERT_TRUE(context.ok()) << context.error().message;
  Context& ctx = *context.value();
  auto decompressor = Decompressor::create(ctx);
  ASSERT_TRUE(decompressor.ok()) << decompressor.error().message;

  const std::array<std::array<float, 3>, 3> eyes{{{0.3f, 0.8f, 3.0f}, {-2.5f, -0.4f, 1.0f}, {0.0f, 0.05f, 1.2f}}};
  for (uint32_t order : {0u, 1u, 2u, 4u, 8u, 16u})
    for (Quantization q : {Quantization::U8, Quantization::F16})
      for (uint32_t channels : {3u, 4u}) {
        SCOPED_TRACE("order " + std::to_string(order) + " " + toString(q) + " channels " + std::to_string(channels));
        SyntheticFieldOptions options;
        options.order = order;
        options.quantization = q;
        options.channels = channels;
        options.emptyAndGutters = true;
        options.seed = 17 + order * 4 + channels;
        const Field field = testing::makeSyntheticField(options);
        ASSERT_TRUE(validateField(field).ok()) << validateField(field).error().message;

        std::unique_ptr<Object> object;
        auto uploaded = ctx.uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
          auto created = Object::createFromField(ctx, field, cmd);
          if (!created) return created.error();
          object = std::move(created).value();
          return {};
        });
        ASSERT_TRUE(uploaded.ok()) << uploaded.error().message;
        ASSERT_EQ(object->fieldOrder(), order);

        Stats stats;
        std::vector<std::vector<float>> perEye;
        for (const auto& eye : eyes) {
          auto submitted = h->submitAndWait([&](VkCommandBuffer cmd) {
            auto recorded = decompressor.value()->record(cmd, eye, {object.get()});
            ASSERT_TRUE(recorded.ok()) << recorded.error().message;
          });
          ASSERT_TRUE(submitted.ok()) << submitted.error().message;
          auto gpu = testing::readDistortion(*h, *object);
          ASSERT_TRUE(gpu.ok()) << gpu.error().message;
          const reference::DistortionImage cpu = reference::decompress(field, eye);
          ASSERT_EQ(gpu.value().size(), cpu.rgba.size());
          perEye.push_back(gpu.value());
          for (uint64_t t = 0; t < field.texelCount(); ++t) {
            const float* g = &gpu.value()[t * 4];
            const float* c = &cpu.rgba[t * 4];
            const uint8_t kind = field.texelKinds[t];
            if (kind == kTexelEmpty) {
              ++stats.empty;
              for (int k = 0; k < 4; ++k) ASSERT_EQ(g[k], 0.0f) << "empty texel " << t;
            } else if (kind == kTexelSample) {
              ++stats.samples;
              for (int k = 0; k < 3; ++k) {
                const float e = std::fabs(g[k] - c[k]);
                stats.maxDirection = std::max(stats.maxDirection, e);
                ASSERT_LE(e, kDirectionTolerance) << "texel " << t << " component " << k << ": gpu " << g[k]
                                                  << " cpu " << c[k];
              }
              const float e = std::fabs(g[3] - c[3]);
              stats.maxTau = std::max(stats.maxTau, e / std::max(1.0f, std::fabs(c[3])));
              ASSERT_LE(e, kTauRelative * std::max(1.0f, std::fabs(c[3]))) << "texel " << t << " tau";
              if (channels == 3) {
                ASSERT_EQ(g[3], 0.0f);
              }
            } else {
              ++stats.gutters;
              for (int k = 0; k < 4; ++k) {
                const float e = std::fabs(g[k] - c[k]);
                stats.maxGutter = std::max(stats.maxGutter, e / std::max(1.0f, std::fabs(c[k])));
                ASSERT_LE(e, kGutterTolerance * std::max(1.0f, std::fabs(c[k]))) << "gutter texel " << t;
              }
            }
          }
        }
        // The eye must matter from order 1 on: the texels' directions differ between two eyes.
        uint32_t changed = 0;
        for (size_t i = 0; i < perEye[0].size(); ++i) changed += std::fabs(perEye[0][i] - perEye[1][i]) > 1e-2f;
        if (order == 0) EXPECT_EQ(changed, 0u) << "band 0 does not depend on the eye";
        else EXPECT_GT(changed, 100u) << "the decoded field does not follow the eye";
        EXPECT_GT(stats.samples, 0u);
        EXPECT_GT(stats.gutters, 0u);
        EXPECT_GT(stats.empty, 0u);
        std::printf("order %2u %-3s channels %u: max |direction diff| %.2e, max tau rel diff %.2e, max gutter diff %.2e"
                    " (%u sample, %u gutter, %u empty texel checks)\n",
                    order, toString(q), channels, double(stats.maxDirection), double(stats.maxTau),
                    double(stats.maxGutter), stats.samples, stats.gutters, stats.empty);
        object.reset();
        ctx.releaseDeferred();
      }
  decompressor.value().reset();
  ctx.releaseDeferred();
  context.value().reset();
  SHREFRACT_EXPECT_NO_VALIDATION_MESSAGES(*h);
}

}  // namespace
}  // namespace shrefract
