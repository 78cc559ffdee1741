// One 2D image's create info: the engine's images and the headless harness (engine/harness) start
// from it. No Vulkan calls, so that it serves code built with and without VK_NO_PROTOTYPES.
#pragma once

#include <vulkan/vulkan_core.h>

#include <cstdint>

namespace shrefract {

// A 2D image of one level and one layer, optimally tiled, created UNDEFINED.
inline VkImageCreateInfo imageInfo2D(VkFormat format, uint32_t width, uint32_t height, VkImageUsageFlags usage,
                                     VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT) {
  VkImageCreateInfo ici{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ici.imageType = VK_IMAGE_TYPE_2D;
  ici.format = format;
  ici.extent = {width, height, 1};
  ici.mipLevels = 1;
  ici.arrayLayers = 1;
  ici.samples = samples;
  ici.tiling = VK_IMAGE_TILING_OPTIMAL;
  ici.usage = usage;
  return ici;
}

}  // namespace shrefract
