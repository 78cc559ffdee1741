// One image memory barrier, built: the engine's passes (core/barriers.h) and the headless harness
// (engine/harness) fill VkImageMemoryBarrier2 here and nowhere else. No Vulkan calls, so that it
// serves code built with and without VK_NO_PROTOTYPES.
#pragma once

#include <vulkan/vulkan_core.h>

#include <cstdint>

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

// `t` over the levels [baseLevel, baseLevel + levels) and layers [0, layers) of `image` (its colour
// unless `aspect` says otherwise), with no queue family transfer (the engine records on the host's
// one queue).
inline VkImageMemoryBarrier2 imageBarrier(VkImage image, const ImageTransition& t, uint32_t baseLevel = 0,
                                          uint32_t levels = 1, uint32_t layers = 1,
                                          VkImageAspectFlags aspect = VK_IMAGE_ASPECT_COLOR_BIT) {
  VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  b.srcStageMask = t.srcStage;
  b.srcAccessMask = t.srcAccess;
  b.dstStageMask = t.dstStage;
  b.dstAccessMask = t.dstAccess;
  b.oldLayout = t.oldLayout;
  b.newLayout = t.newLayout;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {aspect, baseLevel, levels, 0, layers};
  return b;
}

}  // namespace shrefract
