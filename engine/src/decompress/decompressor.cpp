// The decompression compute pass (see shrefract/decompressor.h).
#include <shrefract/decompressor.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "core/context_impl.h"
#include "decompress/field_layouts.h"
#include "engine_spirv.h"
#include "raster/object_impl.h"
#include "shrefract/gpu_layout.h"

namespace shrefract {

namespace {
// Highest order whose pipeline can be built (field.h allows order <= 32).
constexpr uint32_t kMaxDecompressOrder = 32;
}  // namespace

struct DecompressorImpl {
  ContextImpl* context = nullptr;
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkShaderModule decompressModule = VK_NULL_HANDLE;
  VkPipeline gutter = VK_NULL_HANDLE;
  std::map<uint32_t, VkPipeline> byOrder;

  void release() {
    if (!context) return;
    ContextImpl& c = *context;
    for (auto& [order, p] : byOrder) c.vk.vkDestroyPipeline(c.device(), p, c.alloc());
    byOrder.clear();
    if (gutter) c.vk.vkDestroyPipeline(c.device(), gutter, c.alloc());
    if (decompressModule) c.vk.vkDestroyShaderModule(c.device(), decompressModule, c.alloc());
    if (layout) c.vk.vkDestroyPipelineLayout(c.device(), layout, c.alloc());
    if (setLayout) c.vk.vkDestroyDescriptorSetLayout(c.device(), setLayout, c.alloc());
    context = nullptr;
  }

  Result<VkPipeline> createPipeline(VkShaderModule module, const VkSpecializationInfo* specialization) {
    ContextImpl& c = *context;
    VkComputePipelineCreateInfo cpci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    cpci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    cpci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    cpci.stage.module = module;
    cpci.stage.pName = "main";
    cpci.stage.pSpecializationInfo = specialization;
    cpci.layout = layout;
    VkPipeline pipeline = VK_NULL_HANDLE;
    const VkResult r =
        c.vk.vkCreateComputePipelines(c.device(), c.info.pipelineCache, 1, &cpci, c.alloc(), &pipeline);
    if (r != VK_SUCCESS) return vulkanError("vkCreateComputePipelines", r);
    return pipeline;
  }
};

Decompressor::Decompressor(std::unique_ptr<DecompressorImpl> impl) : impl_(std::move(impl)) {}

Decompressor::~Decompressor() {
  DecompressorImpl* d = impl_.release();
  if (!d->context) {
    delete d;
    return;
  }
  d->context->retire([d]() {
    d->release();
    delete d;
  });
}

Result<std::unique_ptr<Decompressor>> Decompressor::create(Context& context) {
  ContextImpl& c = context.impl();
  auto impl = std::make_unique<DecompressorImpl>();
  impl->context = &c;
  struct Guard {
    DecompressorImpl* impl;
    ~Guard() {
      if (impl) impl->release();
    }
  } guard{impl.get()};

  auto setLayout = createDecompressSetLayout(c);
  if (!setLayout) return setLayout.error();
  impl->setLayout = setLayout.value();
  const VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(gpu::DecompressPushConstants)};
  VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = 1;
  plci.pSetLayouts = &impl->setLayout;
  plci.pushConstantRangeCount = 1;
  plci.pPushConstantRanges = &range;
  VkResult r = c.vk.vkCreatePipelineLayout(c.device(), &plci, c.alloc(), &impl->layout);
  if (r != VK_SUCCESS) return vulkanError("vkCreatePipelineLayout", r);

  // The decompression module stays alive: one pipeline per order is specialized from it later.
  auto module = c.createShaderModule(kSpirv_decompress_comp, sizeof(kSpirv_decompress_comp));
  if (!module) return module.error();
  impl->decompressModule = module.value();
  auto gutterModule = c.createShaderModule(kSpirv_gutter_comp, sizeof(kSpirv_gutter_comp));
  if (!gutterModule) return gutterModule.error();
  auto gutter = impl->createPipeline(gutterModule.value(), nullptr);
  c.vk.vkDestroyShaderModule(c.device(), gutterModule.value(), c.alloc());
  if (!gutter) return gutter.error();
  impl->gutter = gutter.value();
  guard.impl = nullptr;
  return std::unique_ptr<Decompressor>(new Decompressor(std::move(impl)));
}

