// Vulkan entry points loaded from the host's vkGetInstanceProcAddr: the engine is compiled with
// VK_NO_PROTOTYPES and calls no global Vulkan symbol.
#pragma once

#include <vulkan/vulkan_core.h>

namespace shrefract {

#define SHREFRACT_INSTANCE_FUNCTIONS(X)    \
  X(vkGetDeviceProcAddr)                   \
  X(vkGetPhysicalDeviceProperties)         \
  X(vkGetPhysicalDeviceMemoryProperties)   \
  X(vkGetPhysicalDeviceFormatProperties)   \
  X(vkGetPhysicalDeviceFeatures2)

#define SHREFRACT_DEVICE_FUNCTIONS(X) \
  X(vkAllocateCommandBuffers)         \
  X(vkAllocateDescriptorSets)         \
  X(vkAllocateMemory)                 \
  X(vkBeginCommandBuffer)             \
  X(vkBindBufferMemory)               \
  X(vkBindImageMemory)                \
  X(vkCmdBindDescriptorSets)          \
  X(vkCmdBindIndexBuffer)             \
  X(vkCmdBindPipeline)                \
  X(vkCmdBindVertexBuffers)           \
  X(vkCmdClearColorImage)             \
  X(vkCmdCopyBuffer)                  \
  X(vkCmdCopyBufferToImage)           \
  X(vkCmdBlitImage)                   \
  X(vkCmdDispatch)                    \
  X(vkCmdDraw)                        \
  X(vkCmdDrawIndexed)                 \
  X(vkCmdPipelineBarrier2)            \
  X(vkCmdPushConstants)               \
  X(vkCmdWriteTimestamp2)             \
  X(vkCmdResetQueryPool)              \
  X(vkCreateBuffer)                   \
  X(vkCreateBufferView)               \
  X(vkCreateCommandPool)              \
  X(vkCreateComputePipelines)         \
  X(vkCreateDescriptorPool)           \
  X(vkCreateDescriptorSetLayout)      \
  X(vkCreateFence)                    \
  X(vkCreateGraphicsPipelines)        \
  X(vkCreateImage)                    \
  X(vkCreateImageView)                \
  X(vkCreatePipelineLayout)           \
  X(vkCreateQueryPool)                \
  X(vkCreateSampler)                  \
  X(vkCreateShaderModule)             \
  X(vkDestroyBuffer)                  \
  X(vkDestroyBufferView)              \
  X(vkDestroyCommandPool)             \
  X(vkDestroyDescriptorPool)          \
  X(vkDestroyDescriptorSetLayout)     \
  X(vkDestroyFence)                   \
  X(vkDestroyImage)                   \
  X(vkDestroyImageView)               \
  X(vkDestroyPipeline)                \
  X(vkDestroyPipelineLayout)          \
  X(vkDestroyQueryPool)               \
  X(vkDestroySampler)                 \
  X(vkDestroyShaderModule)            \
  X(vkEndCommandBuffer)               \
  X(vkFreeCommandBuffers)             \
  X(vkFreeMemory)                     \
  X(vkGetBufferMemoryRequirements)    \
  X(vkGetImageMemoryRequirements)     \
  X(vkGetQueryPoolResults)            \
  X(vkMapMemory)                      \
  X(vkQueueSubmit)                    \
  X(vkResetFences)                    \
  X(vkUnmapMemory)                    \
  X(vkUpdateDescriptorSets)           \
  X(vkWaitForFences)

struct Dispatch {
#define SHREFRACT_DECLARE(name) PFN_##name name = nullptr;
  SHREFRACT_INSTANCE_FUNCTIONS(SHREFRACT_DECLARE)
  SHREFRACT_DEVICE_FUNCTIONS(SHREFRACT_DECLARE)
#undef SHREFRACT_DECLARE

  // Loads every entry point; returns the name of the first one missing, or nullptr.
  const char* load(PFN_vkGetInstanceProcAddr getInstanceProcAddr, VkInstance instance, VkDevice device);
};

}  // namespace shrefract
