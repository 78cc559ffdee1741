#include <shrefract/harness/harness.h>

#include <cstdio>
#include <cstring>
#include <mutex>
#include <string>

#include "core/image_barrier.h"
#include "core/image_info.h"

namespace shrefract::harness {
namespace {

Error vkError(const char* what, VkResult r) {
  return makeError(ErrorCode::Vulkan, std::string(what) + " failed (VkResult " + std::to_string(r) + ")", r);
}

bool hasLayer(const char* name) {
  uint32_t count = 0;
  vkEnumerateInstanceLayerProperties(&count, nullptr);
  std::vector<VkLayerProperties> layers(count);
  vkEnumerateInstanceLayerProperties(&count, layers.data());
  for (const auto& l : layers)
    if (std::strcmp(l.layerName, name) == 0) return true;
  return false;
}

// A NoDevice failure: tools map its code to their exit code (Harness::create reports it as
// HarnessFailure::NoDevice, every other error as HarnessFailure::Other).
Error noDevice(Error e) {
  e.code = ErrorCode::NoDevice;
  return e;
}

// The validation layer and the debug-utils extension it reports through, when validation is on.
Result<void> addValidationLayer(const HarnessOptions& options, std::vector<const char*>& layers,
                                std::vector<const char*>& extensions) {
  if (!options.enableValidation) return {};
  if (!hasLayer("VK_LAYER_KHRONOS_validation"))
    return makeError(ErrorCode::MissingFeature,
                     "VK_LAYER_KHRONOS_validation is not installed (Debian: vulkan-validationlayers)");
  layers.push_back("VK_LAYER_KHRONOS_validation");
  extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  return {};
}

VkDebugUtilsMessengerCreateInfoEXT messengerCreateInfo(PFN_vkDebugUtilsMessengerCallbackEXT callback, void* user) {
  VkDebugUtilsMessengerCreateInfoEXT messengerInfo{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  messengerInfo.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                                  VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  messengerInfo.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                              VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                              VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  messengerInfo.pfnUserCallback = callback;
  messengerInfo.pUserData = user;
  return messengerInfo;
}

Result<void> createInstance(const HarnessOptions& options, const std::vector<const char*>& layers,
                            const std::vector<const char*>& extensions,
                            const VkDebugUtilsMessengerCreateInfoEXT& messengerInfo, VkInstance& instance) {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "shrefract";
  app.pEngineName = "shrefract";
  app.apiVersion = VK_API_VERSION_1_3;

  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pApplicationInfo = &app;
  ici.enabledLayerCount = static_cast<uint32_t>(layers.size());
  ici.ppEnabledLayerNames = layers.data();
  ici.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  ici.ppEnabledExtensionNames = extensions.data();
  // Chained so that messages from vkCreateInstance/vkDestroyInstance are counted too.
  VkValidationFeatureEnableEXT syncValidation = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT;
  VkValidationFeaturesEXT validationFeatures{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  validationFeatures.enabledValidationFeatureCount = options.synchronizationValidation ? 1u : 0u;
  validationFeatures.pEnabledValidationFeatures = &syncValidation;
  if (options.enableValidation) {
    validationFeatures.pNext = &messengerInfo;
    ici.pNext = &validationFeatures;
  }
  VkResult r = vkCreateInstance(&ici, nullptr, &instance);
  if (r == VK_ERROR_INCOMPATIBLE_DRIVER) return noDevice(vkError("vkCreateInstance (no Vulkan driver)", r));
  if (r != VK_SUCCESS) return vkError("vkCreateInstance", r);
  return {};
}

Result<void> createMessenger(VkInstance instance, const VkDebugUtilsMessengerCreateInfoEXT& messengerInfo,
                             VkDebugUtilsMessengerEXT& messenger) {
  auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
      vkGetInstanceProcAddr(instance, "vkCreateDebugUtilsMessengerEXT"));
  if (!create || create(instance, &messengerInfo, nullptr, &messenger) != VK_SUCCESS)
    return makeError(ErrorCode::Vulkan, "cannot create the debug-utils messenger");
  return {};
}

// The devices Harness::create may pick from: the one options.deviceIndex names, else all of them.
Result<std::vector<VkPhysicalDevice>> candidateDevices(VkInstance instance, const HarnessOptions& options) {
  uint32_t count = 0;
  vkEnumeratePhysicalDevices(instance, &count, nullptr);
  if (count == 0) return noDevice(makeError(ErrorCode::MissingFeature, "no Vulkan physical device"));
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(instance, &count, devices.data());
  if (options.deviceIndex >= static_cast<int>(count))
    return makeError(ErrorCode::InvalidArgument, "device index " + std::to_string(options.deviceIndex) +
                                                     " out of range (" + std::to_string(count) + " devices)");
  std::vector<VkPhysicalDevice> candidates;
  if (options.deviceIndex >= 0) candidates.push_back(devices[static_cast<size_t>(options.deviceIndex)]);
  else candidates = devices;
  return candidates;
}

struct DeviceChoice {
  VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
  VkPhysicalDeviceProperties properties{};
  uint32_t queueFamily = 0;
};

// The first Vulkan 1.3 candidate with a queue family that does both graphics and compute.
Result<DeviceChoice> chooseDevice(const std::vector<VkPhysicalDevice>& candidates) {
  for (VkPhysicalDevice pd : candidates) {
    VkPhysicalDeviceProperties props{};
    vkGetPhysicalDeviceProperties(pd, &props);
    if (props.apiVersion < VK_API_VERSION_1_3) continue;
    uint32_t qcount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &qcount, nullptr);
    std::vector<VkQueueFamilyProperties> qprops(qcount);
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &qcount, qprops.data());
    for (uint32_t q = 0; q < qcount; ++q) {
      const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
      if ((qprops[q].queueFlags & need) == need) return DeviceChoice{pd, props, q};
    }
  }
  return noDevice(makeError(ErrorCode::MissingFeature, "no Vulkan 1.3 device with a graphics+compute queue"));
}

Result<void> createDevice(const DeviceChoice& choice, const HarnessOptions& options, VkDevice& device) {
  float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = choice.queueFamily;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;

  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  f13.dynamicRendering = VK_TRUE;
  f13.synchronization2 = VK_TRUE;
  f13.maintenance4 = VK_TRUE;  // SPIR-V 1.6 compute shaders declare LocalSizeId
  VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  features.pNext = &f13;

  VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.pNext = &features;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = static_cast<uint32_t>(options.deviceExtensions.size());
  dci.ppEnabledExtensionNames = options.deviceExtensions.data();
  VkResult r = vkCreateDevice(choice.physicalDevice, &dci, nullptr, &device);
  if (r != VK_SUCCESS) return vkError("vkCreateDevice", r);
  return {};
}

// The command pool and fence of submitAndWait.
Result<void> createSubmitObjects(VkDevice device, uint32_t queueFamily, VkCommandPool& pool, VkFence& fence) {
  VkResult r = VK_SUCCESS;
  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = queueFamily;
  if ((r = vkCreateCommandPool(device, &pci, nullptr, &pool)) != VK_SUCCESS) return vkError("vkCreateCommandPool", r);
  VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  if ((r = vkCreateFence(device, &fci, nullptr, &fence)) != VK_SUCCESS) return vkError("vkCreateFence", r);
  return {};
}

}  // namespace

