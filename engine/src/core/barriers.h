// Pipeline barriers as the engine's passes record them: every transition of an image the engine
// owns goes through these two functions, so queue-family and aspect settings are written once.
#pragma once

#include <vulkan/vulkan_core.h>

#include <cstdint>
#include <span>

#include "core/context_impl.h"

namespace shrefract {

// The stages, accesses and layouts of one image barrier; the image and range are added by
// imageBarrier.
struct ImageTransition {
  VkPipelineStageFlags2 srcStage = VK_PIPELINE_STAGE_2_NONE;
  VkAccessFlags2 srcAccess = 0;
  VkPipelineStageFlags2 dstStage = VK_PIPELINE_STAGE_2_NONE;
  VkAccessFlags2 dstAccess = 0;
  VkImageLayout oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkImageLayout newLayout = VK_IMAGE_LAYOUT_UNDEFINED;
};

// `t` over the colour levels [baseLevel, baseLevel + levels) and layers [0, layers) of `image`, with
// no queue family transfer (the engine records on the host's one queue).
inline VkImageMemoryBarrier2 imageBarrier(VkImage image, const ImageTransition& t, uint32_t baseLevel = 0,
                                          uint32_t levels = 1, uint32_t layers = 1) {
  VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  b.srcStageMask = t.srcStage;
  b.srcAccessMask = t.srcAccess;
  b.dstStageMask = t.dstStage;
  b.dstAccessMask = t.dstAccess;
  b.oldLayout = t.oldLayout;
  b.newLayout = t.newLayout;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, baseLevel, levels, 0, layers};
  return b;
}

// One vkCmdPipelineBarrier2 with `images` and, when not null, one global memory barrier.
inline void recordBarriers(const ContextImpl& c, VkCommandBuffer cmd, std::span<const VkImageMemoryBarrier2> images,
                           const VkMemoryBarrier2* memory = nullptr) {
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = static_cast<uint32_t>(images.size());
  dep.pImageMemoryBarriers = images.data();
  dep.memoryBarrierCount = memory ? 1u : 0u;
  dep.pMemoryBarriers = memory;
  c.vk.vkCmdPipelineBarrier2(cmd, &dep);
}

}  // namespace shrefract
