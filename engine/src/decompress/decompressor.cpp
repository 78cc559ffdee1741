// The decompression compute pass (see shrefract/decompressor.h).
#include <shrefract/decompressor.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <compare>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/barriers.h"
#include "core/context_impl.h"
#include "decompress/field_layouts.h"
#include "engine_spirv.h"
#include "object/object_impl.h"
#include "raster/view_frustum.h"
#include "shrefract/gpu_layout.h"

namespace shrefract {

namespace {
// Highest order whose pipeline can be built (field.h allows order <= 32).
constexpr uint32_t kMaxDecompressOrder = 32;
}  // namespace

// What selects a decompression pipeline: the shader (by encoding) and its specialization constants.
struct DecompressVariant {
  Encoding encoding = Encoding::Sh;
  uint32_t order = 0;       // Sh
  uint32_t tableSize = 0;   // Table, Pca
  uint32_t components = 0;  // Pca
  uint32_t channels = 4;
  bool throughput = false;
  Quantization quantization = Quantization::U8;
  bool scaleBiasStorage = false;  // Sh
  bool coefficientsStorage = false;
  bool jumpAware = false;     // Table, Pca
  bool jumpDistance = false;  // Table, Pca: the last channel is the jump distance
  bool sampleFrameExits = false;  // the exits are in the sample's frame
  bool clustered = false;         // Pca: one function index per sample
  auto operator<=>(const DecompressVariant&) const = default;
};

struct DecompressorImpl {
  ContextImpl* context = nullptr;
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkShaderModule shModule = VK_NULL_HANDLE;     // decompress.comp
  VkShaderModule tableModule = VK_NULL_HANDLE;  // decompress_table.comp (Table and Pca)
  VkShaderModule volumeModule = VK_NULL_HANDLE;  // decompress_volume.comp
  VkPipeline gutter = VK_NULL_HANDLE;
  std::map<DecompressVariant, VkPipeline> byVariant;
  bool skipUnchanged = true;
  DecompressStats lastStats;

  void release() {
    if (!context) return;
    ContextImpl& c = *context;
    for (auto& [key, p] : byVariant) c.vk.vkDestroyPipeline(c.device(), p, c.alloc());
    byVariant.clear();
    if (gutter) c.vk.vkDestroyPipeline(c.device(), gutter, c.alloc());
    for (VkShaderModule m : {shModule, tableModule, volumeModule})
      if (m) c.vk.vkDestroyShaderModule(c.device(), m, c.alloc());
    if (layout) c.vk.vkDestroyPipelineLayout(c.device(), layout, c.alloc());
    if (setLayout) c.vk.vkDestroyDescriptorSetLayout(c.device(), setLayout, c.alloc());
    context = nullptr;
  }

