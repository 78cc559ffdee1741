// The decompression compute pass against the CPU reference (shrefract/cpu_reference.h): synthetic
// fields of SH orders 0, 1, 2, 4, 8 and 16, both quantizations, 3 and 4 channels, with empty
// texels and split-layout gutter rules, decompressed on the GPU for several eyes and read back.
#include <gtest/gtest.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/decompressor.h>

#include <cstdio>

#include "engine/distortion_check.h"
#include "engine/synthetic_field.h"

namespace shrefract {
namespace {

using testing::SyntheticFieldOptions;

// Tolerances. The GPU and the CPU run the same float operations on the same dequantized
// coefficients (U8: bias + scale * q / 255 on both sides), in a different summation order, with
// the GPU's own inversesqrt; both results are then stored as binary16 (half an ulp: 2.4e-4 below
// 1), so sample texels may differ by one half-ulp plus float noise. Gutter texels are a + b - c of
// three stored values (each within the direction tolerance), rounded once more: 3 x 1e-3 plus one
// ulp of the result.
constexpr testing::DistortionTolerance kTolerance{
    /*direction=*/1e-3f,    // the bound, per component of the unit direction
    /*tauRelative=*/1e-3f,  // optical depth: relative (binary16 ulp is 2^-10 relative)
    /*gutter=*/3e-3f};

using Decompression = testing::ContextTest;

TEST_F(Decompression, GpuMatchesCpuReference) {
  std::printf("device: %s\n", h->deviceName().c_str());
  Context& ctx = *context;
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
        auto object = testing::uploadFieldNow(ctx, field);
        ASSERT_TRUE(object.ok()) << object.error().message;
        ASSERT_EQ(object.value()->fieldOrder(), order);

        testing::DistortionStats stats;
        std::vector<std::vector<float>> perEye;
        for (const auto& eye : eyes) {
          auto gpu = testing::decompressAndRead(*h, *decompressor.value(), *object.value(), eye);
          ASSERT_TRUE(gpu.ok()) << gpu.error().message;
          ASSERT_NO_FATAL_FAILURE(
              testing::compareDistortion(field, gpu.value(), reference::decompress(field, eye), kTolerance, stats));
          perEye.push_back(std::move(gpu).value());
        }
        // The eye must matter from order 1 on: the texels' directions differ between two eyes.
        const uint32_t changed = testing::countChanged(perEye[0], perEye[1]);
        if (order == 0) EXPECT_EQ(changed, 0u) << "band 0 does not depend on the eye";
        else EXPECT_GT(changed, 100u) << "the decoded field does not follow the eye";
        EXPECT_GT(stats.samples, 0u);
        EXPECT_GT(stats.gutters, 0u);
        EXPECT_GT(stats.empty, 0u);
        std::printf("order %2u %-3s channels %u: max |direction diff| %.2e, max tau rel diff %.2e, max gutter diff %.2e"
                    " (%u sample, %u gutter, %u empty texel checks)\n",
                    order, toString(q), channels, double(stats.maxDirection), double(stats.maxTau),
                    double(stats.maxGutter), stats.samples, stats.gutters, stats.empty);
        object.value().reset();
        ctx.releaseDeferred();
      }
  decompressor.value().reset();
}

// Two instances of one upload decode at different SH orders (Object::setDecodeOrder), each
// matching the CPU reference summed to its order; coverageOrder follows the size on screen.
TEST_F(Decompression, InstancesDecodeAtTheirOwnOrder) {
  Context& ctx = *context;
  auto decompressor = Decompressor::create(ctx);
  ASSERT_TRUE(decompressor.ok()) << decompressor.error().message;
  SyntheticFieldOptions options;
  options.order = 8;
  options.emptyAndGutters = true;
  options.seed = 41;
  const Field field = testing::makeSyntheticField(options);
  auto full = testing::uploadFieldNow(ctx, field);
  ASSERT_TRUE(full.ok()) << full.error().message;
  std::unique_ptr<Object> low;
  ASSERT_TRUE(ctx.uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
                   auto created = Object::createInstance(ctx, *full.value(), cmd);
                   if (!created) return created.error();
                   low = std::move(created).value();
                   return {};
                 }).ok());
  EXPECT_FALSE(low->setDecodeOrder(9).ok()) << "above the baked order";
  ASSERT_TRUE(low->setDecodeOrder(3).ok());
  EXPECT_EQ(low->decodeOrder(), 3u);
  EXPECT_EQ(full.value()->decodeOrder(), 8u);
  const std::array<float, 3> eye{0.3f, 0.8f, 3.0f};
  testing::DistortionStats stats;
  auto gpuFull = testing::decompressAndRead(*h, *decompressor.value(), *full.value(), eye);
  auto gpuLow = testing::decompressAndRead(*h, *decompressor.value(), *low, eye);
  ASSERT_TRUE(gpuFull.ok() && gpuLow.ok());
  testing::compareDistortion(field, gpuFull.value(), reference::decompress(field, eye), kTolerance, stats);
  testing::compareDistortion(field, gpuLow.value(), reference::decompress(field, eye, 3), kTolerance, stats);
  EXPECT_GT(testing::countChanged(gpuFull.value(), gpuLow.value()), 100u) << "order 3 must differ from order 8";

  // A change of order decodes again at the next record; the same order does not.
  ASSERT_TRUE(h->submitAndWait([&](VkCommandBuffer cmd) { (void)decompressor.value()->record(cmd, eye, {low.get()}); }).ok());
  EXPECT_EQ(decompressor.value()->lastStats().unchanged, 1u);
  ASSERT_TRUE(low->setDecodeOrder(5).ok());
  ASSERT_TRUE(h->submitAndWait([&](VkCommandBuffer cmd) { (void)decompressor.value()->record(cmd, eye, {low.get()}); }).ok());
  EXPECT_EQ(decompressor.value()->lastStats().decompressed, 1u);

  // The synthetic band spans about 2 units: 40 pixels high at 1 unit away, a few pixels far off.
  Camera camera;
  camera.eye = {0.0f, 0.0f, 2.5f};
  EXPECT_EQ(coverageOrder(*low, camera, {256, 256}), 8u);
  camera.eye = {0.0f, 0.0f, 400.0f};
  const uint32_t far = coverageOrder(*low, camera, {256, 256});
  EXPECT_LT(far, 3u) << "a speck on screen cannot show high bands";
  camera.eye = {0.0f, 0.0f, 0.5f};  // inside the bounds: corners behind the eye
  EXPECT_EQ(coverageOrder(*low, camera, {256, 256}), 8u);

  low.reset();
  full.value().reset();
  decompressor.value().reset();
}

}  // namespace
}  // namespace shrefract
