// Pipeline barriers as the engine's passes record them: every transition of an image the engine
// owns goes through imageBarrier (core/image_barrier.h, shared with the headless harness) and
// recordBarriers, so queue-family and aspect settings are written once.
#pragma once

#include <vulkan/vulkan_core.h>

#include <cstdint>
#include <span>

#include "core/context_impl.h"
#include "core/image_barrier.h"

namespace shrefract {

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
