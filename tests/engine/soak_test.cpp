// Soak: what a host does for minutes, at a small size. 1000 frames with two frames in flight (two
// command buffers and fences, Context::beginFrame after each fence wait), the eye orbiting and
// every instance moving, instances of one field created and destroyed every few frames in the
// frame's own command buffer while earlier frames may still read the ones going away. At the end
// the engine's device memory is back to its baseline, nothing is left deferred, and the
// validation layer (synchronization validation included) reported nothing, teardown included.
#include <gtest/gtest.h>
#include <shrefract/decompressor.h>
#include <shrefract/environment.h>
#include <shrefract/renderer.h>

#include <cmath>
#include <cstdio>
#include <deque>
#include <vector>

#include "engine/engine_test_support.h"
#include "engine/synthetic_field.h"
#include "gpu_test_support.h"

namespace shrefract {
namespace {

constexpr uint32_t kFrames = 1000;
constexpr uint32_t kInFlight = 2;
constexpr VkExtent2D kExtent{64, 48};

struct Slot {
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
};

TEST(Soak, InstancesComeAndGoOverAThousandFrames) {
  auto h = testing::harnessOrSkip();
  ASSERT_TRUE(h);
  ContextCreateInfo info = testing::contextInfo(*h);
  info.framesInFlight = kInFlight;
  auto created = Context::create(info);
  ASSERT_TRUE(created.ok()) << created.error().message;
  std::unique_ptr<Context> context = std::move(created).value();
  EXPECT_EQ(context->deviceMemoryBytes(), 0u);

  auto color = h->createImage(kExtent.width, kExtent.height, VK_FORMAT_R8G8B8A8_UNORM,
                              VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT, VK_IMAGE_ASPECT_COLOR_BIT);
  auto depth = h->createImage(kExtent.width, kExtent.height, VK_FORMAT_D32_SFLOAT,
                              VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, VK_IMAGE_ASPECT_DEPTH_BIT);
  ASSERT_TRUE(color.ok() && depth.ok());
  RendererCreateInfo rci;
  rci.colorFormat = VK_FORMAT_R8G8B8A8_UNORM;
  auto renderer = Renderer::create(*context, rci);
  auto decompressor = Decompressor::create(*context);
  ASSERT_TRUE(renderer.ok() && decompressor.ok());

  testing::SyntheticFieldOptions o;
  o.order = 3;
  o.radius = 0.5f;
  const Field field = testing::makeSyntheticField(o);
  std::vector<float> sky(32 * 16 * 4);
  for (size_t i = 0; i < sky.size(); ++i) sky[i] = i % 4 == 3 ? 1.0f : 0.2f + 0.6f * float((i / 4) % 32) / 32.0f;
  std::unique_ptr<Environment> environment;
  std::unique_ptr<Object> original;
  ASSERT_TRUE(context
                  ->uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
                    auto env = Environment::createLatLong(*context, {32, 16, sky.data()}, cmd);
                    if (!env) return env.error();
                    environment = std::move(env).value();
                    auto object = Object::createFromField(*context, field, cmd);
                    if (!object) return object.error();
                    original = std::move(object).value();
                    return {};
                  })
                  .ok());
  const uint64_t baseline = context->deviceMemoryBytes();
  ASSERT_GT(baseline, 0u);
  EXPECT_EQ(context->deferredCount(), 0u) << "uploadNow released its own staging buffers";

  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = h->queueFamily();
  VkCommandPool pool = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateCommandPool(h->device(), &pci, nullptr, &pool), VK_SUCCESS);
  std::array<Slot, kInFlight> slots{};
  for (Slot& s : slots) {
    VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ai.commandPool = pool;
    ai.commandBufferCount = 1;
    ASSERT_EQ(vkAllocateCommandBuffers(h->device(), &ai, &s.cmd), VK_SUCCESS);
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    fci.flags = VK_FENCE_CREATE_SIGNALED_BIT;
    ASSERT_EQ(vkCreateFence(h->device(), &fci, nullptr, &s.fence), VK_SUCCESS);
  }

  std::deque<std::unique_ptr<Object>> instances;
  uint64_t peak = baseline, instancesCreated = 0;
  for (uint32_t frame = 0; frame < kFrames; ++frame) {
    Slot& slot = slots[frame % kInFlight];
    ASSERT_EQ(vkWaitForFences(h->device(), 1, &slot.fence, VK_TRUE, UINT64_MAX), VK_SUCCESS);
    context->beginFrame();
    vkResetFences(h->device(), 1, &slot.fence);
    vkResetCommandBuffer(slot.cmd, 0);
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vkBeginCommandBuffer(slot.cmd, &bi);
    // Every 5th frame a new instance; every 7th the oldest goes (up to 4 live at once).
    if (frame % 5 == 0 && instances.size() < 4) {
      auto instance = Object::createInstance(*context, *original, slot.cmd);
      ASSERT_TRUE(instance.ok()) << instance.error().message;
      instances.push_back(std::move(instance).value());
      ++instancesCreated;
    }
    if (frame % 7 == 0 && !instances.empty()) instances.pop_front();
    std::vector<Object*> objects{original.get()};
    for (size_t k = 0; k < instances.size(); ++k) {
      const float a = 0.01f * float(frame) + float(k);
      instances[k]->worldFromObject = {{0.0f, std::sin(a), 0.0f, std::cos(a)},
                                       {1.2f * std::cos(a), 0.1f * float(k), 1.2f * std::sin(a)}, 0.6f};
      objects.push_back(instances[k].get());
    }
    Camera camera;
    const float orbit = 0.003f * float(frame);
    camera.eye = {4.0f * std::sin(orbit), 0.8f, 4.0f * std::cos(orbit)};
    ASSERT_TRUE(decompressor.value()->record(slot.cmd, camera, kExtent, objects).ok());
    testing::recordRaster(slot.cmd, color.value(), depth.value(), nullptr, *renderer.value(), *environment, camera,
                          objects);
    ASSERT_EQ(vkEndCommandBuffer(slot.cmd), VK_SUCCESS);
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &slot.cmd;
    ASSERT_EQ(vkQueueSubmit(h->queue(), 1, &si, slot.fence), VK_SUCCESS);
    peak = std::max(peak, context->deviceMemoryBytes());
  }
  vkDeviceWaitIdle(h->device());
  instances.clear();
  context->releaseDeferred();
  std::printf("soak: %u frames, %llu instances created, device memory baseline %llu, peak %llu, end %llu bytes\n",
              kFrames, static_cast<unsigned long long>(instancesCreated), static_cast<unsigned long long>(baseline),
              static_cast<unsigned long long>(peak), static_cast<unsigned long long>(context->deviceMemoryBytes()));
  EXPECT_GT(instancesCreated, 100u);
  EXPECT_GT(peak, baseline) << "instances and staging must show in the accounting";
  EXPECT_EQ(context->deviceMemoryBytes(), baseline);
  EXPECT_EQ(context->deferredCount(), 0u);

  for (Slot& s : slots) vkDestroyFence(h->device(), s.fence, nullptr);
  vkDestroyCommandPool(h->device(), pool, nullptr);
  original.reset();
  environment.reset();
  decompressor.value().reset();
  renderer.value().reset();
  context->releaseDeferred();
  EXPECT_EQ(context->deviceMemoryBytes(), 0u) << "the engine frees everything it allocated";
  context.reset();
  h->destroyImage(color.value());
  h->destroyImage(depth.value());
  testing::expectNoMessagesThroughDestruction(h);
}

}  // namespace
}  // namespace shrefract
