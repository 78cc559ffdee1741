// Private side of Context: dispatch table, memory helpers, shared layouts, deferred destruction.
#pragma once

#include <shrefract/context.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/dispatch.h"

namespace shrefract {

Error vulkanError(const char* what, VkResult result);

struct BufferAllocation {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  VkDeviceSize memoryBytes = 0;  // the allocation's size (memory requirements)
  void* mapped = nullptr;  // host-visible allocations only
};

// One device-local allocation shared by several buffers of an object (each bound at its own
// aligned offset): an object costs one vkAllocateMemory for its buffers, not one per buffer.
struct MemoryBlock {
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize memoryBytes = 0;
};

struct ImageAllocation {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;  // null for an image bound into another's (createImages)
  VkImageView view = VK_NULL_HANDLE;
  VkDeviceSize memoryBytes = 0;  // the allocation's size (memory requirements); 0 with no memory of its own
};

struct ContextImpl {
  ContextCreateInfo info;
  Dispatch vk;
  VkPhysicalDeviceProperties properties{};
  VkPhysicalDeviceMemoryProperties memoryProperties{};

  // Shared by every raster pipeline: set 0 = environment sampler.
  VkSampler environmentSampler = VK_NULL_HANDLE;
  VkDescriptorSetLayout environmentSetLayout = VK_NULL_HANDLE;

  // Own pool and fence, used only by Context::uploadNow().
  VkCommandPool uploadPool = VK_NULL_HANDLE;
  VkFence uploadFence = VK_NULL_HANDLE;

  uint64_t frame = 0;
  // Device memory allocated by createBuffer/createImage and not yet freed (retired allocations
  // count until they are released): Context::deviceMemoryBytes().
  uint64_t memoryBytes = 0;
  struct Retired {
    uint64_t frame;
    std::function<void()> release;
  };
  std::vector<Retired> retired;

  ~ContextImpl();

  const VkAllocationCallbacks* alloc() const { return info.allocator; }
  VkDevice device() const { return info.device; }

  uint32_t findMemoryType(uint32_t typeBits, VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred) const;
  Result<BufferAllocation> createBuffer(VkDeviceSize size, VkBufferUsageFlags usage, bool hostVisible);
  // A device-local buffer without memory, for bindBlock (destroyBuffer frees only the buffer).
  Result<BufferAllocation> createUnboundBuffer(VkDeviceSize size, VkBufferUsageFlags usage);
  // Allocates one device-local block for `buffers` (created unbound) and binds each at an offset
  // aligned to its requirement. Error (MissingFeature) when no memory type suits them all.
  Result<MemoryBlock> bindBlock(const std::vector<BufferAllocation*>& buffers);
  void destroyBlock(MemoryBlock& block);
  void destroyBuffer(BufferAllocation& buffer);
  Result<ImageAllocation> createImage(const VkImageCreateInfo& imageInfo, VkImageViewType viewType,
                                      VkImageAspectFlags aspect);
  // Images with views in one device-local allocation, each at an offset aligned to its
  // requirement: the first holds the memory, so it is destroyed last (destroyImage frees it).
  Result<std::vector<ImageAllocation>> createImages(const std::vector<VkImageCreateInfo>& imageInfos,
                                                    VkImageViewType viewType, VkImageAspectFlags aspect);
  void destroyImage(ImageAllocation& image);
  Result<VkShaderModule> createShaderModule(const uint32_t* code, size_t bytes);

  // Defers `release` until the GPU can no longer be using what it frees.
  void retire(std::function<void()> release);

  // Uploads `bytes` into `dst` through a staging buffer; records the copy into `cmd` and retires
  // the staging buffer.
  Result<void> recordBufferUpload(VkCommandBuffer cmd, VkBuffer dst, const void* data, VkDeviceSize bytes);
};

// Frees a pass's state (DecompressorImpl, RendererImpl: a `context` and release()) once the GPU can
// no longer be using it; state that never got a context goes at once.
template <class Impl>
void retireImpl(std::unique_ptr<Impl> impl) {
  Impl* p = impl.release();
  if (!p->context) {
    delete p;
    return;
  }
  p->context->retire([p]() {
    p->release();
    delete p;
  });
}

// The engine's way into Context's private state.
struct ContextAccess {
  static ContextImpl& impl(Context& context) { return *context.impl_; }
};

}  // namespace shrefract
