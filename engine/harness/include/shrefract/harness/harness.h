// Headless Vulkan harness for shrefract's tools and tests: it owns an instance (validation layer on
// when asked), a debug-utils messenger that counts validation and performance messages, one device
// with one graphics+compute queue, and a command pool for one-shot submissions.
//
// It plays the part of a host engine: it creates the handles that shrefract::engine borrows.
// Not part of the installed library. Lavapipe is chosen with VK_DRIVER_FILES (see tests/).
#pragma once

#include <shrefract/context.h>
#include <shrefract/field.h>
#include <shrefract/object.h>
#include <shrefract/result.h>
#include <vulkan/vulkan_core.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace shrefract::harness {

struct HarnessOptions {
  bool enableValidation = true;    // VK_LAYER_KHRONOS_validation; an error if it is missing
  // With validation: also the layer's synchronization validation (hazards between commands and
  // submissions), so that a missing or too-narrow barrier is a counted message.
  bool synchronizationValidation = true;
  int deviceIndex = -1;            // -1: first device; else an index into vkEnumeratePhysicalDevices
  bool echoMessages = true;        // print every counted message to stderr as it arrives
  std::vector<const char*> instanceExtensions;  // extra (e.g. surface extensions for a viewer)
  std::vector<const char*> deviceExtensions;    // extra (e.g. VK_KHR_swapchain)
};

// Counted validation messages. Shared with the debug messenger so that it outlives the harness:
// messages the layer emits while the device and instance are destroyed (leaked objects) land here
// after the harness is gone, and a test checks them then.
class MessageLog {
 public:
  uint32_t count() const { return count_.load(); }
  std::vector<std::string> messages() const;
  void add(std::string text);
  bool echo = true;  // print every counted message to stderr as it arrives

 private:
  mutable std::mutex mutex_;  // the debug callback may be called from any thread
  std::atomic<uint32_t> count_{0};
  std::vector<std::string> messages_;
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
  // Whether the queue writes timestamps (timestampValidBits) with a usable period.
  bool hasTimestamps() const;

  // Number of validation or performance warnings and errors seen so far (general loader chatter
  // and info/verbose messages are not counted).
  uint32_t messageCount() const { return log_->count(); }
  std::vector<std::string> messages() const { return log_->messages(); }
  // The log itself, to read after the harness is destroyed (see MessageLog).
  std::shared_ptr<const MessageLog> messageLog() const { return log_; }

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
                            VkImageAspectFlags aspect, VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT);
  void destroyImage(Image& image);

  // Reads back a VK_FORMAT_R32G32B32A32_SFLOAT or R8G8B8A8_UNORM color image that is in
  // `layout` (it is left in that layout) as linear RGBA floats.
  Result<std::vector<float>> readbackColor(const Image& image, VkImageLayout layout);
  // The bytes of mip 0, layer 0 of a colour image of `extent` with `bytesPerTexel`, in `layout`
  // (left in it) after all earlier work on the queue: what readbackColor and the tests' reads of
  // an object's images share.
  Result<std::vector<uint8_t>> readImage(VkImage image, VkExtent2D extent, uint32_t bytesPerTexel,
                                         VkImageLayout layout);

 private:
  Harness() = default;
  // Memory for `buffer` or, when it is null, `image`, of a type with `preferred` flags, else with
  // `required` ones (0: any type), bound at offset 0 into `memory`.
  Result<void> bindMemory(VkBuffer buffer, VkImage image, VkMemoryPropertyFlags preferred,
                          VkMemoryPropertyFlags required, VkDeviceMemory& memory) const;
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
  std::shared_ptr<MessageLog> log_ = std::make_shared<MessageLog>();
};

// The harness's handles as a Context borrows them (the harness must outlive the context); callers
// that need more set the rest before creating it.
ContextCreateInfo contextInfo(const Harness& h);
// Context::create(contextInfo(h)): the one way tools and tests put the engine on a harness.
Result<std::unique_ptr<Context>> createContext(const Harness& h);

// `field` as an engine object, uploaded at once (Context::uploadNow). With `volumeInDecompression`
// a Volume field traces its sample texels in the decompression pass (what the benchmarks and tests
// of that pass measure) rather than per fragment.
Result<std::unique_ptr<Object>> uploadField(Context& context, const Field& field, bool volumeInDecompression = false);

// One image memory barrier on mip 0, layers [0, layers) of `image` (the attachments and swapchain
// images of the tools and tests have one), built as the engine builds its own.
void imageBarrier(VkCommandBuffer cmd, VkImage image, VkImageAspectFlags aspect, VkPipelineStageFlags2 srcStage,
                  VkAccessFlags2 srcAccess, VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess,
                  VkImageLayout oldLayout, VkImageLayout newLayout, uint32_t layers = 1);

// One global memory barrier: the buffers of the tools and tests have no barriers of their own.
void memoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                   VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess);

// A host's frame into its own targets, as the tools, benchmarks and tests record it: `color` and
// `depth` (and `resolve`, the single-sample target of a multisampled `color`, averaged into at the
// end of rendering) go to attachment layouts with their contents dropped (all are cleared),
// ordered after the previous frame's writes and any transfer out of them on the same queue; then
// dynamic rendering begins over color's extent with viewport and scissor set. The caller records
// the engine's passes and vkCmdEndRendering.
void beginRendering(VkCommandBuffer cmd, const Harness::Image& color, const Harness::Image& depth,
                    const Harness::Image* resolve = nullptr);
// Its two halves, for a host that records something between them (the viewer's timestamps).
// The barriers: each target to its attachment layout, contents dropped, after earlier attachment
// writes and transfers (copies, blits) out of it.
void attachmentBarriers(VkCommandBuffer cmd, const Harness::Image& color, const Harness::Image& depth,
                        const Harness::Image* resolve = nullptr);
// vkCmdBeginRendering over colour's extent (all cleared), viewport and scissor set; `colorStore`
// DONT_CARE for a multisampled colour whose samples are not read after the resolve.
void beginDynamicRendering(VkCommandBuffer cmd, const Harness::Image& color, const Harness::Image& depth,
                           const Harness::Image* resolve = nullptr,
                           VkAttachmentStoreOp colorStore = VK_ATTACHMENT_STORE_OP_STORE);

}  // namespace shrefract::harness