Result<void> Decompressor::prepare(uint32_t order) {
  DecompressorImpl& d = *impl_;
  if (order > kMaxDecompressOrder)
    return makeError(ErrorCode::InvalidArgument, "Decompressor: SH order " + std::to_string(order) + " exceeds " +
                                                     std::to_string(kMaxDecompressOrder));
  if (d.byOrder.count(order)) return {};
  const int32_t value = static_cast<int32_t>(order);
  const VkSpecializationMapEntry entry{gpu::kSpecShOrder, 0, sizeof(value)};
  const VkSpecializationInfo specialization{1, &entry, sizeof(value), &value};  // { SH_ORDER = order }
  auto pipeline = d.createPipeline(d.decompressModule, &specialization);
  if (!pipeline) return pipeline.error();
  d.byOrder[order] = pipeline.value();
  return {};
}

Result<void> Decompressor::record(VkCommandBuffer cmd, const std::array<float, 3>& eye,
                                  const std::vector<Object*>& objects) {
  DecompressorImpl& d = *impl_;
  ContextImpl& c = *d.context;
  std::vector<FieldResources*> fields;
  for (Object* o : objects)
    if (o && o->impl().field && std::find(fields.begin(), fields.end(), o->impl().field.get()) == fields.end())
      fields.push_back(o->impl().field.get());
  if (fields.empty()) return {};
  for (FieldResources* f : fields)
    if (auto r = prepare(f->order); !r) return r;

  auto imageBarrier = [](const FieldResources& f) {
    VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = f.distortion.image;
    b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    return b;
  };
  auto submitBarriers = [&](const std::vector<VkImageMemoryBarrier2>& barriers) {
    VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
    dep.imageMemoryBarrierCount = static_cast<uint32_t>(barriers.size());
    dep.pImageMemoryBarriers = barriers.data();
    c.vk.vkCmdPipelineBarrier2(cmd, &dep);
  };

  // 1. Wait for earlier reads (the previous frame's raster pass, earlier decompressions), discard
  //    the old contents and make the images writable by the compute shader.
  std::vector<VkImageMemoryBarrier2> barriers;
  for (const FieldResources* f : fields) {
    VkImageMemoryBarrier2 b = imageBarrier(*f);
    b.srcStageMask = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    b.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    b.dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    b.newLayout = VK_IMAGE_LAYOUT_GENERAL;
    barriers.push_back(b);
  }
  submitBarriers(barriers);

  // 2. One dispatch per object.
  gpu::DecompressPushConstants push{};
  push.eyeWorld = {eye[0], eye[1], eye[2], 1.0f};
  VkPipeline bound = VK_NULL_HANDLE;
  for (const FieldResources* f : fields) {
    const VkPipeline pipeline = d.byOrder[f->order];
    if (pipeline != bound) {
      c.vk.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
      bound = pipeline;
    }
    c.vk.vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.layout, 0, 1, &f->decompressSet, 0, nullptr);
    push.size = {f->width, f->height, f->gutterCount, 0u};
    c.vk.vkCmdPushConstants(cmd, d.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    const uint32_t tile = gpu::kDecompressLocalSize;
    c.vk.vkCmdDispatch(cmd, (f->width + tile - 1) / tile, (f->height + tile - 1) / tile, 1);
  }

  // 3. Gutter rules read what step 2 wrote.
  bool anyGutters = false;
  barriers.clear();
  for (const FieldResources* f : fields) {
    if (!f->gutterCount) continue;
    anyGutters = true;
    VkImageMemoryBarrier2 b = imageBarrier(*f);
    b.srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    b.srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
    b.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    b.dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
    b.oldLayout = b.newLayout = VK_IMAGE_LAYOUT_GENERAL;
    barriers.push_back(b);
  }
  if (anyGutters) {
    submitBarriers(barriers);
    c.vk.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.gutter);
    for (const FieldResources* f : fields) {
      if (!f->gutterCount) continue;
      c.vk.vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.layout, 0, 1, &f->decompressSet, 0,
                                   nullptr);
      push.size = {f->width, f->height, f->gutterCount, 0u};
      c.vk.vkCmdPushConstants(cmd, d.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
      c.vk.vkCmdDispatch(cmd, (f->gutterCount + gpu::kGutterLocalSize - 1) / gpu::kGutterLocalSize, 1, 1);
    }
  }

  // 4. Hand the images to the raster pass.
  barriers.clear();
  for (const FieldResources* f : fields) {
    VkImageMemoryBarrier2 b = imageBarrier(*f);
    b.srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    b.srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
    b.dstStageMask = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
    b.dstAccessMask = VK_ACCESS_2_SHADER_SAMPLED_READ_BIT;
    b.oldLayout = VK_IMAGE_LAYOUT_GENERAL;
    b.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    barriers.push_back(b);
  }
  submitBarriers(barriers);
  return {};
}

}  // namespace shrefract
