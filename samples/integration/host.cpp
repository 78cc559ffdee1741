#include "host.h"

#include <atomic>
#include <cstdio>
#include <type_traits>
#include <vector>

namespace integration {
namespace {

// Counts validation warnings and errors. Called by the layer, possibly from several threads.
std::atomic<uint32_t> gValidationMessages{0};
VKAPI_ATTR VkBool32 VKAPI_CALL onDebugMessage(VkDebugUtilsMessageSeverityFlagBitsEXT,
                                              VkDebugUtilsMessageTypeFlagsEXT type,
                                              const VkDebugUtilsMessengerCallbackDataEXT* data, void*) {
  if (type & (VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT)) {
    ++gValidationMessages;
    std::fprintf(stderr, "[vulkan validation] %s\n", data && data->pMessage ? data->pMessage : "(no message)");
  }
  return VK_FALSE;
}

}  // namespace

uint32_t validationMessageCount() { return gValidationMessages.load(); }

// The messenger's settings: validation warnings and errors, to onDebugMessage.
namespace {

VkDebugUtilsMessengerCreateInfoEXT messengerCreateInfo() {
  VkDebugUtilsMessengerCreateInfoEXT messengerInfo{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  messengerInfo.messageSeverity =
      VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  messengerInfo.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                              VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT;
  messengerInfo.pfnUserCallback = onDebugMessage;
  return messengerInfo;
}

}  // namespace

Host::Host() {
  const shrefract::DeviceRequirements req = shrefract::deviceRequirements();
  createInstance(req);
  pickPhysicalDevice(req);
  createDevice(req);
  createFrames();
}

void Host::createInstance(const shrefract::DeviceRequirements& req) {
  // Instance: Vulkan 1.3, validation layer and debug messenger (a host ships without them; a
  // sample and its test keep them on so that misuse of the engine's contract is reported).
  uint32_t loaderVersion = 0;
  if (vkEnumerateInstanceVersion(&loaderVersion) != VK_SUCCESS || loaderVersion < req.apiVersion)
    throw Failure{"the Vulkan loader does not offer Vulkan 1.3", 77};
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "shrefract_integration";
  app.apiVersion = req.apiVersion;
  const char* layer = "VK_LAYER_KHRONOS_validation";
  const char* debugUtils = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
  const VkDebugUtilsMessengerCreateInfoEXT messengerInfo = messengerCreateInfo();
  // Synchronization validation too: a missing or too-narrow barrier is a counted message.
  const VkValidationFeatureEnableEXT syncValidation = VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT;
  VkValidationFeaturesEXT validationFeatures{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  validationFeatures.enabledValidationFeatureCount = 1;
  validationFeatures.pEnabledValidationFeatures = &syncValidation;
  validationFeatures.pNext = &messengerInfo;  // also reports problems inside vkCreateInstance / vkDestroyInstance
  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pNext = &validationFeatures;
  ici.pApplicationInfo = &app;
  ici.enabledLayerCount = 1;
  ici.ppEnabledLayerNames = &layer;
  ici.enabledExtensionCount = 1;
  ici.ppEnabledExtensionNames = &debugUtils;
  const VkResult created = vkCreateInstance(&ici, nullptr, &instance);
  if (created == VK_ERROR_INCOMPATIBLE_DRIVER) throw Failure{"no Vulkan driver (vkCreateInstance)", 77};
  if (created == VK_ERROR_LAYER_NOT_PRESENT)
    throw Failure{"VK_LAYER_KHRONOS_validation is not installed (Debian: vulkan-validationlayers)"};
  check(created, "vkCreateInstance");
  auto createMessenger = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
      vkGetInstanceProcAddr(instance, "vkCreateDebugUtilsMessengerEXT"));
  if (!createMessenger) throw Failure{"vkCreateDebugUtilsMessengerEXT is missing"};
  check(createMessenger(instance, &messengerInfo, nullptr, &messenger), "vkCreateDebugUtilsMessengerEXT");
}

void Host::pickPhysicalDevice(const shrefract::DeviceRequirements& req) {
  // Physical device: Vulkan 1.3, the features shrefract lists, and one queue family with the
  // flags it needs (graphics + compute), which the host also uses for its own drawing.
  uint32_t count = 0;
  vkEnumeratePhysicalDevices(instance, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(instance, &count, devices.data());
  for (VkPhysicalDevice pd : devices) {
    VkPhysicalDeviceProperties props{};
    vkGetPhysicalDeviceProperties(pd, &props);
    VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    VkPhysicalDeviceFeatures2 f2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
    f2.pNext = &f13;
    if (props.apiVersion < req.apiVersion) continue;
    vkGetPhysicalDeviceFeatures2(pd, &f2);
    if ((req.dynamicRendering && !f13.dynamicRendering) || (req.synchronization2 && !f13.synchronization2) ||
        (req.maintenance4 && !f13.maintenance4))
      continue;
    uint32_t families = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &families, nullptr);
    std::vector<VkQueueFamilyProperties> qprops(families);
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &families, qprops.data());
    for (uint32_t q = 0; q < families && !physicalDevice; ++q)
      if ((qprops[q].queueFlags & req.queueFlags) == req.queueFlags) {
        physicalDevice = pd;
        queueFamily = q;
      }
    if (physicalDevice) break;
  }
  if (!physicalDevice) throw Failure{"no Vulkan 1.3 device with the features shrefract needs", 77};
}

void Host::createDevice(const shrefract::DeviceRequirements& req) {
  // Device: exactly what deviceRequirements() lists (plus whatever the host itself needs).
  float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = queueFamily;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  f13.dynamicRendering = req.dynamicRendering ? VK_TRUE : VK_FALSE;
  f13.synchronization2 = req.synchronization2 ? VK_TRUE : VK_FALSE;
  f13.maintenance4 = req.maintenance4 ? VK_TRUE : VK_FALSE;
  VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  features.pNext = &f13;
  VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.pNext = &features;
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.enabledExtensionCount = static_cast<uint32_t>(req.deviceExtensions.size());
  dci.ppEnabledExtensionNames = req.deviceExtensions.data();
  check(vkCreateDevice(physicalDevice, &dci, nullptr, &device), "vkCreateDevice");
  vkGetDeviceQueue(device, queueFamily, 0, &queue);
}

void Host::createFrames() {
  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = queueFamily;
  check(vkCreateCommandPool(device, &pci, nullptr, &pool), "vkCreateCommandPool");
  for (Frame& f : frames) {
    VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ai.commandPool = pool;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(device, &ai, &f.cmd), "vkAllocateCommandBuffers");
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    fci.flags = VK_FENCE_CREATE_SIGNALED_BIT;
    check(vkCreateFence(device, &fci, nullptr, &f.fence), "vkCreateFence");
  }
}