VKAPI_ATTR VkBool32 VKAPI_CALL Harness::debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                      VkDebugUtilsMessageTypeFlagsEXT type,
                                                      const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                      void* user) {
  auto* log = static_cast<MessageLog*>(user);
  // General messages are loader chatter; info and verbose severities are not problems.
  const bool relevantType = (type & (VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                                     VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT)) != 0;
  const bool relevantSeverity = severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT;
  if (!relevantType || !relevantSeverity) return VK_FALSE;
  log->add(data && data->pMessage ? data->pMessage : "(no message)");
  return VK_FALSE;
}

std::vector<std::string> MessageLog::messages() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return messages_;
}

void MessageLog::add(std::string text) {
  if (echo) std::fprintf(stderr, "[vulkan validation] %s\n", text.c_str());
  std::lock_guard<std::mutex> lock(mutex_);
  messages_.push_back(std::move(text));
  count_.fetch_add(1);
}

Result<std::unique_ptr<Harness>> Harness::create(const HarnessOptions& options, HarnessFailure* failure) {
  auto fail = [&](Error e) -> Result<std::unique_ptr<Harness>> {
    if (failure) *failure = e.code == ErrorCode::NoDevice ? HarnessFailure::NoDevice : HarnessFailure::Other;
    return e;
  };
  if (failure) *failure = HarnessFailure::None;
  std::unique_ptr<Harness> h(new Harness());
  h->log_->echo = options.echoMessages;

  uint32_t apiVersion = 0;
  if (vkEnumerateInstanceVersion(&apiVersion) != VK_SUCCESS || apiVersion < VK_API_VERSION_1_3)
    return fail(noDevice(makeError(ErrorCode::MissingFeature, "the Vulkan loader does not offer Vulkan 1.3")));

  std::vector<const char*> layers;
  std::vector<const char*> extensions = options.instanceExtensions;
  if (auto added = addValidationLayer(options, layers, extensions); !added) return fail(added.error());
  // The user data is h's log: the instance's last messages arrive during ~Harness.
  const VkDebugUtilsMessengerCreateInfoEXT messengerInfo = messengerCreateInfo(&Harness::debugCallback, h->log_.get());
  if (auto created = createInstance(options, layers, extensions, messengerInfo, h->instance_); !created)
    return fail(created.error());
  if (options.enableValidation)
    if (auto created = createMessenger(h->instance_, messengerInfo, h->messenger_); !created)
      return fail(created.error());

  auto candidates = candidateDevices(h->instance_, options);
  if (!candidates) return fail(candidates.error());
  auto choice = chooseDevice(candidates.value());
  if (!choice) return fail(choice.error());
  h->physicalDevice_ = choice.value().physicalDevice;
  h->properties_ = choice.value().properties;
  h->queueFamily_ = choice.value().queueFamily;

  if (auto created = createDevice(choice.value(), options, h->device_); !created) return fail(created.error());
  vkGetDeviceQueue(h->device_, h->queueFamily_, 0, &h->queue_);
  if (auto created = createSubmitObjects(h->device_, h->queueFamily_, h->pool_, h->fence_); !created)
    return fail(created.error());
  return h;
}

