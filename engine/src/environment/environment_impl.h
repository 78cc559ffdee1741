#pragma once

#include <shrefract/environment.h>

#include "core/context_impl.h"

namespace shrefract {

struct EnvironmentImpl {
  ContextImpl* context = nullptr;
  ImageAllocation image;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;  // layout: ContextImpl::environmentSetLayout
  uint32_t width = 0, height = 0;
};

}  // namespace shrefract
