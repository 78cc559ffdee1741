// The viewer's swapchain: created for a surface, re-created when the window changes size. Images
// are written only by a blit (TRANSFER_DST usage), so no image views are needed.
#pragma once

#include <shrefract/result.h>
#include <vulkan/vulkan.h>

#include <vector>

namespace shrefract::viewer {

class Swapchain {
 public:
  Swapchain(VkPhysicalDevice physicalDevice, VkDevice device, VkSurfaceKHR surface)
      : physicalDevice_(physicalDevice), device_(device), surface_(surface) {}
  ~Swapchain() { destroy(); }
  Swapchain(const Swapchain&) = delete;
  Swapchain& operator=(const Swapchain&) = delete;

  // (Re)creates the swapchain. `framebuffer` is the window's framebuffer size, used where the
  // surface lets the application choose. Precondition: the device is idle for the old swapchain's
  // images (the caller waits), since their semaphores are destroyed here.
  Result<void> create(VkExtent2D framebuffer, bool vsync);
  void destroy();

  VkSwapchainKHR handle() const { return swapchain_; }
  VkFormat format() const { return format_; }
  VkExtent2D extent() const { return extent_; }
  VkPresentModeKHR presentMode() const { return presentMode_; }
  VkImage image(uint32_t index) const { return images_[index]; }
  // Signalled by the frame that renders into image `index`, waited on by its present. One per
  // image rather than per frame in flight: a semaphore handed to vkQueuePresentKHR may be in use
  // until that image is acquired again.
  VkSemaphore renderDone(uint32_t index) const { return renderDone_[index]; }

 private:
  VkPhysicalDevice physicalDevice_;
  VkDevice device_;
  VkSurfaceKHR surface_;
  VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
  VkFormat format_ = VK_FORMAT_UNDEFINED;
  VkExtent2D extent_{};
  VkPresentModeKHR presentMode_ = VK_PRESENT_MODE_FIFO_KHR;
  std::vector<VkImage> images_;
  std::vector<VkSemaphore> renderDone_;
};

}  // namespace shrefract::viewer
