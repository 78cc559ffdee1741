// Device memory is sub-allocated per object: a field object holds three allocations (one block for
// its mesh buffers, one for its field buffers, one for its distortion and jump images), an instance
// one (its two images), whatever the number of buffers. Counted through the engine's only way to Vulkan, the host's
// vkGetInstanceProcAddr: the test hands it a wrapper that counts vkAllocateMemory and vkFreeMemory.
#include <gtest/gtest.h>

#include <atomic>
#include <cstring>

#include "engine/distortion_check.h"
#include "engine/synthetic_field.h"

namespace shrefract {
namespace {

std::atomic<int> gAllocations{0};
PFN_vkGetDeviceProcAddr gRealGetDeviceProcAddr = nullptr;
PFN_vkAllocateMemory gRealAllocate = nullptr;
PFN_vkFreeMemory gRealFree = nullptr;

VKAPI_ATTR VkResult VKAPI_CALL countingAllocate(VkDevice device, const VkMemoryAllocateInfo* info,
                                                const VkAllocationCallbacks* allocator, VkDeviceMemory* memory) {
  const VkResult r = gRealAllocate(device, info, allocator, memory);
  if (r == VK_SUCCESS) ++gAllocations;
  return r;
}

VKAPI_ATTR void VKAPI_CALL countingFree(VkDevice device, VkDeviceMemory memory, const VkAllocationCallbacks* allocator) {
  if (memory) --gAllocations;
  gRealFree(device, memory, allocator);
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL countingGetDeviceProcAddr(VkDevice device, const char* name) {
  if (std::strcmp(name, "vkAllocateMemory") == 0) {
    gRealAllocate = reinterpret_cast<PFN_vkAllocateMemory>(gRealGetDeviceProcAddr(device, name));
    return reinterpret_cast<PFN_vkVoidFunction>(&countingAllocate);
  }
  if (std::strcmp(name, "vkFreeMemory") == 0) {
    gRealFree = reinterpret_cast<PFN_vkFreeMemory>(gRealGetDeviceProcAddr(device, name));
    return reinterpret_cast<PFN_vkVoidFunction>(&countingFree);
  }
  return gRealGetDeviceProcAddr(device, name);
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL countingGetInstanceProcAddr(VkInstance instance, const char* name) {
  if (std::strcmp(name, "vkGetDeviceProcAddr") == 0) {
    gRealGetDeviceProcAddr = reinterpret_cast<PFN_vkGetDeviceProcAddr>(vkGetInstanceProcAddr(instance, name));
    return reinterpret_cast<PFN_vkVoidFunction>(&countingGetDeviceProcAddr);
  }
  return vkGetInstanceProcAddr(instance, name);
}

TEST(ObjectMemory, OneAllocationPerKindOfStorage) {
  auto h = testing::harnessOrSkip();
  ASSERT_TRUE(h);
  ContextCreateInfo info = testing::contextInfo(*h);
  info.getInstanceProcAddr = countingGetInstanceProcAddr;
  auto context = Context::create(info);
  ASSERT_TRUE(context.ok()) << context.error().message;
  Context& ctx = *context.value();
  const int before = gAllocations.load();

  testing::SyntheticFieldOptions o;
  o.encoding = Encoding::Pca;  // every field buffer in use: coefficients, scale/bias, frames, ..., basis
  o.emptyAndGutters = true;
  const Field field = testing::makeSyntheticField(o);
  auto object = testing::uploadFieldNow(ctx, field);  // uploadNow frees its staging buffers
  ASSERT_TRUE(object.ok()) << object.error().message;
  EXPECT_EQ(gAllocations.load() - before, 3) << "mesh block, field block, distortion and jump images";
  std::unique_ptr<Object> instance;
  ASSERT_TRUE(ctx.uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
                   auto created = Object::createInstance(ctx, *object.value(), cmd);
                   if (!created) return created.error();
                   instance = std::move(created).value();
                   return {};
                 }).ok());
  EXPECT_EQ(gAllocations.load() - before, 4) << "an instance adds its distortion and jump images only";
  EXPECT_EQ(ctx.deviceMemoryBytes(), object.value()->gpuMemoryBytes() + instance->gpuMemoryBytes());

  object.value().reset();  // the instance keeps the shared blocks alive
  ctx.releaseDeferred();
  EXPECT_EQ(gAllocations.load() - before, 3);
  instance.reset();
  ctx.releaseDeferred();
  EXPECT_EQ(gAllocations.load(), before);
  EXPECT_EQ(ctx.deviceMemoryBytes(), 0u);
  context.value().reset();
  testing::expectNoMessagesThroughDestruction(h);
}

}  // namespace
}  // namespace shrefract