  // The decompression pipeline of a variant, created on first use.
  Result<VkPipeline> variant(const DecompressVariant& v);
  Result<VkPipeline> variant(const FieldResources& f) {
    return variant(DecompressVariant{f.encoding, f.order, f.tableSize, f.components, f.channels, f.throughput,
                                     f.quantization, f.scaleBiasStorage, f.coefficientsStorage, f.jumpAware,
                                     f.jumpDistance, f.sampleFrameExits, f.clustered});
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

Decompressor::~Decompressor() { retireImpl(std::move(impl_)); }

Result<std::unique_ptr<Decompressor>> Decompressor::create(Context& context) {
  ContextImpl& c = ContextAccess::impl(context);
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

  // The decompression modules stay alive: one pipeline per variant is specialized from them later.
  auto shModule = c.createShaderModule(kSpirv_decompress_comp, sizeof(kSpirv_decompress_comp));
  if (!shModule) return shModule.error();
  impl->shModule = shModule.value();
  auto tableModule = c.createShaderModule(kSpirv_decompress_table_comp, sizeof(kSpirv_decompress_table_comp));
  if (!tableModule) return tableModule.error();
  impl->tableModule = tableModule.value();
  auto volumeModule = c.createShaderModule(kSpirv_decompress_volume_comp, sizeof(kSpirv_decompress_volume_comp));
  if (!volumeModule) return volumeModule.error();
  impl->volumeModule = volumeModule.value();
  auto gutterModule = c.createShaderModule(kSpirv_gutter_comp, sizeof(kSpirv_gutter_comp));
  if (!gutterModule) return gutterModule.error();
  auto gutter = impl->createPipeline(gutterModule.value(), nullptr);
  c.vk.vkDestroyShaderModule(c.device(), gutterModule.value(), c.alloc());
  if (!gutter) return gutter.error();
  impl->gutter = gutter.value();
  guard.impl = nullptr;
  return std::unique_ptr<Decompressor>(new Decompressor(std::move(impl)));
}

Result<VkPipeline> DecompressorImpl::variant(const DecompressVariant& v) {
  if (v.encoding == Encoding::Sh && v.order > kMaxDecompressOrder)
    return makeError(ErrorCode::InvalidArgument, "Decompressor: SH order " + std::to_string(v.order) + " exceeds " +
                                                     std::to_string(kMaxDecompressOrder));
  if (auto found = byVariant.find(v); found != byVariant.end()) return found->second;
  // Both shaders get every constant; each ignores those it does not declare. (A bool
  // specialization constant is 32 bits wide.)
  auto flag = [](bool b) { return b ? uint32_t(VK_TRUE) : uint32_t(VK_FALSE); };
  // { SH_ORDER, CHANNELS, QUANTIZATION, SCALE_BIAS_STORAGE, COEFFICIENTS_STORAGE, THROUGHPUT,
  //   ENCODING, TABLE_SIZE, COMPONENTS, JUMP_AWARE, JUMP_DISTANCE, SAMPLE_FRAME_EXITS, CLUSTERED }
  const std::array<uint32_t, 13> values{v.order,
                                       v.channels,
                                       static_cast<uint32_t>(v.quantization),
                                       flag(v.scaleBiasStorage),
                                       flag(v.coefficientsStorage),
                                       flag(v.throughput),
                                       static_cast<uint32_t>(v.encoding),
                                       v.tableSize,
                                       v.components,
                                       flag(v.jumpAware),
                                       flag(v.jumpDistance),
                                       flag(v.sampleFrameExits),
                                       flag(v.clustered)};
  const std::array<uint32_t, 13> ids{gpu::kSpecShOrder,          gpu::kSpecChannels,    gpu::kSpecQuantization,
                                    gpu::kSpecScaleBiasStorage, gpu::kSpecCoefficientsStorage,
                                    gpu::kSpecThroughput,       gpu::kSpecEncoding,    gpu::kSpecTableSize,
                                    gpu::kSpecComponents,       gpu::kSpecJumpAware,   gpu::kSpecJumpDistance,
                                    gpu::kSpecSampleFrameExits, gpu::kSpecClustered};
  std::array<VkSpecializationMapEntry, 13> entries{};
  for (uint32_t i = 0; i < entries.size(); ++i) entries[i] = {ids[i], i * uint32_t(sizeof(uint32_t)), sizeof(uint32_t)};
  const VkSpecializationInfo specialization{static_cast<uint32_t>(entries.size()), entries.data(), sizeof(values),
                                            values.data()};
  const VkShaderModule module = v.encoding == Encoding::Sh       ? shModule
                                : v.encoding == Encoding::Volume ? volumeModule
                                                                 : tableModule;
  auto pipeline = createPipeline(module, &specialization);
  if (!pipeline) return pipeline.error();
  byVariant[v] = pipeline.value();
  return pipeline.value();
}

Result<void> Decompressor::prepare(uint32_t order) {
  // Every channel layout (field.h: 3 or 4 without throughput, 4 or 5 with it), with the table each
  // field of this order uses (as createFromField decides).
  const std::array<std::pair<uint32_t, bool>, 4> layouts{{{4, false}, {3, false}, {5, true}, {4, true}}};
  for (Quantization q : {Quantization::U8, Quantization::F16})
    for (const auto& [channels, throughput] : layouts) {
      DecompressVariant v;
      v.order = order;
      v.channels = channels;
      v.throughput = throughput;
      v.quantization = q;
      v.scaleBiasStorage = shScaleBiasStorage(order, channels);
      if (auto p = impl_->variant(v); !p) return p.error();
    }
  return {};
}

Result<void> Decompressor::prepare(const Object& object) {
  const FieldResources* f = ObjectAccess::impl(object).field.get();
  if (!f) return {};
  if (auto p = impl_->variant(*f); !p) return p.error();
  return {};
}

const DecompressStats& Decompressor::lastStats() const { return impl_->lastStats; }

void Decompressor::setSkipUnchanged(bool skip) { impl_->skipUnchanged = skip; }

namespace {

// `groups` workgroups as a grid of at most kMaxDispatchGroupsX per row (gpu_layout.h).
void dispatchGrid(ContextImpl& c, VkCommandBuffer cmd, uint32_t groups) {
  const uint32_t x = std::min(groups, gpu::kMaxDispatchGroupsX);
  c.vk.vkCmdDispatch(cmd, x, (groups + x - 1) / x, 1);
}

// The fields a record() decodes, with the eye in each one's object space.
struct FieldsToDecode {
  std::vector<FieldResources*> fields;
  std::vector<std::array<float, 3>> eyes;
};

// The distinct field objects among `objects` that are in the frustum (null: no culling) and not
// already decoded for this eye and order (when skipping is on), nor Volume fields traced per fragment;
// counts the others in `stats`.
FieldsToDecode fieldsToDecode(const DecompressorImpl& d, const std::array<float, 3>& eye, const ViewFrustum* frustum,
                              std::span<Object* const> objects, DecompressStats& stats) {
  FieldsToDecode out;
  std::vector<const ObjectImpl*> seen;
  for (Object* o : objects) {
    if (!o) continue;
    const ObjectImpl& object = ObjectAccess::impl(*o);
    if (!object.field || std::find(seen.begin(), seen.end(), &object) != seen.end()) continue;
    seen.push_back(&object);
    FieldResources* f = object.field.get();
    if (f->volumePerFragment) {  // the raster pass traces it; no image to write
      ++stats.perFragment;
      continue;
    }
    std::array<float, 3> lo{}, hi{};
    worldBounds(*o, lo, hi);
    if (frustum && outsideFrustum(*frustum, lo, hi)) {
      ++stats.culled;
      continue;
    }
    // The field is decoded for the eye as the object sees it: a moved object is decoded again.
    const std::array<float, 3> objectEye = inverseTransformPoint(o->worldFromObject, eye);
    if (d.skipUnchanged && f->decoded && f->decodedEye == objectEye && f->decodedOrder == f->order) {
      ++stats.unchanged;
      continue;
    }
    out.fields.push_back(f);
    out.eyes.push_back(objectEye);
  }
  return out;
}

// One pipeline barrier over the distortion and jump images of `fields` (those with gutters only,
// if `gutteredOnly`).
void recordImageBarriers(ContextImpl& c, VkCommandBuffer cmd, const std::vector<FieldResources*>& fields,
                         bool gutteredOnly, const ImageTransition& t) {
  std::vector<VkImageMemoryBarrier2> barriers;
  for (const FieldResources* f : fields)
    if (!gutteredOnly || f->gutterCount)
      for (VkImage image : {f->distortion.image, f->jump.image}) barriers.push_back(imageBarrier(image, t));
  recordBarriers(c, cmd, barriers);
}

// One decompression dispatch per field, binding a pipeline only when it changes.
void recordDecodeDispatches(DecompressorImpl& d, VkCommandBuffer cmd, const FieldsToDecode& work,
                            const std::vector<VkPipeline>& pipelines, DecompressStats& stats) {
  ContextImpl& c = *d.context;
  gpu::DecompressPushConstants push{};
  VkPipeline bound = VK_NULL_HANDLE;
  for (size_t k = 0; k < work.fields.size(); ++k) {
    const FieldResources* f = work.fields[k];
    if (!f->sampleCount) continue;
    push.eyeObject = {work.eyes[k][0], work.eyes[k][1], work.eyes[k][2], 1.0f};
    if (pipelines[k] != bound) {
      c.vk.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelines[k]);
      bound = pipelines[k];
    }
    c.vk.vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.layout, 0, 1, &f->decompressSet, 0, nullptr);
    push.size = {f->width, f->height, f->gutterCount, f->sampleCount};
    c.vk.vkCmdPushConstants(cmd, d.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    // Sh: one invocation per 4 samples; Table, Pca, Volume: one per sample (gpu_layout.h).
    const uint32_t perInvocation = f->encoding == Encoding::Sh ? gpu::kDecompressSamplesPerInvocation : 1;
    const uint32_t invocations = (f->sampleCount + perInvocation - 1) / perInvocation;
    dispatchGrid(c, cmd, (invocations + gpu::kDecompressLocalSize - 1) / gpu::kDecompressLocalSize);
    ++stats.dispatches;
  }
}

// The gutter rules of the fields that have any, after a barrier on what the decode wrote (gutter.comp
// reads the push constants' size only).
void recordGutterDispatches(DecompressorImpl& d, VkCommandBuffer cmd, const FieldsToDecode& work,
                            DecompressStats& stats) {
  ContextImpl& c = *d.context;
  if (std::none_of(work.fields.begin(), work.fields.end(), [](const FieldResources* f) { return f->gutterCount; }))
    return;
  recordImageBarriers(c, cmd, work.fields, true,
                      {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_IMAGE_LAYOUT_GENERAL,
                       VK_IMAGE_LAYOUT_GENERAL});
  c.vk.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.gutter);
  gpu::DecompressPushConstants push{};
  for (const FieldResources* f : work.fields) {
    if (!f->gutterCount) continue;
    c.vk.vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.layout, 0, 1, &f->decompressSet, 0, nullptr);
    push.size = {f->width, f->height, f->gutterCount, f->sampleCount};
    c.vk.vkCmdPushConstants(cmd, d.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    dispatchGrid(c, cmd, (f->gutterCount + gpu::kGutterLocalSize - 1) / gpu::kGutterLocalSize);
    ++stats.dispatches;
  }
}

// Both record() overloads; `frustum` null: no culling.
Result<void> recordFields(DecompressorImpl& d, VkCommandBuffer cmd, const std::array<float, 3>& eye,
                          const ViewFrustum* frustum, std::span<Object* const> objects) {
  ContextImpl& c = *d.context;
  d.lastStats = DecompressStats{};
  DecompressStats stats;
  const FieldsToDecode work = fieldsToDecode(d, eye, frustum, objects, stats);
  std::vector<VkPipeline> pipelines;
  for (FieldResources* f : work.fields) {
    auto p = d.variant(*f);
    if (!p) return p.error();
    pipelines.push_back(p.value());
  }
  stats.decompressed = static_cast<uint32_t>(work.fields.size());
  if (work.fields.empty()) {
    d.lastStats = stats;
    return {};
  }
  // 1. Wait for earlier reads (the previous frame's raster pass, earlier decompressions) and make
  //    the images writable by the compute shader. Their contents are kept: only sample and gutter
  //    texels are rewritten, the empty ones keep the zero of createFromField's clear.
  recordImageBarriers(c, cmd, work.fields, false,
                      {VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, 0,
                       VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL});
  // 2. One dispatch per object; 3. gutter rules read what step 2 wrote.
  recordDecodeDispatches(d, cmd, work, pipelines, stats);
  recordGutterDispatches(d, cmd, work, stats);
  // 4. Hand the images to the raster pass.
  recordImageBarriers(c, cmd, work.fields, false,
                      {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                       VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
  for (size_t k = 0; k < work.fields.size(); ++k) {
    work.fields[k]->decoded = true;
    work.fields[k]->decodedEye = work.eyes[k];
    work.fields[k]->decodedOrder = work.fields[k]->order;
  }
  d.lastStats = stats;
  return {};
}

}  // namespace

uint32_t coverageOrder(const Object& object, const Camera& camera, VkExtent2D extent) {
  const uint32_t full = object.fieldOrder();
  std::array<float, 3> lo{}, hi{};
  worldBounds(object, lo, hi);
  const glm::mat4 clipFromWorld = clipFromView(camera, extent) * viewFromWorld(camera);
  glm::vec2 min(INFINITY), max(-INFINITY);
  for (int corner = 0; corner < 8; ++corner) {
    const glm::vec4 clip = clipFromWorld * glm::vec4((corner & 1) ? hi[0] : lo[0], (corner & 2) ? hi[1] : lo[1],
                                                     (corner & 4) ? hi[2] : lo[2], 1.0f);
    if (!(clip.w > 0.0f)) return full;  // behind the eye (or NaN): no bound on the projected size
    const glm::vec2 ndc = glm::vec2(clip) / clip.w;
    min = glm::min(min, ndc);
    max = glm::max(max, ndc);
  }
  const float pixels = std::max((max.x - min.x) * 0.5f * float(extent.width), (max.y - min.y) * 0.5f * float(extent.height));
  if (!std::isfinite(pixels)) return full;
  const float bands = std::floor(pixels * 0.5f) - 1.0f;
  return bands <= 0.0f ? 0u : std::min(full, bands >= float(full) ? full : static_cast<uint32_t>(bands));
}

Result<void> Decompressor::record(VkCommandBuffer cmd, const std::array<float, 3>& eye,
                                  std::span<Object* const> objects) {
  return recordFields(*impl_, cmd, eye, nullptr, objects);
}

Result<void> Decompressor::record(VkCommandBuffer cmd, const Camera& camera, VkExtent2D extent,
                                  std::span<Object* const> objects) {
  const ViewFrustum frustum = viewFrustum(clipFromView(camera, extent) * viewFromWorld(camera));
  return recordFields(*impl_, cmd, camera.eye, &frustum, objects);
}

}  // namespace shrefract
