// Headless Vulkan harness for shrefract's tools and tests: it owns an instance (validation layer on
// when asked), a debug-utils messenger that counts validation and performance messages, one device
// with one graphics+compute queue, and a command pool for one-shot submissions.
//
// It plays the part of a host engine: it creates the handles that shrefract::engine borrows.
// Not part of the installed library. Lavapipe is chosen with VK_DRIVER_FILES (see tests/).
#pragma once

#include <shrefract/result.h>
#include <vulkan/vulkan_core.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace shrefract::harness {

struct HarnessOptions {
  bool enableValidation = true;    // VK_LAYER_KHRONOS_validation; an error if it is missing
  int deviceIndex = -1;            // -1: first device; else an index into vkEnumeratePhysicalDevices
  bool echoMessages = true;        // print every counted message to stderr as it arrives
  std::vector<const char*> instanceExtensions;  // extra (e.g. surface extensions for a viewer)
  std::vector<const char*> deviceExtensions;    // extra (e.g. VK_KHR_swapchain)
};

// Why a harness could not be created: the tests skip on NoDevice and fail on anything else.
enum class HarnessFailure { None, NoDevice, Other };

class Harness {
 public:
  // Creates the instance and device. On failure, `failure` says whether no Vulkan device exists
  // (NoVulkan loader/ICD or zero devices) or something else went wrong.
  static Result<std::unique_ptr<Harness>> create(const HarnessOptions& options,
                                                 HarnessFailure* failure = nullptr);
  ~Harness();
  Harness(const Harness&) = delete;
  Harness& operator=(const Harness&) = delete;

  VkInstance instance() const { return instance_; }
  VkPhysicalDevice physicalDevice() const { return physicalDevice_; }
  VkDevice device() const { return device_; }
  uint32_t queueFamily() const { return queueFamily_; }
  VkQueue queue() const { return queue_; }
  const VkPhysicalDeviceProperties& properties() const { return properties_; }
  std::string deviceName() const { return properties_.deviceName; }

  // Number of validation or performance warnings and errors seen so far (general loader chatter
  // and info/verbose messages are not counted).
  uint32_t messageCount() const { return messageCount_.load(); }
  const std::vector<std::string>& messages() const { return messages_; }

  // Records with `record` into a fresh primary command buffer, submits it and waits for it.
  Result<void> submitAndWait(const std::function<void(VkCommandBuffer)>& record);

  // Memory type index with all `required` property flags among `typeBits`, or UINT32_MAX.
  uint32_t findMemoryType(uint32_t typeBits, VkMemoryPropertyFlags required) const;

  // Host-visible buffer helpers for tests and tools (coherent memory, persistently mapped).
  struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    void* mapped = nullptr;
  };
  Result<Buffer> createHostBuffer(VkDeviceSize size, VkBufferUsageFlags usage);
  void destroyBuffer(Buffer& buffer);

  // A device-local 2D image with one view, for render targets in tools and tests.
  struct Image {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
    VkFormat format = VK_FORMAT_UNDEFINED;
    uint32_t width = 0, height = 0;
  };
  Result<Image> createImage(uint32_t width, uint32_t height, VkFormat format, VkImageUsageFlags usage,
                            VkImageAspectFlags aspect);
  void destroyImage(Image& image);

  // Reads back a VK_FORMAT_R32G32B32A32_SFLOAT or R8G8B8A8_UNORM color image that is in
  // `layout` (it is left in that layout) as linear RGBA floats.
  Result<std::vector<float>> readbackColor(const Image& image, VkImageLayout layout);

 private:
  Harness() = default;
  static VKAPI_ATTR VkBool32 VKAPI_CALL debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT,
                                                      VkDebugUtilsMessageTypeFlagsEXT,
                                                      const VkDebugUtilsMessengerCallbackDataEXT*,
                                                      void*);

  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physicalDevice_ = VK_NULL_HANDLE;
  VkPhysicalDeviceProperties properties_{};
  VkDevice device_ = VK_NULL_HANDLE;
  uint32_t queueFamily_ = 0;
  VkQueue queue_ = VK_NULL_HANDLE;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  bool echo_ = true;
  std::atomic<uint32_t> messageCount_{0};
  std::vector<std::string> messages_;
};

}  // namespace shrefract::harness
