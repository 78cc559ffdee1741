// Shared by the engine's GPU tests: a context on the test harness, one-shot uploads, and the
// read-back of an object's distortion and jump images.
#pragma once

#include <shrefract/context.h>
#include <shrefract/environment.h>
#include <shrefract/renderer.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <span>
#include <vector>

#include "gpu_test_support.h"

namespace shrefract::testing {

// The harness's handles, lent to a Context; tests that need more set the rest before creating it.
inline ContextCreateInfo contextInfo(const harness::Harness& h) {
  ContextCreateInfo info;
  info.instance = h.instance();
  info.physicalDevice = h.physicalDevice();
  info.device = h.device();
  info.queueFamilyIndex = h.queueFamily();
  info.queue = h.queue();
  info.getInstanceProcAddr = vkGetInstanceProcAddr;
  return info;
}

inline Result<std::unique_ptr<Context>> createContext(const harness::Harness& h) { return Context::create(contextInfo(h)); }

inline float halfToFloat(uint16_t h) {
  const int exponent = (h >> 10) & 0x1f;
  const int mantissa = h & 0x3ff;
  float value = 0.0f;
  if (exponent == 0) value = std::ldexp(float(mantissa), -24);
  else if (exponent == 31) value = mantissa ? std::nanf("") : INFINITY;
  else value = std::ldexp(float(mantissa | 0x400), exponent - 25);
  return (h & 0x8000) ? -value : value;
}

// Copies one of the object's images of extent fieldExtent() (SHADER_READ_ONLY_OPTIMAL, as the
// engine leaves them) to the host as `bytesPerTexel` bytes a texel, and returns it to
// SHADER_READ_ONLY_OPTIMAL.
inline Result<std::vector<uint8_t>> readFieldImage(harness::Harness& h, const Object& object, VkImage image,
                                                   uint32_t bytesPerTexel) {
  const VkExtent2D extent = object.fieldExtent();
  const VkDeviceSize bytes = VkDeviceSize(extent.width) * extent.height * bytesPerTexel;
  auto staging = h.createHostBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  if (!staging) return staging.error();
  harness::Harness::Buffer buffer = staging.value();
  auto submitted = h.submitAndWait([&](VkCommandBuffer cmd) {
    VkImageMemoryBarrier2 toSrc{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
    toSrc.srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    toSrc.srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT;
    toSrc.dstStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
    toSrc.dstAccessMask = VK_ACCESS_2_TRANSFER_READ_BIT;
    toSrc.oldLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    toSrc.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    toSrc.srcQueueFamilyIndex = toSrc.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    toSrc.image = image;
    toSrc.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
    dep.imageMemoryBarrierCount = 1;
    dep.pImageMemoryBarriers = &toSrc;
    vkCmdPipelineBarrier2(cmd, &dep);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {extent.width, extent.height, 1};
    vkCmdCopyImageToBuffer(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer.buffer, 1, &region);
    VkImageMemoryBarrier2 back = toSrc;
    back.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
    back.srcAccessMask = 0;
    back.dstStageMask = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    back.dstAccessMask = 0;
    back.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    back.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    VkMemoryBarrier2 host{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
    host.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
    host.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    host.dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT;
    host.dstAccessMask = VK_ACCESS_2_HOST_READ_BIT;
    dep.pImageMemoryBarriers = &back;
    dep.memoryBarrierCount = 1;
    dep.pMemoryBarriers = &host;
    vkCmdPipelineBarrier2(cmd, &dep);
  });
  std::vector<uint8_t> out;
  if (submitted) {
    const auto* p = static_cast<const uint8_t*>(buffer.mapped);
    out.assign(p, p + bytes);
  }
  h.destroyBuffer(buffer);
  if (!submitted) return submitted.error();
  return out;
}

// The object's distortion image (RGBA16F) as floats, four a texel.
inline Result<std::vector<float>> readDistortion(harness::Harness& h, const Object& object) {
  auto bytes = readFieldImage(h, object, object.distortionImage(), 8);
  if (!bytes) return bytes.error();
  std::vector<float> out(bytes.value().size() / 2);
  for (size_t i = 0; i < out.size(); ++i) {
    uint16_t half = 0;
    std::memcpy(&half, &bytes.value()[i * 2], 2);
    out[i] = halfToFloat(half);
  }
  return out;
}

// The object's jump image (R32F), one float a texel.
inline Result<std::vector<float>> readJumpImage(harness::Harness& h, const Object& object) {
  auto bytes = readFieldImage(h, object, object.jumpImage(), 4);
  if (!bytes) return bytes.error();
  std::vector<float> out(bytes.value().size() / 4);
  std::memcpy(out.data(), bytes.value().data(), out.size() * 4);
  return out;
}

// The engine's raster pass (objects in Field mode, then the background) into the host's colour and
// depth targets, as a host records it; with `resolve`, the (multisampled) colour is
// averaged into it at the end of rendering. Both colour images end in COLOR_ATTACHMENT_OPTIMAL.
inline void recordRaster(VkCommandBuffer cmd, const harness::Harness::Image& color,
                         const harness::Harness::Image& depth, const harness::Harness::Image* resolve,
                         Renderer& renderer, const Environment& environment, const Camera& camera,
                         std::span<Object* const> objects) {
  const VkExtent2D extent{color.width, color.height};
  harness::beginRendering(cmd, color, depth, resolve);
  renderer.recordObjects(cmd, environment, camera, extent, objects, ShadingMode::Field);
  renderer.recordBackground(cmd, environment, camera, extent);
  vkCmdEndRendering(cmd);
}

}  // namespace shrefract::testing
