#include <shrefract/environment.h>

#include <cmath>
#include <string>
#include <vector>

#include "core/half.h"
#include "environment/environment_impl.h"

namespace shrefract {

Environment::Environment(std::unique_ptr<EnvironmentImpl> impl) : impl_(std::move(impl)) {}

Environment::~Environment() {
  EnvironmentImpl* e = impl_.release();
  e->context->retire([e]() {
    ContextImpl& c = *e->context;
    if (e->pool) c.vk.vkDestroyDescriptorPool(c.device(), e->pool, c.alloc());
    c.destroyImage(e->image);
    delete e;
  });
}

Result<std::unique_ptr<Environment>> Environment::createLatLong(Context& context, const LatLongEnvironmentDesc& desc,
                                                                VkCommandBuffer cmd) {
  if (!desc.rgba || desc.width == 0 || desc.height == 0)
    return makeError(ErrorCode::InvalidArgument, "environment: empty image");
  if (desc.width != 2 * desc.height)
    return makeError(ErrorCode::InvalidArgument, "environment: a lat-long map must be 2:1, got " +
                                                     std::to_string(desc.width) + "x" + std::to_string(desc.height));
  ContextImpl& c = context.impl();
  const size_t texels = size_t(desc.width) * desc.height;
  std::vector<uint16_t> half(texels * 4);
  for (size_t i = 0; i < texels * 4; ++i) {
    const float v = desc.rgba[i];
    if (!std::isfinite(v) || v < 0.0f)
      return makeError(ErrorCode::InvalidArgument,
                       "environment: pixel " + std::to_string((i / 4) % desc.width) + "," +
                           std::to_string((i / 4) / desc.width) + " is negative, NaN or infinite");
    half[i] = floatToHalf(v);
  }

  auto impl = std::make_unique<EnvironmentImpl>();
  impl->context = &c;
  impl->width = desc.width;
  impl->height = desc.height;
  VkImageCreateInfo ici{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ici.imageType = VK_IMAGE_TYPE_2D;
  ici.format = VK_FORMAT_R16G16B16A16_SFLOAT;
  ici.extent = {desc.width, desc.height, 1};
  ici.mipLevels = 1;
  ici.arrayLayers = 1;
  ici.samples = VK_SAMPLE_COUNT_1_BIT;
  ici.tiling = VK_IMAGE_TILING_OPTIMAL;
  ici.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  auto image = c.createImage(ici, VK_IMAGE_VIEW_TYPE_2D, VK_IMAGE_ASPECT_COLOR_BIT);
  if (!image) return image.error();
  impl->image = image.value();
  std::unique_ptr<Environment> env(new Environment(std::move(impl)));
  EnvironmentImpl& e = env->impl();

  const VkDeviceSize bytes = half.size() * sizeof(uint16_t);
  auto staging = c.createBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
  if (!staging) return staging.error();
  BufferAllocation s = staging.value();
  std::memcpy(s.mapped, half.data(), bytes);
  c.retire([&c, s]() mutable { c.destroyBuffer(s); });

  VkImageMemoryBarrier2 toDst{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  toDst.srcStageMask = VK_PIPELINE_STAGE_2_NONE;
  toDst.dstStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  toDst.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  toDst.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  toDst.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  toDst.srcQueueFamilyIndex = toDst.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  toDst.image = e.image.image;
  toDst.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &toDst;
  c.vk.vkCmdPipelineBarrier2(cmd, &dep);

  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {desc.width, desc.height, 1};
  c.vk.vkCmdCopyBufferToImage(cmd, s.buffer, e.image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);

  VkImageMemoryBarrier2 toRead = toDst;
  toRead.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  toRead.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  toRead.dstStageMask = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  toRead.dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
  toRead.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  toRead.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  dep.pImageMemoryBarriers = &toRead;
  c.vk.vkCmdPipelineBarrier2(cmd, &dep);

  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1};
  VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = 1;
  dpci.poolSizeCount = 1;
  dpci.pPoolSizes = &size;
  VkResult r = c.vk.vkCreateDescriptorPool(c.device(), &dpci, c.alloc(), &e.pool);
  if (r != VK_SUCCESS) return vulkanError("vkCreateDescriptorPool", r);
  VkDescriptorSetAllocateInfo dsai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  dsai.descriptorPool = e.pool;
  dsai.descriptorSetCount = 1;
  dsai.pSetLayouts = &c.environmentSetLayout;
  r = c.vk.vkAllocateDescriptorSets(c.device(), &dsai, &e.set);
  if (r != VK_SUCCESS) return vulkanError("vkAllocateDescriptorSets", r);
  VkDescriptorImageInfo dii{c.environmentSampler, e.image.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  w.dstSet = e.set;
  w.dstBinding = 0;
  w.descriptorCount = 1;
  w.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w.pImageInfo = &dii;
  c.vk.vkUpdateDescriptorSets(c.device(), 1, &w, 0, nullptr);
  return env;
}

}  // namespace shrefract