Harness::~Harness() {
  if (device_) {
    vkDeviceWaitIdle(device_);
    if (fence_) vkDestroyFence(device_, fence_, nullptr);
    if (pool_) vkDestroyCommandPool(device_, pool_, nullptr);
    vkDestroyDevice(device_, nullptr);
  }
  if (messenger_) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy) destroy(instance_, messenger_, nullptr);
  }
  if (instance_) vkDestroyInstance(instance_, nullptr);
}

Result<void> Harness::submitAndWait(const std::function<void(VkCommandBuffer)>& record) {
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = pool_;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkResult r = vkAllocateCommandBuffers(device_, &ai, &cmd);
  if (r != VK_SUCCESS) return vkError("vkAllocateCommandBuffers", r);
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vkBeginCommandBuffer(cmd, &bi);
  record(cmd);
  r = vkEndCommandBuffer(cmd);
  if (r == VK_SUCCESS) {
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    vkResetFences(device_, 1, &fence_);
    r = vkQueueSubmit(queue_, 1, &si, fence_);
    if (r == VK_SUCCESS) r = vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX);
  }
  vkFreeCommandBuffers(device_, pool_, 1, &cmd);
  if (r != VK_SUCCESS) return vkError("submitAndWait", r);
  return {};
}

bool Harness::hasTimestamps() const {
  uint32_t count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physicalDevice_, &count, nullptr);
  std::vector<VkQueueFamilyProperties> families(count);
  vkGetPhysicalDeviceQueueFamilyProperties(physicalDevice_, &count, families.data());
  return queueFamily_ < count && families[queueFamily_].timestampValidBits > 0 &&
         properties_.limits.timestampPeriod > 0.0f;
}

uint32_t Harness::findMemoryType(uint32_t typeBits, VkMemoryPropertyFlags required) const {
  VkPhysicalDeviceMemoryProperties mp{};
  vkGetPhysicalDeviceMemoryProperties(physicalDevice_, &mp);
  for (uint32_t i = 0; i < mp.memoryTypeCount; ++i)
    if ((typeBits & (1u << i)) && (mp.memoryTypes[i].propertyFlags & required) == required) return i;
  return UINT32_MAX;
}

Result<void> Harness::bindMemory(VkBuffer buffer, VkImage image, VkMemoryPropertyFlags preferred,
                                 VkMemoryPropertyFlags required, VkDeviceMemory& memory) const {
  VkMemoryRequirements req{};
  if (buffer) vkGetBufferMemoryRequirements(device_, buffer, &req);
  else vkGetImageMemoryRequirements(device_, image, &req);
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = findMemoryType(req.memoryTypeBits, preferred);
  if (mai.memoryTypeIndex == UINT32_MAX) mai.memoryTypeIndex = findMemoryType(req.memoryTypeBits, required);
  if (mai.memoryTypeIndex == UINT32_MAX)
    return makeError(ErrorCode::MissingFeature, "no memory type with the flags " + std::to_string(required));
  VkDeviceMemory allocated = VK_NULL_HANDLE;  // `memory` stays null on failure
  if (VkResult r = vkAllocateMemory(device_, &mai, nullptr, &allocated); r != VK_SUCCESS)
    return vkError("vkAllocateMemory", r);
  memory = allocated;
  if (buffer) vkBindBufferMemory(device_, buffer, memory, 0);
  else vkBindImageMemory(device_, image, memory, 0);
  return {};
}

