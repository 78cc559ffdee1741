// Anti-aliasing the host can use: the renderer's pipelines take the host's sample count
// (RendererCreateInfo::sampleCount), the host owns the multisampled attachments and their resolve.
// A field object rendered at 64x48 with 4x MSAA is closer to the same frame supersampled 4x4 (the
// frame at 256x192 averaged over 4x4 blocks) than the 1-sample frame is, zero validation messages;
// an unsupported count is refused.
#include <gtest/gtest.h>
#include <shrefract/decompressor.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "engine/distortion_check.h"
#include "engine/synthetic_field.h"

namespace shrefract {
namespace {

constexpr VkExtent2D kExtent{64, 48};
constexpr uint32_t kSuper = 4;  // the reference: kSuper x kSuper samples per pixel


// Renders `object` at `extent` with `samples` per pixel (resolved) and reads the colour back.
Result<std::vector<float>> render(harness::Harness& h, Context& context, Decompressor& decompressor,
                                  const Environment& environment, Object& object, const Camera& camera,
                                  VkExtent2D extent, VkSampleCountFlagBits samples) {
  RendererCreateInfo rci;
  rci.colorFormat = VK_FORMAT_R8G8B8A8_UNORM;
  rci.sampleCount = samples;
  auto renderer = Renderer::create(context, rci);
  if (!renderer) return renderer.error();
  const VkImageUsageFlags colorUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  auto color = h.createImage(extent.width, extent.height, rci.colorFormat, colorUsage, VK_IMAGE_ASPECT_COLOR_BIT, samples);
  auto depth = h.createImage(extent.width, extent.height, rci.depthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                             VK_IMAGE_ASPECT_DEPTH_BIT, samples);
  auto resolve = h.createImage(extent.width, extent.height, rci.colorFormat, colorUsage, VK_IMAGE_ASPECT_COLOR_BIT);
  if (!color || !depth || !resolve) return makeError(ErrorCode::Vulkan, "cannot create the render targets");
  const bool msaa = samples != VK_SAMPLE_COUNT_1_BIT;
  Result<void> recorded;
  Object* const objects[] = {&object};
  auto submitted = h.submitAndWait([&](VkCommandBuffer cmd) {
    recorded = decompressor.record(cmd, camera, extent, {&object});
    testing::recordRaster(cmd, color.value(), depth.value(), msaa ? &resolve.value() : nullptr,
                          *renderer.value(), environment, camera, objects);
  });
  auto pixels = h.readbackColor(msaa ? resolve.value() : color.value(), VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
  h.destroyImage(color.value());
  h.destroyImage(depth.value());
  h.destroyImage(resolve.value());
  renderer.value().reset();
  context.releaseDeferred();
  if (!submitted) return submitted.error();
  if (!recorded) return recorded.error();
  return pixels;
}

using Msaa = testing::ContextTest;

TEST_F(Msaa, HostSampleCountBringsTheFrameTowardSupersampling) {
  Context& ctx = *context;
  const VkSampleCountFlags counts = h->properties().limits.framebufferColorSampleCounts &
                                    h->properties().limits.framebufferDepthSampleCounts;
  ASSERT_TRUE(counts & VK_SAMPLE_COUNT_4_BIT) << "every Vulkan device supports 4 samples per pixel";
  if (!(counts & VK_SAMPLE_COUNT_64_BIT)) {
    RendererCreateInfo unsupported;
    unsupported.sampleCount = VK_SAMPLE_COUNT_64_BIT;
    auto refused = Renderer::create(ctx, unsupported);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ErrorCode::Unsupported);
  }
  {
    // Silhouette coverage blends at one sample per pixel: an integer colour format (which no
    // device blends) is refused, naming the setting, before any pipeline is made.
    RendererCreateInfo integer;
    integer.colorFormat = VK_FORMAT_R32G32B32A32_UINT;
    auto refused = Renderer::create(ctx, integer);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ErrorCode::Unsupported);
    EXPECT_NE(refused.error().message.find("silhouetteCoverage"), std::string::npos) << refused.error().message;
  }

  std::vector<float> sky(64 * 32 * 4);
  for (size_t i = 0; i < sky.size(); ++i) sky[i] = i % 4 == 3 ? 1.0f : float((i / 4) % 64) / 64.0f;
  std::unique_ptr<Environment> environment;
  testing::SyntheticFieldOptions o;
  o.radius = 0.8f;
  const Field field = testing::makeSyntheticField(o);
  auto object = testing::uploadFieldNow(ctx, field);
  ASSERT_TRUE(object.ok()) << object.error().message;
  ASSERT_TRUE(ctx.uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
                   auto env = Environment::createLatLong(ctx, {64, 32, sky.data()}, cmd);
                   if (!env) return env.error();
                   environment = std::move(env).value();
                   return {};
                 }).ok());
  auto decompressor = Decompressor::create(ctx);
  ASSERT_TRUE(decompressor.ok());
  Camera camera;
  camera.eye = {0.3f, 0.5f, 3.2f};

  auto one = render(*h, ctx, *decompressor.value(), *environment, *object.value(), camera, kExtent, VK_SAMPLE_COUNT_1_BIT);
  auto four = render(*h, ctx, *decompressor.value(), *environment, *object.value(), camera, kExtent, VK_SAMPLE_COUNT_4_BIT);
  auto big = render(*h, ctx, *decompressor.value(), *environment, *object.value(), camera,
                    {kExtent.width * kSuper, kExtent.height * kSuper}, VK_SAMPLE_COUNT_1_BIT);
  ASSERT_TRUE(one.ok() && four.ok() && big.ok());
  // The reference: every kSuper x kSuper block of the big frame averaged.
  double errorOne = 0.0, errorFour = 0.0;
  for (uint32_t y = 0; y < kExtent.height; ++y)
    for (uint32_t x = 0; x < kExtent.width; ++x)
      for (uint32_t c = 0; c < 3; ++c) {
        double reference = 0.0;
        for (uint32_t j = 0; j < kSuper; ++j)
          for (uint32_t i = 0; i < kSuper; ++i)
            reference += double(big.value()[((size_t(y) * kSuper + j) * kExtent.width * kSuper + x * kSuper + i) * 4 + c]);
        reference /= double(kSuper * kSuper);
        const size_t p = (size_t(y) * kExtent.width + x) * 4 + c;
        errorOne += std::fabs(double(one.value()[p]) - reference);
        errorFour += std::fabs(double(four.value()[p]) - reference);
      }
  std::printf("mean |error| against 4x4 supersampling: 1 sample %.5f, 4x MSAA %.5f\n",
              errorOne / (kExtent.width * kExtent.height * 3), errorFour / (kExtent.width * kExtent.height * 3));
  EXPECT_GT(errorOne, 0.0);
  EXPECT_LT(errorFour, 0.75 * errorOne) << "MSAA must smooth the silhouettes";

  object.value().reset();
  environment.reset();
  decompressor.value().reset();
}

}  // namespace
}  // namespace shrefract
