#include <shrefract/context.h>

#include <algorithm>
#include <cstring>
#include <string>

#include "core/context_impl.h"

namespace shrefract {

Error vulkanError(const char* what, VkResult result) {
  return makeError(ErrorCode::Vulkan, std::string(what) + " failed (VkResult " + std::to_string(result) + ")", result);
}

DeviceRequirements deviceRequirements() { return DeviceRequirements{}; }

Result<std::unique_ptr<Context>> Context::create(const ContextCreateInfo& info) {
  if (!info.instance || !info.physicalDevice || !info.device || !info.queue || !info.getInstanceProcAddr)
    return makeError(ErrorCode::InvalidArgument,
                     "ContextCreateInfo: instance, physicalDevice, device, queue and getInstanceProcAddr are required");
  if (info.framesInFlight < 1 || info.framesInFlight > 8)
    return makeError(ErrorCode::InvalidArgument, "ContextCreateInfo: framesInFlight must be 1..8");

  auto impl = std::make_unique<ContextImpl>();
  impl->info = info;
  if (const char* missing = impl->vk.load(info.getInstanceProcAddr, info.instance, info.device))
    return makeError(ErrorCode::MissingFeature, std::string("Vulkan entry point not available: ") + missing);
  impl->vk.vkGetPhysicalDeviceProperties(info.physicalDevice, &impl->properties);
  impl->vk.vkGetPhysicalDeviceMemoryProperties(info.physicalDevice, &impl->memoryProperties);
  if (impl->properties.apiVersion < VK_API_VERSION_1_3)
    return makeError(ErrorCode::MissingFeature, "shrefract needs a Vulkan 1.3 device");

  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  f2.pNext = &f13;
  impl->vk.vkGetPhysicalDeviceFeatures2(info.physicalDevice, &f2);
  if (!f13.dynamicRendering || !f13.synchronization2 || !f13.maintenance4)
    return makeError(ErrorCode::MissingFeature, "the device lacks dynamicRendering, synchronization2 or maintenance4");

  const VkDevice device = info.device;
  const auto& vk = impl->vk;
  VkSamplerCreateInfo sci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  sci.magFilter = VK_FILTER_LINEAR;
  sci.minFilter = VK_FILTER_LINEAR;
  sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
  sci.addressModeU = VK_SAMPLER_ADDRESS_MODE_REPEAT;         // longitude wraps
  sci.addressModeV = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;  // latitude stops at the poles
  sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  sci.maxLod = VK_LOD_CLAMP_NONE;
  VkResult r = vk.vkCreateSampler(device, &sci, impl->alloc(), &impl->environmentSampler);
  if (r != VK_SUCCESS) return vulkanError("vkCreateSampler", r);

  VkDescriptorSetLayoutBinding binding{};
  binding.binding = 0;
  binding.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  binding.descriptorCount = 1;
  binding.stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT;
  VkDescriptorSetLayoutCreateInfo lci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  lci.bindingCount = 1;
  lci.pBindings = &binding;
  r = vk.vkCreateDescriptorSetLayout(device, &lci, impl->alloc(), &impl->environmentSetLayout);
  if (r != VK_SUCCESS) return vulkanError("vkCreateDescriptorSetLayout", r);

  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  pci.queueFamilyIndex = info.queueFamilyIndex;
  r = vk.vkCreateCommandPool(device, &pci, impl->alloc(), &impl->uploadPool);
  if (r != VK_SUCCESS) return vulkanError("vkCreateCommandPool", r);
  VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  r = vk.vkCreateFence(device, &fci, impl->alloc(), &impl->uploadFence);
  if (r != VK_SUCCESS) return vulkanError("vkCreateFence", r);

  return std::unique_ptr<Context>(new Context(std::move(impl)));
}

Context::Context(std::unique_ptr<ContextImpl> impl) : impl_(std::move(impl)) {}
Context::~Context() = default;

ContextImpl::~ContextImpl() {
  // The context's destructor is the host's promise that the GPU is done with the engine's work.
  for (auto& r : retired) r.release();
  retired.clear();
  if (!vk.vkDestroyFence) return;  // creation failed before the table was loaded
  VkDevice d = info.device;
  if (uploadFence) vk.vkDestroyFence(d, uploadFence, alloc());
  if (uploadPool) vk.vkDestroyCommandPool(d, uploadPool, alloc());
  if (environmentSetLayout) vk.vkDestroyDescriptorSetLayout(d, environmentSetLayout, alloc());
  if (environmentSampler) vk.vkDestroySampler(d, environmentSampler, alloc());
}

void Context::beginFrame() {
  ContextImpl& c = *impl_;
  ++c.frame;
  std::vector<ContextImpl::Retired> keep;
  for (auto& r : c.retired) {
    if (r.frame + c.info.framesInFlight <= c.frame) r.release();
    else keep.push_back(std::move(r));
  }
  c.retired = std::move(keep);
}

uint64_t Context::deviceMemoryBytes() const { return impl_->memoryBytes; }
size_t Context::deferredCount() const { return impl_->retired.size(); }

void Context::releaseDeferred() {
  for (auto& r : impl_->retired) r.release();
  impl_->retired.clear();
}

Result<void> Context::uploadNow(const std::function<Result<void>(VkCommandBuffer)>& record) {
  ContextImpl& c = *impl_;
  const auto& vk = c.vk;
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = c.uploadPool;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkResult r = vk.vkAllocateCommandBuffers(c.device(), &ai, &cmd);
  if (r != VK_SUCCESS) return vulkanError("vkAllocateCommandBuffers", r);
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vk.vkBeginCommandBuffer(cmd, &bi);
  // What `record` retires (its staging buffers) is read by this submission only; what was
  // retired before may still be read by the host's frames in flight and waits for beginFrame().
  const size_t retiredBefore = c.retired.size();
  Result<void> recorded = record(cmd);
  r = vk.vkEndCommandBuffer(cmd);
  if (recorded.ok() && r == VK_SUCCESS) {
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    vk.vkResetFences(c.device(), 1, &c.uploadFence);
    r = vk.vkQueueSubmit(c.info.queue, 1, &si, c.uploadFence);
    if (r == VK_SUCCESS) r = vk.vkWaitForFences(c.device(), 1, &c.uploadFence, VK_TRUE, UINT64_MAX);
  }
  vk.vkFreeCommandBuffers(c.device(), c.uploadPool, 1, &cmd);
  if (!recorded.ok()) return recorded;
  if (r != VK_SUCCESS) return vulkanError("Context::uploadNow", r);
  // The upload has completed: what it retired can go now (on failure above it waits for
  // beginFrame() like everything else, since the GPU may not be done with it).
  for (size_t i = retiredBefore; i < c.retired.size(); ++i) c.retired[i].release();
  c.retired.erase(c.retired.begin() + std::ptrdiff_t(retiredBefore), c.retired.end());
  return {};
}

uint32_t ContextImpl::findMemoryType(uint32_t typeBits, VkMemoryPropertyFlags required,
                                     VkMemoryPropertyFlags preferred) const {
  uint32_t fallback = UINT32_MAX;
  for (uint32_t i = 0; i < memoryProperties.memoryTypeCount; ++i) {
    if (!(typeBits & (1u << i))) continue;
    const VkMemoryPropertyFlags flags = memoryProperties.memoryTypes[i].propertyFlags;
    if ((flags & required) != required) continue;
    if ((flags & preferred) == preferred) return i;
    if (fallback == UINT32_MAX) fallback = i;
  }
  return fallback;
}

Result<BufferAllocation> ContextImpl::createBuffer(VkDeviceSize size, VkBufferUsageFlags usage, bool hostVisible) {
  BufferAllocation b;
  b.size = size;
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = size;
  bci.usage = usage;
  VkResult r = vk.vkCreateBuffer(device(), &bci, alloc(), &b.buffer);
  if (r != VK_SUCCESS) return vulkanError("vkCreateBuffer", r);
  VkMemoryRequirements req{};
  vk.vkGetBufferMemoryRequirements(device(), b.buffer, &req);
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex =
      hostVisible ? findMemoryType(req.memoryTypeBits,
                                   VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, 0)
                  : findMemoryType(req.memoryTypeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  if (mai.memoryTypeIndex == UINT32_MAX) {
    destroyBuffer(b);
    return makeError(ErrorCode::MissingFeature, "no suitable memory type for a buffer");
  }
  r = vk.vkAllocateMemory(device(), &mai, alloc(), &b.memory);
  if (r != VK_SUCCESS) {
    destroyBuffer(b);
    return vulkanError("vkAllocateMemory", r);
  }
  b.memoryBytes = mai.allocationSize;
  memoryBytes += b.memoryBytes;
  vk.vkBindBufferMemory(device(), b.buffer, b.memory, 0);
  if (hostVisible) {
    r = vk.vkMapMemory(device(), b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped);
    if (r != VK_SUCCESS) {
      destroyBuffer(b);
      return vulkanError("vkMapMemory", r);
    }
  }
  return b;
}

Result<BufferAllocation> ContextImpl::createUnboundBuffer(VkDeviceSize size, VkBufferUsageFlags usage) {
  BufferAllocation b;
  b.size = size;
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = size;
  bci.usage = usage;
  const VkResult r = vk.vkCreateBuffer(device(), &bci, alloc(), &b.buffer);
  if (r != VK_SUCCESS) return vulkanError("vkCreateBuffer", r);
  return b;
}

Result<MemoryBlock> ContextImpl::bindBlock(const std::vector<BufferAllocation*>& buffers) {
  std::vector<VkDeviceSize> offsets;
  VkDeviceSize end = 0;
  uint32_t typeBits = ~0u;
  for (const BufferAllocation* b : buffers) {
    VkMemoryRequirements req{};
    vk.vkGetBufferMemoryRequirements(device(), b->buffer, &req);
    const VkDeviceSize offset = (end + req.alignment - 1) / req.alignment * req.alignment;
    offsets.push_back(offset);
    end = offset + req.size;
    typeBits &= req.memoryTypeBits;
  }
  MemoryBlock block;
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = std::max<VkDeviceSize>(end, 1);
  mai.memoryTypeIndex = findMemoryType(typeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  if (mai.memoryTypeIndex == UINT32_MAX)
    return makeError(ErrorCode::MissingFeature, "no memory type suits all of an object's buffers");
  VkResult r = vk.vkAllocateMemory(device(), &mai, alloc(), &block.memory);
  if (r != VK_SUCCESS) return vulkanError("vkAllocateMemory", r);
  block.memoryBytes = mai.allocationSize;
  memoryBytes += block.memoryBytes;
  for (size_t i = 0; i < buffers.size(); ++i)
    if ((r = vk.vkBindBufferMemory(device(), buffers[i]->buffer, block.memory, offsets[i])) != VK_SUCCESS) {
      destroyBlock(block);  // the caller destroys the buffers, which no command has used yet
      return vulkanError("vkBindBufferMemory", r);
    }
  return block;
}

void ContextImpl::destroyBlock(MemoryBlock& block) {
  if (block.memory) vk.vkFreeMemory(device(), block.memory, alloc());
  memoryBytes -= block.memoryBytes;
  block = MemoryBlock{};
}

void ContextImpl::destroyBuffer(BufferAllocation& b) {
  if (b.buffer) vk.vkDestroyBuffer(device(), b.buffer, alloc());
  if (b.memory) vk.vkFreeMemory(device(), b.memory, alloc());  // unmaps implicitly
  memoryBytes -= b.memoryBytes;
  b = BufferAllocation{};
}

Result<ImageAllocation> ContextImpl::createImage(const VkImageCreateInfo& ici, VkImageViewType viewType,
                                                 VkImageAspectFlags aspect) {
  auto images = createImages({ici}, viewType, aspect);
  if (!images) return images.error();
  return images.value()[0];
}

namespace {
// Where each image goes in one allocation, its size, and the memory types all of them accept.
struct ImagePlacement {
  std::vector<VkDeviceSize> offsets;
  VkDeviceSize size = 0;
  uint32_t typeBits = ~0u;
};

ImagePlacement placeImages(const ContextImpl& c, const std::vector<ImageAllocation>& images) {
  ImagePlacement p;
  for (const ImageAllocation& img : images) {
    VkMemoryRequirements req{};
    c.vk.vkGetImageMemoryRequirements(c.device(), img.image, &req);
    const VkDeviceSize offset = (p.size + req.alignment - 1) / req.alignment * req.alignment;
    p.offsets.push_back(offset);
    p.size = offset + req.size;
    p.typeBits &= req.memoryTypeBits;
  }
  return p;
}
}  // namespace

Result<std::vector<ImageAllocation>> ContextImpl::createImages(const std::vector<VkImageCreateInfo>& infos,
                                                               VkImageViewType viewType, VkImageAspectFlags aspect) {
  std::vector<ImageAllocation> images(infos.size());
  auto fail = [&](Error e) -> Result<std::vector<ImageAllocation>> {
    for (size_t i = images.size(); i-- > 0;) destroyImage(images[i]);  // the memory's holder last
    return e;
  };
  for (size_t i = 0; i < infos.size(); ++i) {
    const VkResult r = vk.vkCreateImage(device(), &infos[i], alloc(), &images[i].image);
    if (r != VK_SUCCESS) return fail(vulkanError("vkCreateImage", r));
  }
  const ImagePlacement placement = placeImages(*this, images);
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = placement.size;
  mai.memoryTypeIndex = findMemoryType(placement.typeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  if (mai.memoryTypeIndex == UINT32_MAX) return fail(makeError(ErrorCode::MissingFeature, "no suitable memory type for an image"));
  const VkResult r = vk.vkAllocateMemory(device(), &mai, alloc(), &images[0].memory);
  if (r != VK_SUCCESS) return fail(vulkanError("vkAllocateMemory", r));
  images[0].memoryBytes = mai.allocationSize;
  memoryBytes += mai.allocationSize;
  for (size_t i = 0; i < images.size(); ++i) {
    vk.vkBindImageMemory(device(), images[i].image, images[0].memory, placement.offsets[i]);
    VkImageViewCreateInfo vci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vci.image = images[i].image;
    vci.viewType = viewType;
    vci.format = infos[i].format;
    vci.subresourceRange = {aspect, 0, infos[i].mipLevels, 0, infos[i].arrayLayers};
    const VkResult v = vk.vkCreateImageView(device(), &vci, alloc(), &images[i].view);
    if (v != VK_SUCCESS) return fail(vulkanError("vkCreateImageView", v));
  }
  return images;
}

void ContextImpl::destroyImage(ImageAllocation& img) {
  if (img.view) vk.vkDestroyImageView(device(), img.view, alloc());
  if (img.image) vk.vkDestroyImage(device(), img.image, alloc());
  if (img.memory) vk.vkFreeMemory(device(), img.memory, alloc());
  memoryBytes -= img.memoryBytes;
  img = ImageAllocation{};
}

Result<VkShaderModule> ContextImpl::createShaderModule(const uint32_t* code, size_t bytes) {
  VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  smci.codeSize = bytes;
  smci.pCode = code;
  VkShaderModule module = VK_NULL_HANDLE;
  VkResult r = vk.vkCreateShaderModule(device(), &smci, alloc(), &module);
  if (r != VK_SUCCESS) return vulkanError("vkCreateShaderModule", r);
  return module;
}

void ContextImpl::retire(std::function<void()> release) { retired.push_back({frame, std::move(release)}); }

Result<void> ContextImpl::recordBufferUpload(VkCommandBuffer cmd, VkBuffer dst, const void* data, VkDeviceSize bytes) {
  auto staging = createBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
  if (!staging) return staging.error();
  BufferAllocation s = staging.value();
  std::memcpy(s.mapped, data, bytes);
  VkBufferCopy region{0, 0, bytes};
  vk.vkCmdCopyBuffer(cmd, s.buffer, dst, 1, &region);
  retire([this, s]() mutable { destroyBuffer(s); });
  return {};
}

}  // namespace shrefract
