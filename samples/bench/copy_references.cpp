#include "bench/copy_references.h"

#include <algorithm>
#include <cstring>

#include "bench_spirv.h"

namespace shrefract::bench {
namespace {

bool createCopy(Resources& r, const uint32_t* code, size_t codeBytes, VkDescriptorType sourceType,
                VkDescriptorType destinationType, Copy& out) {
  const VkDevice d = r.h.device();
  const std::array<VkDescriptorSetLayoutBinding, 2> bindings{{
      {0, sourceType, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {1, destinationType, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
  }};
  VkDescriptorSetLayoutCreateInfo dslci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  dslci.bindingCount = 2;
  dslci.pBindings = bindings.data();
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  if (vkCreateDescriptorSetLayout(d, &dslci, nullptr, &setLayout) != VK_SUCCESS) return false;
  r.setLayouts.push_back(setLayout);
  const VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, 16};
  VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = 1;
  plci.pSetLayouts = &setLayout;
  plci.pushConstantRangeCount = 1;
  plci.pPushConstantRanges = &range;
  if (vkCreatePipelineLayout(d, &plci, nullptr, &out.layout) != VK_SUCCESS) return false;
  r.layouts.push_back(out.layout);
  VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  smci.codeSize = codeBytes;
  smci.pCode = code;
  VkShaderModule module = VK_NULL_HANDLE;
  if (vkCreateShaderModule(d, &smci, nullptr, &module) != VK_SUCCESS) return false;
  VkComputePipelineCreateInfo cpci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  cpci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  cpci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  cpci.stage.module = module;
  cpci.stage.pName = "main";
  cpci.layout = out.layout;
  const VkResult result = vkCreateComputePipelines(d, VK_NULL_HANDLE, 1, &cpci, nullptr, &out.pipeline);
  vkDestroyShaderModule(d, module, nullptr);
  if (result != VK_SUCCESS) return false;
  r.pipelines.push_back(out.pipeline);
  const std::array<VkDescriptorPoolSize, 2> sizes{{{sourceType, 1}, {destinationType, 1}}};
  VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = 1;
  dpci.poolSizeCount = 2;
  dpci.pPoolSizes = sizes.data();
  VkDescriptorPool pool = VK_NULL_HANDLE;
  if (vkCreateDescriptorPool(d, &dpci, nullptr, &pool) != VK_SUCCESS) return false;
  r.pools.push_back(pool);
  VkDescriptorSetAllocateInfo dsai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  dsai.descriptorPool = pool;
  dsai.descriptorSetCount = 1;
  dsai.pSetLayouts = &setLayout;
  return vkAllocateDescriptorSets(d, &dsai, &out.set) == VK_SUCCESS;
}

// One descriptor write: exactly one of the three infos is used, by type.
void writeDescriptor(VkDevice d, VkDescriptorSet set, uint32_t binding, VkDescriptorType type,
                     const VkDescriptorBufferInfo* buffer, const VkBufferView* view, const VkDescriptorImageInfo* image) {
  VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  w.dstSet = set;
  w.dstBinding = binding;
  w.descriptorCount = 1;
  w.descriptorType = type;
  w.pBufferInfo = buffer;
  w.pTexelBufferView = view;
  w.pImageInfo = image;
  vkUpdateDescriptorSets(d, 1, &w, 0, nullptr);
}

// The previous layout's image, a layer per coefficient layer, with its view and sampler.
bool createPreviousLayoutImage(Resources& r, const Field& field, CopyTargets& t) {
  harness::Harness& h = r.h;
  VkImageCreateInfo ici{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ici.imageType = VK_IMAGE_TYPE_2D;
  ici.format = field.quantization == Quantization::U8 ? VK_FORMAT_R8G8B8A8_UNORM : VK_FORMAT_R16G16B16A16_SFLOAT;
  ici.extent = {field.width, field.height, 1};
  ici.mipLevels = 1;
  ici.arrayLayers = field.layerCount();
  ici.samples = VK_SAMPLE_COUNT_1_BIT;
  ici.tiling = VK_IMAGE_TILING_OPTIMAL;
  ici.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  bool ok = vkCreateImage(h.device(), &ici, nullptr, &t.image) == VK_SUCCESS;
  if (t.image) r.images.push_back(t.image);
  if (!ok) return false;
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(h.device(), t.image, &req);
  VkDeviceMemory memory = VK_NULL_HANDLE;
  ok = r.allocate(req, memory) && vkBindImageMemory(h.device(), t.image, memory, 0) == VK_SUCCESS;
  VkImageViewCreateInfo ivci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  ivci.image = t.image;
  ivci.viewType = VK_IMAGE_VIEW_TYPE_2D_ARRAY;
  ivci.format = ici.format;
  ivci.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, ici.arrayLayers};
  VkSamplerCreateInfo sci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  ok = ok && vkCreateImageView(h.device(), &ivci, nullptr, &t.imageView) == VK_SUCCESS;
  if (t.imageView) r.imageViews.push_back(t.imageView);
  ok = ok && vkCreateSampler(h.device(), &sci, nullptr, &t.sampler) == VK_SUCCESS;
  if (t.sampler) r.samplers.push_back(t.sampler);
  return ok;
}

constexpr VkDescriptorType kStorageBuffer = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
constexpr VkDescriptorType kTexel = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
constexpr VkDescriptorType kStorageTexel = VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER;

void recordCopySourceUpload(VkCommandBuffer cmd, VkBuffer stage, const CopyTargets& t, const Field& field,
                            uint64_t copyWords) {
  const uint32_t layers = field.layerCount();
  harness::imageBarrier(cmd, t.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_NONE, 0,
                        VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                        VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, layers);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, layers};
  region.imageExtent = {field.width, field.height, 1};
  vkCmdCopyBufferToImage(cmd, stage, t.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  const VkBufferCopy words{0, 0, copyWords * 4};
  vkCmdCopyBuffer(cmd, stage, t.source, 1, &words);
  harness::imageBarrier(cmd, t.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                        VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                        VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                        VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, layers);
  // The copy sources (buffers) for the compute copies.
  harness::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                         VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_READ_BIT);
}

}  // namespace

std::vector<uint8_t> rgbaCoefficients(const Field& field) {
  const size_t n = size_t(field.texelCount()) * field.layerCount();
  const size_t componentBytes = field.coefficientValueBytes();
  const uint32_t values = field.valuesPerLayer();
  const std::vector<uint16_t>& wide = field.clustered ? field.clusterIndices : field.coefficientsF16;
  std::vector<uint8_t> out(n * 4 * componentBytes, 0);
  for (size_t i = 0; i < n; ++i)
    for (uint32_t c = 0; c < std::min(values, 4u); ++c) {  // a fifth channel has no place in RGBA
      if (componentBytes == 1) out[i * 4 + c] = field.coefficientsU8[i * values + c];
      else std::memcpy(&out[(i * 4 + c) * 2], &wide[i * values + c], 2);
    }
  return out;
}

bool createCopyTargets(Resources& r, const Field& field, uint64_t copyWords, size_t rgbaBytes, CopyTargets& t) {
  const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT |
                                   VK_BUFFER_USAGE_STORAGE_TEXEL_BUFFER_BIT;
  const VkDeviceSize destinationBytes = std::max<VkDeviceSize>(copyWords * 4, rgbaBytes);
  t.source = r.buffer(copyWords * 4, usage);
  t.destination = r.buffer(destinationBytes, usage);
  bool ok = t.source && t.destination && createPreviousLayoutImage(r, field, t);
  // Texel views of at most maxTexelBufferElements words (the copies read that many; see bindCopies).
  const VkDeviceSize viewBytes =
      std::min<uint64_t>(copyWords, uint64_t(r.h.properties().limits.maxTexelBufferElements) / 4 * 4) * 4;
  t.source1 = ok ? r.view(t.source, VK_FORMAT_R32_UINT, viewBytes) : VK_NULL_HANDLE;
  t.destination1 = ok ? r.view(t.destination, VK_FORMAT_R32_UINT, viewBytes) : VK_NULL_HANDLE;
  t.source4 = ok ? r.view(t.source, VK_FORMAT_R32G32B32A32_UINT, viewBytes) : VK_NULL_HANDLE;
  t.destination4 = ok ? r.view(t.destination, VK_FORMAT_R32G32B32A32_UINT, viewBytes) : VK_NULL_HANDLE;
  return ok && t.source1 && t.destination1 && t.source4 && t.destination4;
}

bool createCopies(Resources& r, std::array<Copy, 4>& copies) {
  return createCopy(r, kSpirv_copy_buffer_comp, sizeof(kSpirv_copy_buffer_comp), kStorageBuffer, kStorageBuffer,
                    copies[0]) &&
         createCopy(r, kSpirv_copy_texel_comp, sizeof(kSpirv_copy_texel_comp), kTexel, kStorageTexel, copies[1]) &&
         createCopy(r, kSpirv_copy_texel4_comp, sizeof(kSpirv_copy_texel4_comp), kTexel, kStorageTexel, copies[2]) &&
         createCopy(r, kSpirv_copy_image_comp, sizeof(kSpirv_copy_image_comp), VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                    kStorageBuffer, copies[3]);
}

Result<void> uploadCopySources(harness::Harness& h, harness::Harness::Buffer stage, const std::vector<uint8_t>& rgba,
                               const CopyTargets& t, const Field& field, uint64_t copyWords) {
  std::memcpy(stage.mapped, rgba.data(), rgba.size());
  auto submitted = h.submitAndWait(
      [&](VkCommandBuffer cmd) { recordCopySourceUpload(cmd, stage.buffer, t, field, copyWords); });
  h.destroyBuffer(stage);
  return submitted;
}

void bindCopies(harness::Harness& h, const Field& field, const CopyTargets& t, uint64_t copyWords, size_t rgbaBytes,
                std::array<Copy, 4>& copies) {
  // Each copy reads as many bytes as its path's limit allows (all of them unless the field is huge).
  const VkPhysicalDeviceLimits& limits = h.properties().limits;
  const uint64_t storageWords = std::min<uint64_t>(copyWords, limits.maxStorageBufferRange / 16 * 4);
  const uint64_t texelWords = std::min<uint64_t>(copyWords, uint64_t(limits.maxTexelBufferElements) / 4 * 4);
  const VkDevice d = h.device();
  const VkDescriptorBufferInfo sourceInfo{t.source, 0, storageWords * 4};
  const VkDescriptorBufferInfo destinationInfo{t.destination, 0, storageWords * 4};
  const VkDescriptorImageInfo imageInfo{t.sampler, t.imageView, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  writeDescriptor(d, copies[0].set, 0, kStorageBuffer, &sourceInfo, nullptr, nullptr);
  writeDescriptor(d, copies[0].set, 1, kStorageBuffer, &destinationInfo, nullptr, nullptr);
  writeDescriptor(d, copies[1].set, 0, kTexel, nullptr, &t.source1, nullptr);
  writeDescriptor(d, copies[1].set, 1, kStorageTexel, nullptr, &t.destination1, nullptr);
  writeDescriptor(d, copies[2].set, 0, kTexel, nullptr, &t.source4, nullptr);
  writeDescriptor(d, copies[2].set, 1, kStorageTexel, nullptr, &t.destination4, nullptr);
  writeDescriptor(d, copies[3].set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, nullptr, nullptr, &imageInfo);
  // The previous layout's copy writes every texel of as many layers as the binding can hold.
  const bool u8 = field.quantization == Quantization::U8;
  const VkDeviceSize layerBytes = field.texelCount() * 4 * (u8 ? 1u : 2u);
  const uint32_t imageLayers = static_cast<uint32_t>(std::min<VkDeviceSize>(
      field.layerCount(), std::min<VkDeviceSize>(rgbaBytes, limits.maxStorageBufferRange) / layerBytes));
  const VkDescriptorBufferInfo imageDestinationInfo{t.destination, 0, std::max<VkDeviceSize>(imageLayers, 1) * layerBytes};
  writeDescriptor(d, copies[3].set, 1, kStorageBuffer, &imageDestinationInfo, nullptr, nullptr);
  const uint32_t words = static_cast<uint32_t>(storageWords), texels = static_cast<uint32_t>(texelWords);
  copies[0].push = {words, 0, 0, 0};
  copies[0].groups = (words + 63) / 64;
  copies[0].bytes = storageWords * 4;
  copies[1].push = {texels, 0, 0, 0};
  copies[1].groups = (texels + 63) / 64;
  copies[1].bytes = texelWords * 4;
  copies[2].push = {texels / 4, 0, 0, 0};
  copies[2].groups = (texels / 4 + 63) / 64;
  copies[2].bytes = texelWords * 4;
  copies[3].push = {field.width, field.height, imageLayers, u8 ? 0u : 1u};
  copies[3].groups = 0;  // 2D dispatch below
  copies[3].bytes = imageLayers * layerBytes;
  copies[3].reference = false;
}

std::function<void(VkCommandBuffer)> copyRecorder(const Field& field, const Copy& c) {
  return [&field, c](VkCommandBuffer cmd) {
    // Like the decompression's first barrier: wait for earlier writes of the destination.
    harness::memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                           VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c.pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, c.layout, 0, 1, &c.set, 0, nullptr);
    vkCmdPushConstants(cmd, c.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, 16, c.push.data());
    if (c.groups) vkCmdDispatch(cmd, std::min(c.groups, 32768u), (c.groups + 32767u) / 32768u, 1);
    else vkCmdDispatch(cmd, (field.width + 7) / 8, (field.height + 7) / 8, 1);
  };
}

}  // namespace shrefract::bench
