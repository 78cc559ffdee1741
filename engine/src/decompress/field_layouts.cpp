#include "decompress/field_layouts.h"

#include <array>

#include "shrefract/gpu_layout.h"

namespace shrefract {

namespace {

Result<VkDescriptorSetLayout> createLayout(ContextImpl& c, const VkDescriptorSetLayoutBinding* bindings,
                                           uint32_t count) {
  VkDescriptorSetLayoutCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  info.bindingCount = count;
  info.pBindings = bindings;
  VkDescriptorSetLayout layout = VK_NULL_HANDLE;
  const VkResult r = c.vk.vkCreateDescriptorSetLayout(c.device(), &info, c.alloc(), &layout);
  if (r != VK_SUCCESS) return vulkanError("vkCreateDescriptorSetLayout", r);
  return layout;
}

}  // namespace

Result<VkDescriptorSetLayout> createDecompressSetLayout(ContextImpl& c) {
  auto binding = [](uint32_t index, VkDescriptorType type) {
    return VkDescriptorSetLayoutBinding{index, type, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  };
  const std::array<VkDescriptorSetLayoutBinding, 10> bindings{{
      binding(gpu::kBindingCoefficients, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER),
      binding(gpu::kBindingScaleBias, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER),
      binding(gpu::kBindingScaleBiasStorage, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER),
      binding(gpu::kBindingCoefficientsStorage, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER),
      binding(gpu::kBindingFrames, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER),
      binding(gpu::kBindingSampleTexels, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER),
      binding(gpu::kBindingDistortionOut, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE),
      binding(gpu::kBindingGutters, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER),
      binding(gpu::kBindingBasis, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER),
      binding(gpu::kBindingJumpOut, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE),
  }};
  return createLayout(c, bindings.data(), static_cast<uint32_t>(bindings.size()));
}

VkDeviceSize shScaleBiasBytes(uint32_t order, uint32_t channels) {
  return VkDeviceSize(order + 1) * (order + 1) * SHR_SH_SCALE_BIAS_VEC4S(channels) * 4 * sizeof(float);
}

bool shScaleBiasStorage(uint32_t order, uint32_t channels) {
  return shScaleBiasBytes(order, channels) > gpu::kMaxUniformScaleBiasBytes;
}

Result<VkDescriptorSetLayout> createDistortionSetLayout(ContextImpl& c) {
  const std::array<VkDescriptorSetLayoutBinding, 4> bindings{{
      {gpu::kBindingDistortion, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {gpu::kBindingTriangleEdges, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {gpu::kBindingJumpDistance, VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {gpu::kBindingVolumeGrid, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
  }};
  return createLayout(c, bindings.data(), uint32_t(bindings.size()));
}

}  // namespace shrefract
