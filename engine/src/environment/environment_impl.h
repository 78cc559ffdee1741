#pragma once

#include <shrefract/environment.h>

#include "core/context_impl.h"

namespace shrefract {

struct EnvironmentImpl {
  ContextImpl* context = nullptr;
  EnvironmentEncoding encoding = EnvironmentEncoding::LatLong;
  ImageAllocation image;  // lat-long: 2D; cube: 6 layers, CUBE view
  VkSampler cubeSampler = VK_NULL_HANDLE;  // cube maps only (lat-long uses the context's sampler)
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;  // layout: ContextImpl::environmentSetLayout
  uint32_t width = 0, height = 0;        // per face for cube maps
};

// The engine's way into Environment's private state.
struct EnvironmentAccess {
  static EnvironmentImpl& impl(Environment& environment) { return *environment.impl_; }
  static const EnvironmentImpl& impl(const Environment& environment) { return *environment.impl_; }
};

}  // namespace shrefract
