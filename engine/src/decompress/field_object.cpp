// Object::createFromField: uploads a refraction field (coefficients, frames, texel kinds, gutter
// rules, render mesh) and creates the object's distortion image and descriptor sets.
#include <shrefract/field.h>
#include <shrefract/renderer.h>

#include <array>
#include <cstring>
#include <string>
#include <vector>

#include "core/context_impl.h"
#include "decompress/field_layouts.h"
#include "raster/object_impl.h"
#include "shrefract/gpu_layout.h"

namespace shrefract {

static_assert(gpu::kGpuTexelEmpty == kTexelEmpty && gpu::kGpuTexelSample == kTexelSample &&
              gpu::kGpuTexelGutter == kTexelGutter, "gpu_layout.h and field.h must agree on texel kinds");

namespace {

// Copies the layer-major coefficients of `field` into `out` as 4 components per texel (alpha 0
// when the field stores 3 channels), the layout vkCmdCopyBufferToImage expects for a layered copy.
template <class T>
void expandToRgba(const std::vector<T>& in, uint32_t channels, size_t texelsTimesLayers, T* out) {
  if (channels == 4) {
    std::memcpy(out, in.data(), texelsTimesLayers * 4 * sizeof(T));
    return;
  }
  for (size_t t = 0; t < texelsTimesLayers; ++t) {
    for (uint32_t c = 0; c < 3; ++c) out[t * 4 + c] = in[t * 3 + c];
    out[t * 4 + 3] = T{0};
  }
}

Result<BufferAllocation> createDeviceBuffer(ContextImpl& c, VkDeviceSize bytes, VkBufferUsageFlags usage) {
  return c.createBuffer(bytes, usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT, false);
}

}  // namespace

void destroyFieldResources(ContextImpl& c, FieldResources& f) {
  const VkDevice d = c.device();
  if (f.pool) c.vk.vkDestroyDescriptorPool(d, f.pool, c.alloc());
  if (f.decompressSetLayout) c.vk.vkDestroyDescriptorSetLayout(d, f.decompressSetLayout, c.alloc());
  if (f.distortionSetLayout) c.vk.vkDestroyDescriptorSetLayout(d, f.distortionSetLayout, c.alloc());
  if (f.sampler) c.vk.vkDestroySampler(d, f.sampler, c.alloc());
  c.destroyImage(f.coefficients);
  c.destroyImage(f.distortion);
  for (BufferAllocation* b : {&f.scaleBias, &f.frames, &f.kinds, &f.gutters}) c.destroyBuffer(*b);
  f = FieldResources{};
}

bool Object::hasField() const { return impl_->field != nullptr; }
uint32_t Object::fieldOrder() const { return impl_->field ? impl_->field->order : 0; }
VkExtent2D Object::fieldExtent() const {
  return impl_->field ? VkExtent2D{impl_->field->width, impl_->field->height} : VkExtent2D{0, 0};
}
VkImage Object::distortionImage() const { return impl_->field ? impl_->field->distortion.image : VK_NULL_HANDLE; }

Result<std::unique_ptr<Object>> Object::createFromField(Context& context, const Field& field, VkCommandBuffer cmd) {
  if (auto valid = validateField(field); !valid) return valid.error();
  ContextImpl& c = context.impl();
  const VkPhysicalDeviceLimits& limits = c.properties.limits;
  const uint32_t layers = field.basisCount();
  if (field.width > limits.maxImageDimension2D || field.height > limits.maxImageDimension2D)
    return makeError(ErrorCode::Unsupported, "field atlas " + std::to_string(field.width) + "x" +
                                                 std::to_string(field.height) + " exceeds the device's 2D image limit " +
                                                 std::to_string(limits.maxImageDimension2D));
  if (layers > limits.maxImageArrayLayers)
    return makeError(ErrorCode::Unsupported, "field order " + std::to_string(field.order) + " needs " +
                                                 std::to_string(layers) + " image layers; the device allows " +
                                                 std::to_string(limits.maxImageArrayLayers));
  const FieldMesh& m = field.mesh;
  MeshDesc mesh;
  mesh.positions = m.positions.data();
  mesh.normals = m.normals.data();
  mesh.fieldUvs = m.uvs.data();
  mesh.frontIor = m.frontIor.data();
  mesh.vertexCount = static_cast<uint32_t>(m.positions.size() / 3);
  mesh.indices = m.indices.data();
  mesh.indexCount = static_cast<uint32_t>(m.indices.size());

  auto impl = std::make_unique<ObjectImpl>();
  impl->context = &c;
  if (auto r = createMeshBuffers(c, mesh, cmd, *impl); !r) {
    BufferAllocation v = impl->vertices, i = impl->indices;  // `cmd` may reference them: retire
    c.retire([&c, v, i]() mutable {
      c.destroyBuffer(v);
      c.destroyBuffer(i);
    });
    return r.error();
  }
  impl->field = std::make_unique<FieldResources>();
  // From here on the object's destructor retires whatever has been created.
  std::unique_ptr<Object> object(new Object(std::move(impl)));
  FieldResources& f = *object->impl().field;
  f.width = field.width;
  f.height = field.height;
  f.order = field.order;
  f.gutterCount = static_cast<uint32_t>(field.gutters.size());
  const size_t texels = static_cast<size_t>(field.texelCount());
  const bool u8 = field.quantization == Quantization::U8;

  // Images.
  VkImageCreateInfo ici{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ici.imageType = VK_IMAGE_TYPE_2D;
  ici.format = u8 ? VK_FORMAT_R8G8B8A8_UNORM : VK_FORMAT_R16G16B16A16_SFLOAT;
  ici.extent = {field.width, field.height, 1};
  ici.mipLevels = 1;
  ici.arrayLayers = layers;
  ici.samples = VK_SAMPLE_COUNT_1_BIT;
  ici.tiling = VK_IMAGE_TILING_OPTIMAL;
  ici.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  auto coefficients = c.createImage(ici, VK_IMAGE_VIEW_TYPE_2D_ARRAY, VK_IMAGE_ASPECT_COLOR_BIT);
  if (!coefficients) return coefficients.error();
  f.coefficients = coefficients.value();
  ici.format = VK_FORMAT_R16G16B16A16_SFLOAT;
  ici.arrayLayers = 1;
  ici.usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
              VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  auto distortion = c.createImage(ici, VK_IMAGE_VIEW_TYPE_2D, VK_IMAGE_ASPECT_COLOR_BIT);
  if (!distortion) return distortion.error();
  f.distortion = distortion.value();

  // Buffers.
  std::vector<float> scaleBias(size_t(layers) * 8, 0.0f);
  for (uint32_t i = 0; i < layers; ++i)
    for (uint32_t ch = 0; ch < field.channels; ++ch) {
      const size_t table = size_t(i) * field.channels + ch;
      scaleBias[size_t(i) * 8 + ch] = u8 ? field.scale[table] : 1.0f;
      scaleBias[size_t(i) * 8 + 4 + ch] = u8 ? field.bias[table] : 0.0f;
    }
  std::vector<uint32_t> kinds((texels + 3) / 4, 0u);
  for (size_t t = 0; t < texels; ++t) kinds[t / 4] |= uint32_t(field.texelKinds[t]) << (8 * (t % 4));
  std::vector<uint32_t> gutters(std::max<size_t>(field.gutters.size(), 1) * 4, 0u);
  for (size_t g = 0; g < field.gutters.size(); ++g) {
    const GutterTexel& r = field.gutters[g];
    gutters[g * 4 + 0] = r.target;
    gutters[g * 4 + 1] = r.a;
    gutters[g * 4 + 2] = r.b;
    gutters[g * 4 + 3] = r.c;
  }
  const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  struct Upload {
    BufferAllocation* target;
    const void* data;
    VkDeviceSize bytes;
  };
  const std::array<Upload, 4> uploads{{
      {&f.scaleBias, scaleBias.data(), scaleBias.size() * sizeof(float)},
      {&f.frames, field.frames.data(), field.frames.size() * sizeof(float)},
      {&f.kinds, kinds.data(), kinds.size() * sizeof(uint32_t)},
      {&f.gutters, gutters.data(), gutters.size() * sizeof(uint32_t)},
  }};
  for (const Upload& u : uploads) {
    auto b = createDeviceBuffer(c, u.bytes, storage);
    if (!b) return b.error();
    *u.target = b.value();
  }

  // Coefficient staging, written in place.
  const size_t componentBytes = u8 ? 1 : 2;
  const VkDeviceSize coefficientBytes = VkDeviceSize(texels) * layers * 4 * componentBytes;
  auto staging = c.createBuffer(coefficientBytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
  if (!staging) return staging.error();
  BufferAllocation s = staging.value();
  c.retire([&c, s]() mutable { c.destroyBuffer(s); });
  if (u8) expandToRgba(field.coefficientsU8, field.channels, texels * layers, static_cast<uint8_t*>(s.mapped));
  else expandToRgba(field.coefficientsF16, field.channels, texels * layers, static_cast<uint16_t*>(s.mapped));

  // Record: images to TRANSFER_DST, copy and clear, then to SHADER_READ_ONLY_OPTIMAL.
  std::array<VkImageMemoryBarrier2, 2> toDst{};
  for (auto& b : toDst) {
    b = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
    b.srcStageMask = VK_PIPELINE_STAGE_2_NONE;
    b.dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  }
  toDst[0].dstStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  toDst[0].image = f.coefficients.image;
  toDst[0].subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, layers};
  toDst[1].dstStageMask = VK_PIPELINE_STAGE_2_CLEAR_BIT;
  toDst[1].image = f.distortion.image;
  toDst[1].subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = static_cast<uint32_t>(toDst.size());
  dep.pImageMemoryBarriers = toDst.data();
  c.vk.vkCmdPipelineBarrier2(cmd, &dep);

  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, layers};
  region.imageExtent = {field.width, field.height, 1};
  c.vk.vkCmdCopyBufferToImage(cmd, s.buffer, f.coefficients.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  const VkClearColorValue zero{};
  const VkImageSubresourceRange distortionRange{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  c.vk.vkCmdClearColorImage(cmd, f.distortion.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &zero, 1,
                            &distortionRange);
  for (const Upload& u : uploads)
    if (auto r = c.recordBufferUpload(cmd, u.target->buffer, u.data, u.bytes); !r) return r.error();

  std::array<VkImageMemoryBarrier2, 2> toRead = toDst;
  for (auto& b : toRead) {
    b.srcStageMask = b.dstStageMask;
    b.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    b.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
  }
  toRead[0].dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  toRead[1].dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  VkMemoryBarrier2 buffersToRead{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  buffersToRead.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  buffersToRead.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  buffersToRead.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  buffersToRead.dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
  dep.pImageMemoryBarriers = toRead.data();
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &buffersToRead;
  c.vk.vkCmdPipelineBarrier2(cmd, &dep);

  // Sampler and descriptor sets.
  VkSamplerCreateInfo sci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  sci.magFilter = VK_FILTER_LINEAR;
  sci.minFilter = VK_FILTER_LINEAR;
  sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  sci.addressModeU = sci.addressModeV = sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VkResult r = c.vk.vkCreateSampler(c.device(), &sci, c.alloc(), &f.sampler);
  if (r != VK_SUCCESS) return vulkanError("vkCreateSampler", r);
  auto decompressLayout = createDecompressSetLayout(c);
  if (!decompressLayout) return decompressLayout.error();
  f.decompressSetLayout = decompressLayout.value();
  auto distortionLayout = createDistortionSetLayout(c);
  if (!distortionLayout) return distortionLayout.error();
  f.distortionSetLayout = distortionLayout.value();

  const std::array<VkDescriptorPoolSize, 3> sizes{{
      {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 2},
      {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 4},
      {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1},
  }};
  VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = 2;
  dpci.poolSizeCount = static_cast<uint32_t>(sizes.size());
  dpci.pPoolSizes = sizes.data();
  r = c.vk.vkCreateDescriptorPool(c.device(), &dpci, c.alloc(), &f.pool);
  if (r != VK_SUCCESS) return vulkanError("vkCreateDescriptorPool", r);
  const std::array<VkDescriptorSetLayout, 2> setLayouts{f.decompressSetLayout, f.distortionSetLayout};
  std::array<VkDescriptorSet, 2> sets{};
  VkDescriptorSetAllocateInfo dsai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  dsai.descriptorPool = f.pool;
  dsai.descriptorSetCount = 2;
  dsai.pSetLayouts = setLayouts.data();
  r = c.vk.vkAllocateDescriptorSets(c.device(), &dsai, sets.data());
  if (r != VK_SUCCESS) return vulkanError("vkAllocateDescriptorSets", r);
  f.decompressSet = sets[0];
  f.distortionSet = sets[1];

  const VkDescriptorImageInfo coefficientInfo{f.sampler, f.coefficients.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  const VkDescriptorImageInfo storageInfo{VK_NULL_HANDLE, f.distortion.view, VK_IMAGE_LAYOUT_GENERAL};
  const VkDescriptorImageInfo sampledInfo{f.sampler, f.distortion.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  const std::array<VkDescriptorBufferInfo, 4> bufferInfos{{
      {f.scaleBias.buffer, 0, VK_WHOLE_SIZE},
      {f.frames.buffer, 0, VK_WHOLE_SIZE},
      {f.kinds.buffer, 0, VK_WHOLE_SIZE},
      {f.gutters.buffer, 0, VK_WHOLE_SIZE},
  }};
  const std::array<uint32_t, 4> bufferBindings{gpu::kBindingScaleBias, gpu::kBindingFrames, gpu::kBindingTexelKinds,
                                               gpu::kBindingGutters};
  std::vector<VkWriteDescriptorSet> writes;
  auto write = [&](VkDescriptorSet set, uint32_t binding, VkDescriptorType type) -> VkWriteDescriptorSet& {
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = binding;
    w.descriptorCount = 1;
    w.descriptorType = type;
    writes.push_back(w);
    return writes.back();
  };
  writes.reserve(7);
  write(f.decompressSet, gpu::kBindingCoefficients, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER).pImageInfo =
      &coefficientInfo;
  write(f.decompressSet, gpu::kBindingDistortionOut, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE).pImageInfo = &storageInfo;
  for (size_t i = 0; i < bufferInfos.size(); ++i)
    write(f.decompressSet, bufferBindings[i], VK_DESCRIPTOR_TYPE_STORAGE_BUFFER).pBufferInfo = &bufferInfos[i];
  write(f.distortionSet, gpu::kBindingDistortion, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER).pImageInfo =
      &sampledInfo;
  c.vk.vkUpdateDescriptorSets(c.device(), static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);
  return object;
}

}  // namespace shrefract
