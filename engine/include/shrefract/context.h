// shrefract::Context: the engine's view of a host's Vulkan device.
//
// The host owns the instance, physical device, device and queue; the context borrows them and
// never destroys them. They must outlive the context and every object created from it. All Vulkan
// calls go through the host's vkGetInstanceProcAddr: the engine calls no global Vulkan symbol.
//
// Frames in flight and deferred destruction: resources the engine retires while the GPU may still
// read them (staging buffers of uploads, objects destroyed by the host) are released only after
// `framesInFlight` further calls to beginFrame(). A host that waits for the device to go idle may
// call releaseDeferred() instead.
//
// Threading: a Context and everything created from it is externally synchronized: calls that
// take the same Context must not overlap. The engine never submits to the queue itself, with one
// documented exception: Context::uploadNow(), a convenience for tools that uses its own command
// pool and fence.
#pragma once

#include <shrefract/result.h>
#include <vulkan/vulkan_core.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace shrefract {

// What the host must enable on its device before creating it (call before vkCreateDevice).
struct DeviceRequirements {
  uint32_t apiVersion = VK_API_VERSION_1_3;
  std::vector<const char*> deviceExtensions;  // none beyond Vulkan 1.3 today
  // Vulkan 1.3 features that must be VK_TRUE: dynamicRendering (raster pass into the host's
  // attachments without render-pass objects), synchronization2 (barriers), maintenance4 (our
  // shaders are SPIR-V 1.6, whose compute shaders declare their workgroup size with LocalSizeId).
  bool dynamicRendering = true;
  bool synchronization2 = true;
  bool maintenance4 = true;
  // The queue the engine records for must support graphics and compute.
  VkQueueFlags queueFlags = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
};
DeviceRequirements deviceRequirements();

struct ContextCreateInfo {
  VkInstance instance = VK_NULL_HANDLE;              // borrowed; created with apiVersion >= 1.3
  VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;  // borrowed
  VkDevice device = VK_NULL_HANDLE;                  // borrowed; created with deviceRequirements()
  uint32_t queueFamilyIndex = 0;                     // family of `queue`: graphics + compute
  VkQueue queue = VK_NULL_HANDLE;                    // borrowed; only uploadNow() submits to it
  PFN_vkGetInstanceProcAddr getInstanceProcAddr = nullptr;  // required
  const VkAllocationCallbacks* allocator = nullptr;  // optional; must outlive the context
  VkPipelineCache pipelineCache = VK_NULL_HANDLE;    // optional; borrowed
  uint32_t framesInFlight = 2;                       // 1..8
};

struct ContextImpl;  // private

class Context {
 public:
  static Result<std::unique_ptr<Context>> create(const ContextCreateInfo& info);
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  // Marks the start of a host frame: releases what was retired framesInFlight frames ago.
  // Precondition: the host has waited for the GPU work of the frame that last used this slot.
  void beginFrame();
  // Releases every retired resource now. Precondition: the device is idle for the engine's work.
  void releaseDeferred();

  // Device memory the engine holds through this context: every buffer and image allocation it
  // made and has not freed yet (retired ones included until beginFrame/releaseDeferred frees them).
  uint64_t deviceMemoryBytes() const;
  // Resources retired and not yet released (what the next beginFrame() calls will free).
  size_t deferredCount() const;

  // Records `record` into a command buffer from the engine's own pool, submits it to the
  // borrowed queue and waits on the engine's own fence. For tools and loading screens; a host
  // that wants to record uploads into its own command buffers passes them to the create calls.
  // Precondition: no other thread uses the queue during the call.
  Result<void> uploadNow(const std::function<Result<void>(VkCommandBuffer)>& record);

 private:
  friend struct ContextAccess;  // the engine's objects (engine/src)
  explicit Context(std::unique_ptr<ContextImpl> impl);
  std::unique_ptr<ContextImpl> impl_;
};

}  // namespace shrefract