Host::~Host() {
  if (device) {
    vkDeviceWaitIdle(device);
    for (Frame& f : frames)
      if (f.fence) vkDestroyFence(device, f.fence, nullptr);
    if (pool) vkDestroyCommandPool(device, pool, nullptr);
    vkDestroyDevice(device, nullptr);
  }
  if (messenger) {
    auto destroyMessenger = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
    destroyMessenger(instance, messenger, nullptr);
  }
  if (instance) vkDestroyInstance(instance, nullptr);
}

uint32_t Host::memoryType(uint32_t bits, VkMemoryPropertyFlags flags) const {
  VkPhysicalDeviceMemoryProperties mp{};
  vkGetPhysicalDeviceMemoryProperties(physicalDevice, &mp);
  for (uint32_t i = 0; i < mp.memoryTypeCount; ++i)
    if ((bits & (1u << i)) && (mp.memoryTypes[i].propertyFlags & flags) == flags) return i;
  throw Failure{"no suitable memory type"};
}

Image Host::createImage(VkExtent2D extent, VkFormat format, VkImageUsageFlags usage, VkImageAspectFlags aspect) {
  Image img;
  VkImageCreateInfo ici{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ici.imageType = VK_IMAGE_TYPE_2D;
  ici.format = format;
  ici.extent = {extent.width, extent.height, 1};
  ici.mipLevels = ici.arrayLayers = 1;
  ici.samples = VK_SAMPLE_COUNT_1_BIT;
  ici.tiling = VK_IMAGE_TILING_OPTIMAL;
  ici.usage = usage;
  check(vkCreateImage(device, &ici, nullptr, &img.image), "vkCreateImage");
  VkMemoryRequirements req{};
  vkGetImageMemoryRequirements(device, img.image, &req);
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex = memoryType(req.memoryTypeBits, 0);
  check(vkAllocateMemory(device, &mai, nullptr, &img.memory), "vkAllocateMemory");
  check(vkBindImageMemory(device, img.image, img.memory, 0), "vkBindImageMemory");
  VkImageViewCreateInfo vci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  vci.image = img.image;
  vci.viewType = VK_IMAGE_VIEW_TYPE_2D;
  vci.format = format;
  vci.subresourceRange = {aspect, 0, 1, 0, 1};
  check(vkCreateImageView(device, &vci, nullptr, &img.view), "vkCreateImageView");
  return img;
}

void Host::destroy(Image& img) {
  if (img.view) vkDestroyImageView(device, img.view, nullptr);
  if (img.image) vkDestroyImage(device, img.image, nullptr);
  if (img.memory) vkFreeMemory(device, img.memory, nullptr);
  img = Image{};
}

void Host::wait(Frame& frame) {
  check(vkWaitForFences(device, 1, &frame.fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

void Host::beginRecording(Frame& frame) {
  check(vkResetFences(device, 1, &frame.fence), "vkResetFences");
  check(vkResetCommandBuffer(frame.cmd, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(frame.cmd, &bi), "vkBeginCommandBuffer");
}

void Host::submit(Frame& frame) {
  check(vkEndCommandBuffer(frame.cmd), "vkEndCommandBuffer");
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &frame.cmd;
  check(vkQueueSubmit(queue, 1, &si, frame.fence), "vkQueueSubmit");
}

namespace {

// `b` (an image or a buffer barrier) with these stages and accesses, on the one queue family,
// recorded alone.
template <class Barrier>
void recordBarrier(VkCommandBuffer cmd, Barrier b, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess) {
  b.srcStageMask = srcStage;
  b.srcAccessMask = srcAccess;
  b.dstStageMask = dstStage;
  b.dstAccessMask = dstAccess;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  if constexpr (std::is_same_v<Barrier, VkImageMemoryBarrier2>) {
    dep.imageMemoryBarrierCount = 1;
    dep.pImageMemoryBarriers = &b;
  } else {
    dep.bufferMemoryBarrierCount = 1;
    dep.pBufferMemoryBarriers = &b;
  }
  vkCmdPipelineBarrier2(cmd, &dep);
}

}  // namespace

void imageBarrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkPipelineStageFlags2 srcStage,
                  VkAccessFlags2 srcAccess, VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess,
                  VkImageLayout oldLayout, VkImageLayout newLayout) {
  VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
  b.oldLayout = oldLayout;
  b.newLayout = newLayout;
  b.image = image;
  b.subresourceRange = {aspect, 0, 1, 0, 1};
  recordBarrier(cmd, b, srcStage, srcAccess, dstStage, dstAccess);
}

void bufferBarrier(VkCommandBuffer cmd, VkBuffer buffer, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess) {
  VkBufferMemoryBarrier2 b{VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2};
  b.buffer = buffer;
  b.size = VK_WHOLE_SIZE;
  recordBarrier(cmd, b, srcStage, srcAccess, dstStage, dstAccess);
}

}  // namespace integration
