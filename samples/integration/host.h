// The integration sample's host side: what an engine has before it adds shrefract (instance with
// the validation layer, device, queue, frames in flight, images, barriers) and its error handling.
// Host-style on purpose: it uses the engine's public API only (deviceRequirements), as a host does.
#pragma once

#include <shrefract/context.h>
#include <shrefract/result.h>
#include <vulkan/vulkan.h>

#include <array>
#include <cstdint>
#include <string>

namespace integration {

// Errors: a failed step throws a Failure, which unwinds to main and prints one line. (Host code
// only: the engine itself never throws; it returns shrefract::Result values, unwrapped here.)

struct Failure {
  std::string message;
  int exitCode = 1;
};

inline void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) throw Failure{std::string(what) + " failed (VkResult " + std::to_string(r) + ")"};
}

template <class T>
T take(shrefract::Result<T>&& result, const char* what) {
  if (!result) throw Failure{std::string(what) + ": " + result.error().message};
  return std::move(result).value();
}

inline void require(const shrefract::Result<void>& result, const char* what) {
  if (!result) throw Failure{std::string(what) + ": " + result.error().message};
}

// Validation warnings and errors the layer reported so far.
uint32_t validationMessageCount();

struct Image {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
};

struct Frame {  // one frame in flight
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
};

constexpr uint32_t kFramesInFlight = 2;  // also ContextCreateInfo::framesInFlight (see beginFrame)

class Host {
 public:
  // Instance, device, queue, command pool. Throws Failure (exit code 77 when no device fits).
  Host();
  ~Host();
  Host(const Host&) = delete;
  Host& operator=(const Host&) = delete;

  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  uint32_t queueFamily = 0;
  VkQueue queue = VK_NULL_HANDLE;
  VkCommandPool pool = VK_NULL_HANDLE;
  std::array<Frame, kFramesInFlight> frames{};

  uint32_t memoryType(uint32_t bits, VkMemoryPropertyFlags flags) const;
  Image createImage(VkExtent2D extent, VkFormat format, VkImageUsageFlags usage, VkImageAspectFlags aspect);
  void destroy(Image& image);
  // Waits until the GPU is done with `frame`'s previous submission.
  void wait(Frame& frame);
  // Resets `frame` (after wait) and begins its command buffer, for one submission.
  void beginRecording(Frame& frame);
  // Ends `frame`'s command buffer and submits it, signalling its fence.
  void submit(Frame& frame);
  // Records with `record` into frames[0]'s command buffer, submits and waits: for one-off setup.
  template <class F>
  void submitNow(F&& record);

 private:
  void createInstance(const shrefract::DeviceRequirements& req);  // and the debug messenger
  void pickPhysicalDevice(const shrefract::DeviceRequirements& req);
  void createDevice(const shrefract::DeviceRequirements& req);  // and gets its queue
  void createFrames();  // the command pool, and each frame's command buffer and fence
};

// One image memory barrier on mip 0, layer 0 of `image`.
void imageBarrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkPipelineStageFlags2 srcStage,
                  VkAccessFlags2 srcAccess, VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess,
                  VkImageLayout oldLayout, VkImageLayout newLayout);
// One buffer memory barrier over the whole of `buffer`.
void bufferBarrier(VkCommandBuffer cmd, VkBuffer buffer, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess);

template <class F>
void Host::submitNow(F&& record) {
  Frame& f = frames[0];
  wait(f);
  beginRecording(f);
  record(f.cmd);
  submit(f);
  wait(f);
}

}  // namespace integration
