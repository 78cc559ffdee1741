#include <shrefract/environment.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/barriers.h"
#include "core/half.h"
#include "core/image_info.h"
#include "environment/environment_impl.h"
#include "environment/latlong.h"

namespace shrefract {

namespace {

// Converts linear RGBA floats to half, rejecting NaN, Inf and negative values. `what` names the
// image in the message; `width` locates the bad pixel.
Result<void> toHalf(const float* rgba, size_t texels, uint32_t width, const std::string& what,
                    uint16_t* out) {
  for (size_t i = 0; i < texels * 4; ++i) {
    const float v = rgba[i];
    if (!std::isfinite(v) || v < 0.0f)
      return makeError(ErrorCode::InvalidArgument, what + ": pixel " + std::to_string((i / 4) % width) + "," +
                                                       std::to_string((i / 4) / width) +
                                                       " is negative, NaN or infinite");
    out[i] = floatToHalf(v);
  }
  return {};
}

// The RGBA16F image (layers == 6: cube) with room for its level chain.
Result<ImageAllocation> createEnvironmentImage(ContextImpl& c, bool cube, uint32_t width, uint32_t height) {
  // TRANSFER_SRC: each level is blitted from the one above (RGBA16F supports BLIT_SRC, BLIT_DST
  // and linear filtering with optimal tiling on every Vulkan device: a mandatory format).
  VkImageCreateInfo ici =
      imageInfo2D(VK_FORMAT_R16G16B16A16_SFLOAT, width, height,
                  VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
  ici.flags = cube ? VkImageCreateFlags{VK_IMAGE_CREATE_CUBE_COMPATIBLE_BIT} : VkImageCreateFlags{0};
  ici.mipLevels = environmentLevelCount(width, height);
  ici.arrayLayers = cube ? 6u : 1u;
  return c.createImage(ici, cube ? VK_IMAGE_VIEW_TYPE_CUBE : VK_IMAGE_VIEW_TYPE_2D, VK_IMAGE_ASPECT_COLOR_BIT);
}

Result<VkSampler> createCubeSampler(ContextImpl& c) {
  // Cube lookups are seamless; the address modes only matter at face edges, where Vulkan
  // filters across faces regardless.
  VkSamplerCreateInfo sci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  sci.magFilter = VK_FILTER_LINEAR;
  sci.minFilter = VK_FILTER_LINEAR;
  sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;  // the shaders pick fractional levels
  sci.maxLod = VK_LOD_CLAMP_NONE;
  sci.addressModeU = sci.addressModeV = sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  VkSampler sampler = VK_NULL_HANDLE;
  const VkResult r = c.vk.vkCreateSampler(c.device(), &sci, c.alloc(), &sampler);
  if (r != VK_SUCCESS) return vulkanError("vkCreateSampler", r);
  return sampler;
}

// The level chain: level l is level l - 1 blitted with a linear filter to half its size, which is
// the 2x2 box of its texels where the size is even (cpu_reference.h environmentLevels mirrors it).
// A lat-long map's box never straddles the seam (even widths pair texels 2i, 2i + 1 of one side)
// nor the poles (rows pair within a hemisphere); the sampler's repeat in u joins the seam when
// sampling, at every level. Cube faces are filtered each on its own (one blit per level covers
// the six layers); seamless cube sampling joins their edges. Each level is read as TRANSFER_SRC
// once written, then all of them go to SHADER_READ_ONLY together (recordLevelsReadable).
void recordLevelBlits(ContextImpl& c, VkCommandBuffer cmd, VkImage image, uint32_t width, uint32_t height,
                      uint32_t levels, uint32_t layers) {
  const ImageTransition toSrc{VK_PIPELINE_STAGE_2_COPY_BIT | VK_PIPELINE_STAGE_2_BLIT_BIT,
                              VK_ACCESS_2_TRANSFER_WRITE_BIT,
                              VK_PIPELINE_STAGE_2_BLIT_BIT,
                              VK_ACCESS_2_TRANSFER_READ_BIT,
                              VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                              VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL};
  for (uint32_t level = 1; level < levels; ++level) {
    const VkImageMemoryBarrier2 b = imageBarrier(image, toSrc, level - 1, 1, layers);
    recordBarriers(c, cmd, {&b, 1});
    VkImageBlit blit{};
    blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level - 1, 0, layers};
    blit.srcOffsets[1] = {int32_t(std::max(1u, width >> (level - 1))), int32_t(std::max(1u, height >> (level - 1))), 1};
    blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, layers};
    blit.dstOffsets[1] = {int32_t(std::max(1u, width >> level)), int32_t(std::max(1u, height >> level)), 1};
    c.vk.vkCmdBlitImage(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                        1, &blit, VK_FILTER_LINEAR);
  }
}

// Levels 0 .. levels - 2 are TRANSFER_SRC (read by a blit), the last is TRANSFER_DST (written by
// the copy or the last blit): all of them to SHADER_READ_ONLY for the passes.
void recordLevelsReadable(ContextImpl& c, VkCommandBuffer cmd, VkImage image, uint32_t levels, uint32_t layers) {
  const VkPipelineStageFlags2 written = VK_PIPELINE_STAGE_2_COPY_BIT | VK_PIPELINE_STAGE_2_BLIT_BIT;
  const VkPipelineStageFlags2 read = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  const VkImageMemoryBarrier2 toRead[2] = {
      imageBarrier(image,
                   {written, VK_ACCESS_2_TRANSFER_READ_BIT, read, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                    VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
                   0, levels - 1, layers),
      imageBarrier(image,
                   {written, VK_ACCESS_2_TRANSFER_WRITE_BIT, read, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                    VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
                   levels - 1, 1, layers)};
  recordBarriers(c, cmd, levels > 1 ? std::span<const VkImageMemoryBarrier2>(toRead, 2)
                                    : std::span<const VkImageMemoryBarrier2>(&toRead[1], 1));
}

// Records the upload of `half` (layer-major, level 0) through a staging buffer retired with the
// frame, the blits that fill levels 1.. and the transition of every level to SHADER_READ_ONLY.
Result<void> recordUploadAndLevels(ContextImpl& c, VkCommandBuffer cmd, VkImage image, uint32_t width,
                                   uint32_t height, uint32_t layers, const std::vector<uint16_t>& half) {
  const VkDeviceSize bytes = half.size() * sizeof(uint16_t);
  auto staging = c.createBuffer(bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
  if (!staging) return staging.error();
  BufferAllocation s = staging.value();
  std::memcpy(s.mapped, half.data(), bytes);
  c.retire([&c, s]() mutable { c.destroyBuffer(s); });

  const uint32_t levels = environmentLevelCount(width, height);
  const VkImageMemoryBarrier2 toDst =
      imageBarrier(image,
                   {VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_COPY_BIT | VK_PIPELINE_STAGE_2_BLIT_BIT,
                    VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL},
                   0, levels, layers);
  recordBarriers(c, cmd, {&toDst, 1});
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, layers};
  region.imageExtent = {width, height, 1};
  c.vk.vkCmdCopyBufferToImage(cmd, s.buffer, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  recordLevelBlits(c, cmd, image, width, height, levels, layers);
  recordLevelsReadable(c, cmd, image, levels, layers);
  return {};
}

// The environment's descriptor set: its own pool and one combined image sampler.
Result<void> writeEnvironmentSet(ContextImpl& c, EnvironmentImpl& e, VkSampler sampler) {
  VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1};
  VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = 1;
  dpci.poolSizeCount = 1;
  dpci.pPoolSizes = &size;
  VkResult r = c.vk.vkCreateDescriptorPool(c.device(), &dpci, c.alloc(), &e.pool);
  if (r != VK_SUCCESS) return vulkanError("vkCreateDescriptorPool", r);
  VkDescriptorSetAllocateInfo dsai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  dsai.descriptorPool = e.pool;
  dsai.descriptorSetCount = 1;
  dsai.pSetLayouts = &c.environmentSetLayout;
  r = c.vk.vkAllocateDescriptorSets(c.device(), &dsai, &e.set);
  if (r != VK_SUCCESS) return vulkanError("vkAllocateDescriptorSets", r);
  VkDescriptorImageInfo dii{sampler, e.image.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  w.dstSet = e.set;
  w.dstBinding = 0;
  w.descriptorCount = 1;
  w.descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  w.pImageInfo = &dii;
  c.vk.vkUpdateDescriptorSets(c.device(), 1, &w, 0, nullptr);
  return {};
}

// Creates the RGBA16F image (layers == 6: cube) with its level chain, records the upload of `half`
// (layer-major, level 0), the blits that fill levels 1.. (environmentLevelCount) and the transition
// of every level to SHADER_READ_ONLY_OPTIMAL, and writes the descriptor set.
Result<std::unique_ptr<Environment>> createEnvironment(ContextImpl& c, EnvironmentEncoding encoding, uint32_t width,
                                                       uint32_t height, const std::vector<uint16_t>& half,
                                                       VkCommandBuffer cmd,
                                                       std::unique_ptr<Environment> (*wrap)(std::unique_ptr<EnvironmentImpl>)) {
  const bool cube = encoding == EnvironmentEncoding::Cube;
  auto impl = std::make_unique<EnvironmentImpl>();
  impl->context = &c;
  impl->encoding = encoding;
  impl->width = width;
  impl->height = height;
  auto image = createEnvironmentImage(c, cube, width, height);
  if (!image) return image.error();
  impl->image = image.value();
  std::unique_ptr<Environment> env = wrap(std::move(impl));
  EnvironmentImpl& e = EnvironmentAccess::impl(*env);
  VkSampler sampler = c.environmentSampler;
  if (cube) {
    auto cubeSampler = createCubeSampler(c);
    if (!cubeSampler) return cubeSampler.error();
    sampler = e.cubeSampler = cubeSampler.value();
  }
  if (auto r = recordUploadAndLevels(c, cmd, e.image.image, width, height, cube ? 6u : 1u, half); !r) return r.error();
  if (auto r = writeEnvironmentSet(c, e, sampler); !r) return r.error();
  return env;
}

Result<void> checkLatLong(const LatLongEnvironmentDesc& desc) {
  if (!desc.rgba || desc.width == 0 || desc.height == 0)
    return makeError(ErrorCode::InvalidArgument, "environment: empty image");
  if (desc.width != 2 * desc.height)
    return makeError(ErrorCode::InvalidArgument, "environment: a lat-long map must be 2:1, got " +
                                                     std::to_string(desc.width) + "x" + std::to_string(desc.height));
  return {};
}

}  // namespace

Environment::Environment(std::unique_ptr<EnvironmentImpl> impl) : impl_(std::move(impl)) {}

Environment::~Environment() {
  EnvironmentImpl* e = impl_.release();
  e->context->retire([e]() {
    ContextImpl& c = *e->context;
    if (e->pool) c.vk.vkDestroyDescriptorPool(c.device(), e->pool, c.alloc());
    if (e->cubeSampler) c.vk.vkDestroySampler(c.device(), e->cubeSampler, c.alloc());
    c.destroyImage(e->image);
    delete e;
  });
}

EnvironmentEncoding Environment::encoding() const { return impl_->encoding; }

Result<std::unique_ptr<Environment>> Environment::createLatLong(Context& context, const LatLongEnvironmentDesc& desc,
                                                                VkCommandBuffer cmd) {
  if (auto ok = checkLatLong(desc); !ok) return ok.error();
  const size_t texels = size_t(desc.width) * desc.height;
  std::vector<uint16_t> half(texels * 4);
  if (auto ok = toHalf(desc.rgba, texels, desc.width, "environment", half.data()); !ok) return ok.error();
  return createEnvironment(ContextAccess::impl(context), EnvironmentEncoding::LatLong, desc.width, desc.height, half, cmd,
                           [](std::unique_ptr<EnvironmentImpl> impl) {
                             return std::unique_ptr<Environment>(new Environment(std::move(impl)));
                           });
}

Result<std::unique_ptr<Environment>> Environment::createCube(Context& context, const CubeEnvironmentDesc& desc,
                                                             VkCommandBuffer cmd) {
  if (desc.faceSize == 0) return makeError(ErrorCode::InvalidArgument, "cube environment: face size is 0");
  const size_t texels = size_t(desc.faceSize) * desc.faceSize;
  std::vector<uint16_t> half(texels * 4 * 6);
  static const char* const kFaceNames[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
  for (size_t face = 0; face < 6; ++face) {
    if (!desc.faces[face])
      return makeError(ErrorCode::InvalidArgument, std::string("cube environment: face ") + kFaceNames[face] +
                                                       " is missing");
    if (auto ok = toHalf(desc.faces[face], texels, desc.faceSize,
                         std::string("cube environment face ") + kFaceNames[face], &half[face * texels * 4]);
        !ok)
      return ok.error();
  }
  return createEnvironment(ContextAccess::impl(context), EnvironmentEncoding::Cube, desc.faceSize, desc.faceSize, half, cmd,
                           [](std::unique_ptr<EnvironmentImpl> impl) {
                             return std::unique_ptr<Environment>(new Environment(std::move(impl)));
                           });
}

Result<std::unique_ptr<Environment>> Environment::createCubeFromLatLong(Context& context,
                                                                        const LatLongEnvironmentDesc& desc,
                                                                        uint32_t faceSize, VkCommandBuffer cmd) {
  if (auto ok = checkLatLong(desc); !ok) return ok.error();
  // Reject bad pixels with the lat-long's coordinates before resampling spreads them.
  const size_t latLongTexels = size_t(desc.width) * desc.height;
  for (size_t i = 0; i < latLongTexels * 4; ++i)
    if (!std::isfinite(desc.rgba[i]) || desc.rgba[i] < 0.0f)
      return makeError(ErrorCode::InvalidArgument, "environment: pixel " + std::to_string((i / 4) % desc.width) +
                                                       "," + std::to_string((i / 4) / desc.width) +
                                                       " is negative, NaN or infinite");
  const uint32_t n = faceSize ? faceSize : std::max(1u, desc.height / 2);
  std::vector<float> faces(size_t(n) * n * 4 * 6);
  CubeEnvironmentDesc cube;
  cube.faceSize = n;
  for (uint32_t face = 0; face < 6; ++face) {
    float* out = &faces[size_t(face) * n * n * 4];
    cube.faces[face] = out;
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) {
        // Face texel centre -> world direction (CubeEnvironmentDesc's table).
        const float a = 2.0f * (float(i) + 0.5f) / float(n) - 1.0f;
        const float b = 2.0f * (float(j) + 0.5f) / float(n) - 1.0f;
        float d[3];
        switch (face) {
          case 0: d[0] = 1.0f, d[1] = -b, d[2] = -a; break;
          case 1: d[0] = -1.0f, d[1] = -b, d[2] = a; break;
          case 2: d[0] = a, d[1] = 1.0f, d[2] = b; break;
          case 3: d[0] = a, d[1] = -1.0f, d[2] = -b; break;
          case 4: d[0] = a, d[1] = -b, d[2] = 1.0f; break;
          default: d[0] = -a, d[1] = -b, d[2] = -1.0f; break;
        }
        sampleLatLongBilinear(desc.rgba, desc.width, desc.height, d[0], d[1], d[2], &out[(size_t(j) * n + i) * 4]);
      }
  }
  return createCube(context, cube, cmd);
}

}  // namespace shrefract
