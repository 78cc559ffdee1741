#include "viewer/swapchain.h"

#include <algorithm>
#include <optional>
#include <string>

namespace shrefract::viewer {
namespace {

Error vkError(const char* what, VkResult r) {
  return makeError(ErrorCode::Vulkan, std::string(what) + " failed (VkResult " + std::to_string(r) + ")", r);
}

bool blitDestination(VkPhysicalDevice pd, VkFormat format) {
  VkFormatProperties props{};
  vkGetPhysicalDeviceFormatProperties(pd, format, &props);
  return (props.optimalTilingFeatures & VK_FORMAT_FEATURE_BLIT_DST_BIT) != 0;
}

// An sRGB format lets the blit encode the renderer's linear output; otherwise any format the
// surface offers that can be a blit destination (colours are then shown linear, darker).
std::optional<VkSurfaceFormatKHR> chooseFormat(VkPhysicalDevice pd, VkSurfaceKHR surface) {
  uint32_t count = 0;
  vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface, &count, nullptr);
  std::vector<VkSurfaceFormatKHR> formats(count);
  vkGetPhysicalDeviceSurfaceFormatsKHR(pd, surface, &count, formats.data());
  std::optional<VkSurfaceFormatKHR> chosen;
  for (const VkSurfaceFormatKHR& f : formats)
    if ((f.format == VK_FORMAT_B8G8R8A8_SRGB || f.format == VK_FORMAT_R8G8B8A8_SRGB) &&
        f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR && blitDestination(pd, f.format)) {
      chosen = f;
      break;
    }
  for (const VkSurfaceFormatKHR& f : formats)
    if (!chosen && blitDestination(pd, f.format)) chosen = f;
  return chosen;
}

VkPresentModeKHR choosePresentMode(VkPhysicalDevice pd, VkSurfaceKHR surface, bool vsync) {
  uint32_t count = 0;
  vkGetPhysicalDeviceSurfacePresentModesKHR(pd, surface, &count, nullptr);
  std::vector<VkPresentModeKHR> modes(count);
  vkGetPhysicalDeviceSurfacePresentModesKHR(pd, surface, &count, modes.data());
  VkPresentModeKHR mode = VK_PRESENT_MODE_FIFO_KHR;  // always supported
  if (!vsync)
    for (VkPresentModeKHR wanted : {VK_PRESENT_MODE_IMMEDIATE_KHR, VK_PRESENT_MODE_MAILBOX_KHR})
      if (mode == VK_PRESENT_MODE_FIFO_KHR && std::find(modes.begin(), modes.end(), wanted) != modes.end())
        mode = wanted;
  return mode;
}

// 0xFFFFFFFF: the surface takes the swapchain's size, so the window's framebuffer size is used.
VkExtent2D chooseExtent(const VkSurfaceCapabilitiesKHR& caps, VkExtent2D framebuffer) {
  VkExtent2D extent = caps.currentExtent;
  if (caps.currentExtent.width == UINT32_MAX) {
    extent.width = std::clamp(framebuffer.width, caps.minImageExtent.width, caps.maxImageExtent.width);
    extent.height = std::clamp(framebuffer.height, caps.minImageExtent.height, caps.maxImageExtent.height);
  }
  return extent;
}

uint32_t chooseImageCount(const VkSurfaceCapabilitiesKHR& caps) {
  uint32_t imageCount = caps.minImageCount + 1;  // one more than the minimum: acquire does not wait on present
  if (caps.maxImageCount > 0) imageCount = std::min(imageCount, caps.maxImageCount);
  return imageCount;
}

VkCompositeAlphaFlagBitsKHR chooseCompositeAlpha(const VkSurfaceCapabilitiesKHR& caps) {
  VkCompositeAlphaFlagBitsKHR alpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
  if (!(caps.supportedCompositeAlpha & alpha))
    for (VkCompositeAlphaFlagBitsKHR a : {VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR, VK_COMPOSITE_ALPHA_PRE_MULTIPLIED_BIT_KHR,
                                          VK_COMPOSITE_ALPHA_POST_MULTIPLIED_BIT_KHR})
      if (caps.supportedCompositeAlpha & a) {
        alpha = a;
        break;
      }
  return alpha;
}

}  // namespace

Result<void> Swapchain::create(VkExtent2D framebuffer, bool vsync) {
  VkSurfaceCapabilitiesKHR caps{};
  VkResult r = vkGetPhysicalDeviceSurfaceCapabilitiesKHR(physicalDevice_, surface_, &caps);
  if (r != VK_SUCCESS) return vkError("vkGetPhysicalDeviceSurfaceCapabilitiesKHR", r);
  if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT))
    return makeError(ErrorCode::MissingFeature, "the surface's images cannot be blitted to (no TRANSFER_DST usage)");

  const std::optional<VkSurfaceFormatKHR> chosen = chooseFormat(physicalDevice_, surface_);
  if (!chosen) return makeError(ErrorCode::MissingFeature, "the surface offers no format that can be a blit destination");
  presentMode_ = choosePresentMode(physicalDevice_, surface_, vsync);
  extent_ = chooseExtent(caps, framebuffer);

  VkSwapchainCreateInfoKHR sci{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  sci.surface = surface_;
  sci.minImageCount = chooseImageCount(caps);
  sci.imageFormat = chosen->format;
  sci.imageColorSpace = chosen->colorSpace;
  sci.imageExtent = extent_;
  sci.imageArrayLayers = 1;
  sci.imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  sci.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  sci.preTransform = caps.currentTransform;
  sci.compositeAlpha = chooseCompositeAlpha(caps);
  sci.presentMode = presentMode_;
  sci.clipped = VK_TRUE;
  sci.oldSwapchain = swapchain_;
  VkSwapchainKHR created = VK_NULL_HANDLE;
  r = vkCreateSwapchainKHR(device_, &sci, nullptr, &created);
  destroy();  // the old one is retired either way
  if (r != VK_SUCCESS) return vkError("vkCreateSwapchainKHR", r);
  swapchain_ = created;
  format_ = chosen->format;

  uint32_t count = 0;
  vkGetSwapchainImagesKHR(device_, swapchain_, &count, nullptr);
  images_.resize(count);
  vkGetSwapchainImagesKHR(device_, swapchain_, &count, images_.data());
  renderDone_.assign(count, VK_NULL_HANDLE);
  for (VkSemaphore& s : renderDone_) {
    VkSemaphoreCreateInfo info{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    if ((r = vkCreateSemaphore(device_, &info, nullptr, &s)) != VK_SUCCESS) return vkError("vkCreateSemaphore", r);
  }
  return {};
}

void Swapchain::destroy() {
  for (VkSemaphore s : renderDone_)
    if (s) vkDestroySemaphore(device_, s, nullptr);
  renderDone_.clear();
  images_.clear();
  if (swapchain_) vkDestroySwapchainKHR(device_, swapchain_, nullptr);
  swapchain_ = VK_NULL_HANDLE;
}

}  // namespace shrefract::viewer