Result<Harness::Buffer> Harness::createHostBuffer(VkDeviceSize size, VkBufferUsageFlags usage) {
  Buffer b;
  b.size = size;
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = size;
  bci.usage = usage;
  VkResult r = vkCreateBuffer(device_, &bci, nullptr, &b.buffer);
  if (r != VK_SUCCESS) return vkError("vkCreateBuffer", r);
  const VkMemoryPropertyFlags hostFlags = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  if (auto bound = bindMemory(b.buffer, VK_NULL_HANDLE, hostFlags, hostFlags, b.memory); !bound) {
    destroyBuffer(b);
    return bound.error();
  }
  vkMapMemory(device_, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped);
  return b;
}

void Harness::destroyBuffer(Buffer& b) {
  if (b.buffer) vkDestroyBuffer(device_, b.buffer, nullptr);
  if (b.memory) vkFreeMemory(device_, b.memory, nullptr);
  b = Buffer{};
}

Result<Harness::Image> Harness::createImage(uint32_t width, uint32_t height, VkFormat format,
                                            VkImageUsageFlags usage, VkImageAspectFlags aspect,
                                            VkSampleCountFlagBits samples) {
  Image img;
  img.format = format;
  img.width = width;
  img.height = height;
  const VkImageCreateInfo ici = imageInfo2D(format, width, height, usage, samples);
  VkResult r = vkCreateImage(device_, &ici, nullptr, &img.image);
  if (r != VK_SUCCESS) return vkError("vkCreateImage", r);
  auto bound = bindMemory(VK_NULL_HANDLE, img.image, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0, img.memory);
  if (!bound) {
    destroyImage(img);
    return bound.error();
  }
  VkImageViewCreateInfo vci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vci.image = img.image;
  vci.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vci.format = format;
  vci.subresourceRange = {aspect, 0, 1, 0, 1};
  if ((r = vkCreateImageView(device_, &vci, nullptr, &img.view)) != VK_SUCCESS) {
    destroyImage(img);
    return vkError("vkCreateImageView", r);
  }
  return img;
}

void Harness::destroyImage(Image& img) {
  if (img.view) vkDestroyImageView(device_, img.view, nullptr);
  if (img.image) vkDestroyImage(device_, img.image, nullptr);
  if (img.memory) vkFreeMemory(device_, img.memory, nullptr);
  img = Image{};
}

Result<std::vector<uint8_t>> Harness::readImage(VkImage image, VkExtent2D extent, uint32_t bytesPerTexel,
                                                VkImageLayout layout) {
  const VkDeviceSize bytes = VkDeviceSize(extent.width) * extent.height * bytesPerTexel;
  auto staging = createHostBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  if (!staging) return staging.error();
  Buffer buf = staging.value();
  auto submitted = submitAndWait([&](VkCommandBuffer cmd) {
    imageBarrier(cmd, image, VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                 VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT, layout,
                 VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {extent.width, extent.height, 1};
    vkCmdCopyImageToBuffer(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buf.buffer, 1, &region);
    // Back to `layout` for whatever comes next, and the copy's writes made visible to the host.
    imageBarrier(cmd, image, VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_COPY_BIT, 0,
                 VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT,
                 VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, layout);
    memoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                  VK_ACCESS_2_HOST_READ_BIT);
  });
  std::vector<uint8_t> out;
  if (submitted) {
    const auto* p = static_cast<const uint8_t*>(buf.mapped);
    out.assign(p, p + bytes);
  }
  destroyBuffer(buf);
  if (!submitted) return submitted.error();
  return out;
}

Result<std::vector<float>> Harness::readbackColor(const Image& img, VkImageLayout layout) {
  uint32_t texel = 0;
  if (img.format == VK_FORMAT_R32G32B32A32_SFLOAT) texel = 16;
  else if (img.format == VK_FORMAT_R8G8B8A8_UNORM) texel = 4;
  else return makeError(ErrorCode::Unsupported, "readbackColor: unsupported format");
  auto bytes = readImage(img.image, {img.width, img.height}, texel, layout);
  if (!bytes) return bytes.error();
  std::vector<float> out(size_t(img.width) * img.height * 4);
  if (texel == 16) {
    std::memcpy(out.data(), bytes.value().data(), out.size() * sizeof(float));
  } else {
    for (size_t i = 0; i < out.size(); ++i) out[i] = static_cast<float>(bytes.value()[i]) / 255.0f;
  }
  return out;
}

