// The decompression benchmark's references: compute shaders with no arithmetic that copy as many
// bytes as the decompression reads, through each path the engine could read them by, and a copy
// of the layout the engine used before (see decompression_benchmark.cpp).
#pragma once

#include <shrefract/field.h>
#include <shrefract/harness/harness.h>

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace shrefract::bench {

// Every Vulkan object the copies need, destroyed together.
struct Resources {
  harness::Harness& h;
  std::vector<VkBuffer> buffers;
  std::vector<VkDeviceMemory> memories;
  std::vector<VkBufferView> views;
  std::vector<VkImage> images;
  std::vector<VkImageView> imageViews;
  std::vector<VkSampler> samplers;
  std::vector<VkDescriptorSetLayout> setLayouts;
  std::vector<VkPipelineLayout> layouts;
  std::vector<VkPipeline> pipelines;
  std::vector<VkDescriptorPool> pools;

  explicit Resources(harness::Harness& harness) : h(harness) {}
  ~Resources() {
    const VkDevice d = h.device();
    for (auto p : pools) vkDestroyDescriptorPool(d, p, nullptr);
    for (auto p : pipelines) vkDestroyPipeline(d, p, nullptr);
    for (auto l : layouts) vkDestroyPipelineLayout(d, l, nullptr);
    for (auto l : setLayouts) vkDestroyDescriptorSetLayout(d, l, nullptr);
    for (auto s : samplers) vkDestroySampler(d, s, nullptr);
    for (auto v : imageViews) vkDestroyImageView(d, v, nullptr);
    for (auto i : images) vkDestroyImage(d, i, nullptr);
    for (auto v : views) vkDestroyBufferView(d, v, nullptr);
    for (auto b : buffers) vkDestroyBuffer(d, b, nullptr);
    for (auto m : memories) vkFreeMemory(d, m, nullptr);
  }

  bool allocate(const VkMemoryRequirements& req, VkDeviceMemory& memory) {
    VkMemoryAllocateInfo info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    info.allocationSize = req.size;
    info.memoryTypeIndex = h.findMemoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (info.memoryTypeIndex == UINT32_MAX || vkAllocateMemory(h.device(), &info, nullptr, &memory) != VK_SUCCESS)
      return false;
    memories.push_back(memory);
    return true;
  }

  VkBuffer buffer(VkDeviceSize size, VkBufferUsageFlags usage) {
    VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    info.size = size;
    info.usage = usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    VkBuffer b = VK_NULL_HANDLE;
    if (vkCreateBuffer(h.device(), &info, nullptr, &b) != VK_SUCCESS) return VK_NULL_HANDLE;
    buffers.push_back(b);
    VkMemoryRequirements req{};
    vkGetBufferMemoryRequirements(h.device(), b, &req);
    VkDeviceMemory memory = VK_NULL_HANDLE;
    if (!allocate(req, memory) || vkBindBufferMemory(h.device(), b, memory, 0) != VK_SUCCESS) return VK_NULL_HANDLE;
    return b;
  }

  VkBufferView view(VkBuffer b, VkFormat format, VkDeviceSize range) {
    VkBufferViewCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
    info.buffer = b;
    info.format = format;
    info.range = range;
    VkBufferView v = VK_NULL_HANDLE;
    if (vkCreateBufferView(h.device(), &info, nullptr, &v) != VK_SUCCESS) return VK_NULL_HANDLE;
    views.push_back(v);
    return v;
  }
};

// A copy shader with its descriptor set: binding 0 the source, binding 1 the destination.
struct Copy {
  const char* name;
  VkPipeline pipeline = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  std::array<uint32_t, 4> push{};
  uint32_t groups = 0;         // workgroups in x
  uint64_t bytes = 0;          // bytes read
  bool reference = true;       // counts for the ratio
  double ms = 0.0, cpuMs = 0.0;
};

// The copies' sources and destinations: a source and a destination buffer of the bytes the
// decompression reads (rounded up to whole 16-byte texels), and the previous layout's image.
struct CopyTargets {
  VkBuffer source = VK_NULL_HANDLE, destination = VK_NULL_HANDLE;
  VkImage image = VK_NULL_HANDLE;
  VkImageView imageView = VK_NULL_HANDLE;
  VkSampler sampler = VK_NULL_HANDLE;
  VkBufferView source1 = VK_NULL_HANDLE, destination1 = VK_NULL_HANDLE;  // a word per texel
  VkBufferView source4 = VK_NULL_HANDLE, destination4 = VK_NULL_HANDLE;  // four words per texel
};

// The coefficients as the engine used to upload them: RGBA per texel and layer, layer-major,
// alpha 0 when the field has 3 channels (the source of the previous-layout copy).
std::vector<uint8_t> rgbaCoefficients(const Field& field);

bool createCopyTargets(Resources& r, const Field& field, uint64_t copyWords, size_t rgbaBytes, CopyTargets& t);

// The four copies: storage buffer, texel buffer (1 and 4 words an invocation), previous layout.
bool createCopies(Resources& r, std::array<Copy, 4>& copies);

// Upload the previous layout's image; the copy sources hold whatever (a copy does not look).
// `stage` is destroyed.
Result<void> uploadCopySources(harness::Harness& h, harness::Harness::Buffer stage, const std::vector<uint8_t>& rgba,
                               const CopyTargets& t, const Field& field, uint64_t copyWords);

// The copies' descriptors, push constants, dispatch sizes and the bytes each reads.
void bindCopies(harness::Harness& h, const Field& field, const CopyTargets& t, uint64_t copyWords, size_t rgbaBytes,
                std::array<Copy, 4>& copies);

// Records copy `c` (after a barrier like the decompression's first).
std::function<void(VkCommandBuffer)> copyRecorder(const Field& field, const Copy& c);

}  // namespace shrefract::bench
