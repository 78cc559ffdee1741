// The decompression's alternative read paths against the CPU reference: coefficients from a
// storage buffer instead of a texel buffer (devices whose maxTexelBufferElements is too small for
// the field), and the scale/bias table from a storage buffer instead of a uniform buffer (orders
// above 21, whose table exceeds the 16 KiB every device allows). Lavapipe's limits never call for
// the first, so the test switches it on through the object's private state (white box); an order
// 24 field takes the second on its own.
#include <gtest/gtest.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/decompressor.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "engine/engine_test_support.h"
#include "engine/synthetic_field.h"
#include "object/object_impl.h"

namespace shrefract {
namespace {

// As tests/engine/decompression_test.cpp: both sides dequantize the same values and round to
// binary16; the sums differ in order and in the GPU's inversesqrt.
constexpr float kDirectionTolerance = 1e-3f;
constexpr float kTauRelative = 1e-3f;

using DecompressPaths = testing::ContextTest;

TEST_F(DecompressPaths, StorageBufferPathsMatchCpuReference) {
  Context& ctx = *context;
  auto decompressor = Decompressor::create(ctx);
  ASSERT_TRUE(decompressor.ok());
  decompressor.value()->setSkipUnchanged(false);
  const std::array<float, 3> eye{0.3f, 0.8f, 3.0f};

  struct Case {
    uint32_t order;
    Quantization quantization;
    uint32_t channels;
    bool forceCoefficientsStorage;
  };
  const Case cases[] = {
      {2, Quantization::U8, 3, true},  {8, Quantization::U8, 4, true},  {8, Quantization::F16, 3, true},
      {4, Quantization::F16, 4, true}, {24, Quantization::U8, 3, false}, {24, Quantization::U8, 4, true},
  };
  for (const Case& k : cases) {
    SCOPED_TRACE("order " + std::to_string(k.order) + " " + toString(k.quantization) + " channels " +
                 std::to_string(k.channels) + (k.forceCoefficientsStorage ? " storage coefficients" : ""));
    testing::SyntheticFieldOptions options;
    options.order = k.order;
    options.quantization = k.quantization;
    options.channels = k.channels;
    options.emptyAndGutters = true;
    options.seed = 40 + k.order;
    const Field field = testing::makeSyntheticField(options);
    std::unique_ptr<Object> object;
    auto uploaded = ctx.uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
      auto created = Object::createFromField(ctx, field, cmd);
      if (!created) return created.error();
      object = std::move(created).value();
      return {};
    });
    ASSERT_TRUE(uploaded.ok()) << uploaded.error().message;
    FieldResources& f = *ObjectAccess::impl(*object).field;
    EXPECT_EQ(f.scaleBiasStorage, k.order > 21) << "the table exceeds 16 KiB from order 22 on";
    EXPECT_FALSE(f.coefficientsStorage) << "lavapipe's texel buffers hold this field";
    f.coefficientsStorage = k.forceCoefficientsStorage;

    auto submitted = h->submitAndWait([&](VkCommandBuffer cmd) {
      auto recorded = decompressor.value()->record(cmd, eye, {object.get()});
      ASSERT_TRUE(recorded.ok()) << recorded.error().message;
    });
    ASSERT_TRUE(submitted.ok()) << submitted.error().message;
    auto gpu = testing::readDistortion(*h, *object);
    ASSERT_TRUE(gpu.ok()) << gpu.error().message;
    const reference::DistortionImage cpu = reference::decompress(field, eye);
    float worstDirection = 0.0f, worstTau = 0.0f;
    uint32_t samples = 0;
    for (uint64_t t = 0; t < field.texelCount(); ++t) {
      if (field.texelKinds[t] != kTexelSample) continue;
      ++samples;
      const float* g = &gpu.value()[t * 4];
      const float* c = &cpu.rgba[t * 4];
      for (int i = 0; i < 3; ++i) worstDirection = std::max(worstDirection, std::fabs(g[i] - c[i]));
      worstTau = std::max(worstTau, std::fabs(g[3] - c[3]) / std::max(1.0f, std::fabs(c[3])));
    }
    EXPECT_GT(samples, 0u);
    EXPECT_LE(worstDirection, kDirectionTolerance);
    EXPECT_LE(worstTau, kTauRelative);
    std::printf("order %2u %-3s channels %u, coefficients from %s, scale/bias from %s: max |direction diff| %.2e, "
                "max tau rel diff %.2e (%u samples)\n",
                k.order, toString(k.quantization), k.channels, f.coefficientsStorage ? "storage" : "texel buffer",
                f.scaleBiasStorage ? "storage" : "uniform", double(worstDirection), double(worstTau), samples);
    object.reset();
    ctx.releaseDeferred();
  }
  decompressor.value().reset();
}

}  // namespace
}  // namespace shrefract