ContextCreateInfo contextInfo(const Harness& h) {
  ContextCreateInfo info;
  info.instance = h.instance();
  info.physicalDevice = h.physicalDevice();
  info.device = h.device();
  info.queueFamilyIndex = h.queueFamily();
  info.queue = h.queue();
  info.getInstanceProcAddr = vkGetInstanceProcAddr;
  return info;
}

Result<std::unique_ptr<Context>> createContext(const Harness& h) { return Context::create(contextInfo(h)); }

Result<std::unique_ptr<Object>> uploadField(Context& context, const Field& field, bool volumeInDecompression) {
  std::unique_ptr<Object> object;
  auto uploaded = context.uploadNow([&](VkCommandBuffer cmd) -> Result<void> {
    auto created = Object::createFromField(context, field, cmd);
    if (!created) return created.error();
    object = std::move(created).value();
    if (volumeInDecompression && field.encoding == Encoding::Volume) (void)object->setTracesVolumePerFragment(false);
    return {};
  });
  if (!uploaded) return uploaded.error();
  return object;
}

void imageBarrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkPipelineStageFlags2 srcStage,
                  VkAccessFlags2 srcAccess, VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess,
                  VkImageLayout oldLayout, VkImageLayout newLayout, uint32_t layers) {
  const VkImageMemoryBarrier2 b = shrefract::imageBarrier(
      image, {srcStage, srcAccess, dstStage, dstAccess, oldLayout, newLayout}, 0, 1, layers, aspect);
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.imageMemoryBarrierCount = 1;
  dep.pImageMemoryBarriers = &b;
  vkCmdPipelineBarrier2(cmd, &dep);
}

void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess) {
  VkMemoryBarrier2 m{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  m.srcStageMask = srcStage;
  m.srcAccessMask = srcAccess;
  m.dstStageMask = dstStage;
  m.dstAccessMask = dstAccess;
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &m;
  vkCmdPipelineBarrier2(cmd, &dep);
}

void attachmentBarriers(VkCommandBuffer cmd, const Harness::Image& color, const Harness::Image& depth,
                        const Harness::Image* resolve) {
  const VkPipelineStageFlags2 colorStage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
  // A colour target may have been copied or blitted out since its last frame.
  const VkPipelineStageFlags2 colorAfter = colorStage | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
  const VkPipelineStageFlags2 depthStages =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  // Every target goes from UNDEFINED: its contents are dropped (all are cleared).
  const VkAccessFlags2 colorAccess = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
  const VkAccessFlags2 depthAccess =
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  for (const Harness::Image* target : {&color, resolve})
    if (target)
      imageBarrier(cmd, target->image, VK_IMAGE_ASPECT_COLOR_BIT, colorAfter, colorAccess, colorStage, colorAccess,
                   VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
  imageBarrier(cmd, depth.image, VK_IMAGE_ASPECT_DEPTH_BIT, depthStages, depthAccess, depthStages, depthAccess,
               VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
}

void beginRendering(VkCommandBuffer cmd, const Harness::Image& color, const Harness::Image& depth,
                    const Harness::Image* resolve) {
  attachmentBarriers(cmd, color, depth, resolve);
  beginDynamicRendering(cmd, color, depth, resolve);
}

void beginDynamicRendering(VkCommandBuffer cmd, const Harness::Image& color, const Harness::Image& depth,
                           const Harness::Image* resolve, VkAttachmentStoreOp colorStore) {
  const VkExtent2D extent{color.width, color.height};
  VkRenderingAttachmentInfo colorAttachment{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  colorAttachment.imageView = color.view;
  colorAttachment.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  colorAttachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  colorAttachment.storeOp = colorStore;
  if (resolve) {
    colorAttachment.resolveMode = VK_RESOLVE_MODE_AVERAGE_BIT;
    colorAttachment.resolveImageView = resolve->view;
    colorAttachment.resolveImageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  }
  VkRenderingAttachmentInfo depthAttachment{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAttachment.imageView = depth.view;
  depthAttachment.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depthAttachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  depthAttachment.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  depthAttachment.clearValue.depthStencil = {1.0f, 0};
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, extent};
  ri.layerCount = 1;
  ri.colorAttachmentCount = 1;
  ri.pColorAttachments = &colorAttachment;
  ri.pDepthAttachment = &depthAttachment;
  vkCmdBeginRendering(cmd, &ri);
  const VkViewport viewport{0.0f, 0.0f, float(extent.width), float(extent.height), 0.0f, 1.0f};
  const VkRect2D scissor{{0, 0}, extent};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

}  // namespace shrefract::harness
