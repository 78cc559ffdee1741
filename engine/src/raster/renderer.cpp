#include <shrefract/renderer.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "core/context_impl.h"
#include "decompress/field_layouts.h"
#include "engine_spirv.h"
#include "environment/environment_impl.h"
#include "object/object_impl.h"
#include "raster/view_frustum.h"
#include "shrefract/gpu_layout.h"

namespace shrefract {

// ---------------------------------------------------------------------------------------------
// Renderer: pipelines of the background and object passes.

// Pipelines per environment encoding (index: EnvironmentEncoding) and pass.
struct RendererImpl {
  ContextImpl* context = nullptr;
  RendererCreateInfo info;
  VkDescriptorSetLayout distortionSetLayout = VK_NULL_HANDLE;  // set 1 of fieldLayout
  VkPipelineLayout backgroundLayout = VK_NULL_HANDLE;
  VkPipelineLayout objectLayout = VK_NULL_HANDLE;
  VkPipelineLayout fieldLayout = VK_NULL_HANDLE;
  std::array<VkPipeline, 2> background{};
  std::array<VkPipeline, 2> singleInterface{};
  std::array<VkPipeline, 2> field{};
  // ShadingMode::FieldExitDirection where `field` blends by silhouette coverage (else null: `field`).
  std::array<VkPipeline, 2> fieldExit{};
  // Volume fields traced per fragment (Object::tracesVolumePerFragment), as `field` and `fieldExit`.
  std::array<VkPipeline, 2> volume{};
  std::array<VkPipeline, 2> volumeExit{};
  DrawStats lastDraw;

  void release() {
    if (!context) return;
    ContextImpl& c = *context;
    for (const auto* group : {&background, &singleInterface, &field, &fieldExit, &volume, &volumeExit})
      for (VkPipeline p : *group)
        if (p) c.vk.vkDestroyPipeline(c.device(), p, c.alloc());
    for (VkPipelineLayout l : {backgroundLayout, objectLayout, fieldLayout})
      if (l) c.vk.vkDestroyPipelineLayout(c.device(), l, c.alloc());
    if (distortionSetLayout) c.vk.vkDestroyDescriptorSetLayout(c.device(), distortionSetLayout, c.alloc());
    context = nullptr;
  }
};

namespace {

struct ShaderPair {
  const uint32_t* vert;
  size_t vertBytes;
  const uint32_t* frag;
  size_t fragBytes;
};

// A pair of embedded SPIR-V arrays (engine_spirv.h).
template <size_t V, size_t F>
ShaderPair shaderPair(const uint32_t (&vert)[V], const uint32_t (&frag)[F]) {
  return {vert, sizeof(vert), frag, sizeof(frag)};
}

// The object pass reads ObjectImpl's interleaved vertex (object/object_impl.h, kVertexFloats words).
constexpr VkVertexInputBindingDescription kObjectVertexBinding{0, kVertexFloats * sizeof(float),
                                                               VK_VERTEX_INPUT_RATE_VERTEX};
constexpr std::array<VkVertexInputAttributeDescription, 5> kObjectVertexAttributes{{
    {0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0},
    {1, 0, VK_FORMAT_R32G32B32_SFLOAT, 3 * sizeof(float)},
    {2, 0, VK_FORMAT_R32G32_SFLOAT, 6 * sizeof(float)},
    {3, 0, VK_FORMAT_R32_SFLOAT, 8 * sizeof(float)},
    {4, 0, VK_FORMAT_R32_UINT, kVertexTriangleWord * sizeof(float)},
}};
// Where the fragment shaders' specialization values lie: the tap count, the coverage switch, then
// the volume's refinement.
constexpr std::array<VkSpecializationMapEntry, 3> kFragmentSpecEntries{
    {{gpu::kSpecEnvironmentTaps, 0, sizeof(uint32_t)},
     {gpu::kSpecSilhouetteCoverage, sizeof(uint32_t), sizeof(VkBool32)},
     {gpu::kSpecRefineVolumePaths, 2 * sizeof(uint32_t), sizeof(VkBool32)}}};
constexpr std::array<VkDynamicState, 2> kDynamicStates{VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};

struct ShaderModules {
  VkShaderModule vert = VK_NULL_HANDLE;
  VkShaderModule frag = VK_NULL_HANDLE;
};

Result<ShaderModules> createShaderModules(ContextImpl& c, const ShaderPair& shaders) {
  auto vert = c.createShaderModule(shaders.vert, shaders.vertBytes);
  if (!vert) return vert.error();
  auto frag = c.createShaderModule(shaders.frag, shaders.fragBytes);
  if (!frag) {
    c.vk.vkDestroyShaderModule(c.device(), vert.value(), c.alloc());
    return frag.error();
  }
  return ShaderModules{vert.value(), frag.value()};
}

std::array<VkPipelineShaderStageCreateInfo, 2> shaderStages(const ShaderModules& modules,
                                                            const VkSpecializationInfo& fragmentSpecialization) {
  std::array<VkPipelineShaderStageCreateInfo, 2> stages{};
  stages[0] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = modules.vert;
  stages[0].pName = "main";
  stages[1] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = modules.frag;
  stages[1].pName = "main";
  stages[1].pSpecializationInfo = &fragmentSpecialization;
  return stages;
}

// The background pass draws one triangle from the vertex index alone: no vertex input.
VkPipelineVertexInputStateCreateInfo vertexInputState(bool objectPass) {
  VkPipelineVertexInputStateCreateInfo vertexInput{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  if (objectPass) {
    vertexInput.vertexBindingDescriptionCount = 1;
    vertexInput.pVertexBindingDescriptions = &kObjectVertexBinding;
    vertexInput.vertexAttributeDescriptionCount = static_cast<uint32_t>(kObjectVertexAttributes.size());
    vertexInput.pVertexAttributeDescriptions = kObjectVertexAttributes.data();
  }
  return vertexInput;
}

VkPipelineRasterizationStateCreateInfo rasterizationState(bool objectPass) {
  VkPipelineRasterizationStateCreateInfo rs{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  // Only front faces: the field describes what is seen through the front surface.
  rs.cullMode = objectPass ? VK_CULL_MODE_BACK_BIT : VK_CULL_MODE_NONE;
  rs.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  rs.lineWidth = 1.0f;
  return rs;
}

VkPipelineDepthStencilStateCreateInfo depthStencilState(const RendererCreateInfo& info, bool objectPass) {
  VkPipelineDepthStencilStateCreateInfo ds{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  const bool hasDepth = info.depthFormat != VK_FORMAT_UNDEFINED;
  ds.depthTestEnable = hasDepth ? VK_TRUE : VK_FALSE;
  ds.depthWriteEnable = (hasDepth && objectPass) ? VK_TRUE : VK_FALSE;
  ds.depthCompareOp = objectPass ? VK_COMPARE_OP_LESS : VK_COMPARE_OP_LESS_OR_EQUAL;
  return ds;
}

VkPipelineColorBlendAttachmentState blendAttachmentState(bool coverage) {
  VkPipelineColorBlendAttachmentState blend{};
  if (coverage) {  // colour: src a + dst (1 - a); alpha: a + dst alpha (1 - a)
    blend.blendEnable = VK_TRUE;
    blend.srcColorBlendFactor = VK_BLEND_FACTOR_SRC_ALPHA;
    blend.dstColorBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
    blend.srcAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
    blend.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
  }
  blend.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT |
                         VK_COLOR_COMPONENT_A_BIT;
  return blend;
}

// coverage: the fragment shader's alpha is its silhouette coverage (kSpecSilhouetteCoverage),
// blended over the attachment.
Result<VkPipeline> createGraphicsPipeline(ContextImpl& c, const RendererCreateInfo& info, VkPipelineLayout layout,
                                          const ShaderPair& shaders, bool objectPass, bool coverage) {
  auto modules = createShaderModules(c, shaders);
  if (!modules) return modules.error();
  // Every fragment shader gets the tap count, the coverage switch and the volume's refinement; those
  // without the constants (the background, the single interface) ignore them.
  const std::array<uint32_t, 3> specValues{info.environmentTapsPerAxis, coverage ? VK_TRUE : VK_FALSE,
                                           info.refineVolumePaths ? VK_TRUE : VK_FALSE};
  const VkSpecializationInfo specialization{uint32_t(kFragmentSpecEntries.size()), kFragmentSpecEntries.data(),
                                            sizeof(specValues), specValues.data()};
  const std::array<VkPipelineShaderStageCreateInfo, 2> stages = shaderStages(modules.value(), specialization);
  const VkPipelineVertexInputStateCreateInfo vertexInput = vertexInputState(objectPass);
  VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  ia.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = 1;
  vp.scissorCount = 1;
  const VkPipelineRasterizationStateCreateInfo rs = rasterizationState(objectPass);
  VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  ms.rasterizationSamples = info.sampleCount;  // the host's attachments
  const VkPipelineDepthStencilStateCreateInfo ds = depthStencilState(info, objectPass);
  const VkPipelineColorBlendAttachmentState blend = blendAttachmentState(coverage);
  VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  cb.attachmentCount = 1;
  cb.pAttachments = &blend;
  VkPipelineDynamicStateCreateInfo dyn{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dyn.dynamicStateCount = static_cast<uint32_t>(kDynamicStates.size());
  dyn.pDynamicStates = kDynamicStates.data();
  VkPipelineRenderingCreateInfo rendering{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  rendering.colorAttachmentCount = 1;
  rendering.pColorAttachmentFormats = &info.colorFormat;
  rendering.depthAttachmentFormat = info.depthFormat;

  VkGraphicsPipelineCreateInfo gpci{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  gpci.pNext = &rendering;
  gpci.stageCount = static_cast<uint32_t>(stages.size());
  gpci.pStages = stages.data();
  gpci.pVertexInputState = &vertexInput;
  gpci.pInputAssemblyState = &ia;
  gpci.pViewportState = &vp;
  gpci.pRasterizationState = &rs;
  gpci.pMultisampleState = &ms;
  gpci.pDepthStencilState = &ds;
  gpci.pColorBlendState = &cb;
  gpci.pDynamicState = &dyn;
  gpci.layout = layout;
  VkPipeline pipeline = VK_NULL_HANDLE;
  VkResult r = c.vk.vkCreateGraphicsPipelines(c.device(), c.info.pipelineCache, 1, &gpci, c.alloc(), &pipeline);
  c.vk.vkDestroyShaderModule(c.device(), modules.value().vert, c.alloc());
  c.vk.vkDestroyShaderModule(c.device(), modules.value().frag, c.alloc());
  if (r != VK_SUCCESS) return vulkanError("vkCreateGraphicsPipelines", r);
  return pipeline;
}

Result<VkPipelineLayout> createLayout(ContextImpl& c, uint32_t pushBytes,
                                      VkDescriptorSetLayout fieldSet = VK_NULL_HANDLE) {
  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, pushBytes};
  const std::array<VkDescriptorSetLayout, 2> sets{c.environmentSetLayout, fieldSet};
  VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.setLayoutCount = fieldSet ? 2u : 1u;
  plci.pSetLayouts = sets.data();
  plci.pushConstantRangeCount = 1;
  plci.pPushConstantRanges = &range;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkResult r = c.vk.vkCreatePipelineLayout(c.device(), &plci, c.alloc(), &layout);
  if (r != VK_SUCCESS) return vulkanError("vkCreatePipelineLayout", r);
  return layout;
}

glm::vec3 toVec3(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }

gpu::mat4 toGpu(const glm::mat4& m) {
  gpu::mat4 out{};
  std::memcpy(out.m, glm::value_ptr(m), sizeof(out.m));
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Camera matrices and culling (raster/view_frustum.h).

glm::mat4 clipFromView(const Camera& camera, VkExtent2D extent) {
  const float aspect = extent.height ? float(extent.width) / float(extent.height) : 1.0f;
  glm::mat4 p = glm::perspectiveRH_ZO(glm::radians(camera.verticalFovDegrees), aspect, camera.nearPlane,
                                      camera.farPlane);
  p[1][1] *= -1.0f;
  return p;
}

glm::mat4 viewFromWorld(const Camera& camera) {
  return glm::lookAtRH(toVec3(camera.eye), toVec3(camera.target), toVec3(camera.up));
}

ViewFrustum viewFrustum(const glm::mat4& clipFromWorld) {
  // Row r of the matrix (glm is column-major): clip coordinate r = dot(row r, p).
  auto row = [&](int r) {
    return glm::vec4(clipFromWorld[0][r], clipFromWorld[1][r], clipFromWorld[2][r], clipFromWorld[3][r]);
  };
  const glm::vec4 x = row(0), y = row(1), z = row(2), w = row(3);
  return ViewFrustum{{w + x, w - x, w + y, w - y, z, w - z}};
}

bool outsideFrustum(const ViewFrustum& frustum, const std::array<float, 3>& boxMin,
                    const std::array<float, 3>& boxMax) {
  for (const glm::vec4& plane : frustum.planes) {
    // The box corner farthest along the plane's normal: if even it is outside, the box is.
    const glm::vec3 corner(plane.x >= 0.0f ? boxMax[0] : boxMin[0], plane.y >= 0.0f ? boxMax[1] : boxMin[1],
                           plane.z >= 0.0f ? boxMax[2] : boxMin[2]);
    const float distance = glm::dot(glm::vec3(plane), corner) + plane.w;
    // A margin of a few float ulps of the terms keeps boxes that touch the plane.
    const float margin = 1e-5f * (glm::dot(glm::abs(glm::vec3(plane)), glm::abs(corner)) + std::fabs(plane.w));
    if (distance < -margin) return true;  // false for NaN: a degenerate camera culls nothing
  }
  return false;
}

Renderer::Renderer(std::unique_ptr<RendererImpl> impl) : impl_(std::move(impl)) {}

Renderer::~Renderer() { retireImpl(std::move(impl_)); }

namespace {

// The object pass's constants for one object (gpu_layout.h): shading in object space.
gpu::ObjectPushConstants objectPushConstants(const Object& object, const glm::mat4& clipFromWorld,
                                             const std::array<float, 3>& eyeWorld, float exposure, uint32_t mode,
                                             bool throughput) {
  const Transform& t = object.worldFromObject;
  const std::array<float, 3> x = rotateDirection(t, {1.0f, 0.0f, 0.0f}), y = rotateDirection(t, {0.0f, 1.0f, 0.0f}),
                             z = rotateDirection(t, {0.0f, 0.0f, 1.0f});
  const glm::mat4 worldFromObject(glm::vec4(x[0], x[1], x[2], 0.0f) * t.scale,
                                  glm::vec4(y[0], y[1], y[2], 0.0f) * t.scale,
                                  glm::vec4(z[0], z[1], z[2], 0.0f) * t.scale,
                                  glm::vec4(t.translation[0], t.translation[1], t.translation[2], 1.0f));
  const std::array<float, 3> eye = inverseTransformPoint(t, eyeWorld);
  const std::array<float, 4> q = unitRotation(t);
  const ObjectShading& s = object.shading;
  gpu::ObjectPushConstants push{};
  push.clipFromObject = toGpu(clipFromWorld * worldFromObject);
  push.eyeObject = {eye[0], eye[1], eye[2], exposure};
  push.medium = {s.ior, s.absorptionScale * t.scale, s.reflection ? 1.0f : 0.0f, static_cast<float>(mode)};
  push.tint = {s.tint[0], s.tint[1], s.tint[2], throughput ? 1.0f : 0.0f};
  push.worldFromObjectRotation = {q[0], q[1], q[2], q[3]};
  return push;
}

}  // namespace

static_assert(kMaxEnvironmentTapsPerAxis == gpu::kMaxEnvironmentTapsPerAxis &&
                  RendererCreateInfo{}.environmentTapsPerAxis == gpu::kEnvironmentTapsPerAxis,
              "the public tap range and default are the shaders'");

namespace {

// coverage: whether the field pipelines blend by silhouette coverage (RendererCreateInfo).
Result<void> checkCreateInfo(ContextImpl& c, const RendererCreateInfo& info, bool coverage) {
  const VkPhysicalDeviceLimits& limits = c.properties.limits;
  const VkSampleCountFlags supported = limits.framebufferColorSampleCounts &
                                       (info.depthFormat != VK_FORMAT_UNDEFINED ? limits.framebufferDepthSampleCounts : ~0u);
  if (!(supported & info.sampleCount) || (info.sampleCount & (info.sampleCount - 1)) != 0)
    return makeError(ErrorCode::Unsupported, "Renderer::create: the device does not support " +
                                                 std::to_string(info.sampleCount) + " samples per pixel");
  if (coverage) {
    // The coverage pipelines blend: refused here rather than as a validation error later.
    VkFormatProperties format{};
    c.vk.vkGetPhysicalDeviceFormatProperties(c.info.physicalDevice, info.colorFormat, &format);
    if (!(format.optimalTilingFeatures & VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BLEND_BIT))
      return makeError(ErrorCode::Unsupported, "Renderer::create: colorFormat " + std::to_string(info.colorFormat) +
                                                   " does not blend, which silhouetteCoverage needs (set it to false)");
  }
  if (info.environmentTapsPerAxis < 1 || info.environmentTapsPerAxis > kMaxEnvironmentTapsPerAxis)
    return makeError(ErrorCode::InvalidArgument, "Renderer::create: environmentTapsPerAxis " +
                                                     std::to_string(info.environmentTapsPerAxis) + " is outside 1.." +
                                                     std::to_string(kMaxEnvironmentTapsPerAxis));
  return {};
}

// The distortion set layout and the three pipeline layouts, into `impl` (released by the caller on
// failure).
Result<void> createLayouts(ContextImpl& c, RendererImpl& impl) {
  auto distortionLayout = createDistortionSetLayout(c);
  if (!distortionLayout) return distortionLayout.error();
  impl.distortionSetLayout = distortionLayout.value();
  auto bl = createLayout(c, sizeof(gpu::BackgroundPushConstants));
  if (!bl) return bl.error();
  impl.backgroundLayout = bl.value();
  auto ol = createLayout(c, sizeof(gpu::ObjectPushConstants));
  if (!ol) return ol.error();
  impl.objectLayout = ol.value();
  auto fl = createLayout(c, sizeof(gpu::ObjectPushConstants), impl.distortionSetLayout);
  if (!fl) return fl.error();
  impl.fieldLayout = fl.value();
  return {};
}

// One pipeline of RendererImpl: where it goes and how it is made.
struct PipelineVariant {
  VkPipeline* target;
  VkPipelineLayout layout;
  ShaderPair shaders;
  bool objectPass;
  bool coverage = false;
};

std::vector<PipelineVariant> pipelineVariants(RendererImpl& impl, bool coverage) {
  const ShaderPair fieldShaders = shaderPair(kSpirv_object_vert, kSpirv_object_field_frag);
  const ShaderPair fieldCubeShaders = shaderPair(kSpirv_object_vert, kSpirv_object_field_cube_frag);
  const ShaderPair volumeShaders = shaderPair(kSpirv_object_vert, kSpirv_object_volume_frag);
  const ShaderPair volumeCubeShaders = shaderPair(kSpirv_object_vert, kSpirv_object_volume_cube_frag);
  std::vector<PipelineVariant> variants{{
      {&impl.background[0], impl.backgroundLayout, shaderPair(kSpirv_background_vert, kSpirv_background_frag), false},
      {&impl.background[1], impl.backgroundLayout, shaderPair(kSpirv_background_vert, kSpirv_background_cube_frag),
       false},
      {&impl.singleInterface[0], impl.objectLayout,
       shaderPair(kSpirv_object_vert, kSpirv_object_single_interface_frag), true},
      {&impl.singleInterface[1], impl.objectLayout,
       shaderPair(kSpirv_object_vert, kSpirv_object_single_interface_cube_frag), true},
      {&impl.field[0], impl.fieldLayout, fieldShaders, true, coverage},
      {&impl.field[1], impl.fieldLayout, fieldCubeShaders, true, coverage},
      {&impl.volume[0], impl.fieldLayout, volumeShaders, true, coverage},
      {&impl.volume[1], impl.fieldLayout, volumeCubeShaders, true, coverage},
  }};
  if (coverage) {
    variants.push_back({&impl.fieldExit[0], impl.fieldLayout, fieldShaders, true, false});
    variants.push_back({&impl.fieldExit[1], impl.fieldLayout, fieldCubeShaders, true, false});
    variants.push_back({&impl.volumeExit[0], impl.fieldLayout, volumeShaders, true, false});
    variants.push_back({&impl.volumeExit[1], impl.fieldLayout, volumeCubeShaders, true, false});
  }
  return variants;
}

}  // namespace

Result<std::unique_ptr<Renderer>> Renderer::create(Context& context, const RendererCreateInfo& info) {
  ContextImpl& c = ContextAccess::impl(context);
  const bool coverage = info.silhouetteCoverage && info.sampleCount == VK_SAMPLE_COUNT_1_BIT;
  if (auto checked = checkCreateInfo(c, info, coverage); !checked) return checked.error();
  auto impl = std::make_unique<RendererImpl>();
  impl->context = &c;
  impl->info = info;
  // Released right away on failure: nothing has used the pipelines yet.
  struct Guard {
    RendererImpl* impl;
    ~Guard() {
      if (impl) impl->release();
    }
  } guard{impl.get()};

  if (auto created = createLayouts(c, *impl); !created) return created.error();
  for (const PipelineVariant& v : pipelineVariants(*impl, coverage)) {
    auto pipeline = createGraphicsPipeline(c, info, v.layout, v.shaders, v.objectPass, v.coverage);
    if (!pipeline) return pipeline.error();
    *v.target = pipeline.value();
  }
  guard.impl = nullptr;
  return std::unique_ptr<Renderer>(new Renderer(std::move(impl)));
}

const DrawStats& Renderer::lastDrawStats() const { return impl_->lastDraw; }

void Renderer::recordBackground(VkCommandBuffer cmd, const Environment& environment, const Camera& camera,
                                VkExtent2D extent) {
  RendererImpl& r = *impl_;
  ContextImpl& c = *r.context;
  glm::mat4 view = viewFromWorld(camera);
  view[3] = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);  // directions only: drop the translation
  gpu::BackgroundPushConstants push{toGpu(glm::inverse(clipFromView(camera, extent) * view))};
  const size_t encoding = static_cast<size_t>(environment.encoding());
  c.vk.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, r.background[encoding]);
  c.vk.vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, r.backgroundLayout, 0, 1,
                               &EnvironmentAccess::impl(environment).set, 0, nullptr);
  c.vk.vkCmdPushConstants(cmd, r.backgroundLayout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                          sizeof(push), &push);
  c.vk.vkCmdDraw(cmd, 3, 1, 0, 0);
}

void Renderer::recordObjects(VkCommandBuffer cmd, const Environment& environment, const Camera& camera,
                             VkExtent2D extent, std::span<Object* const> objects, ShadingMode mode) {
  RendererImpl& r = *impl_;
  ContextImpl& c = *r.context;
  const glm::mat4 clipFromWorld = clipFromView(camera, extent) * viewFromWorld(camera);
  const ViewFrustum frustum = viewFrustum(clipFromWorld);
  const size_t encoding = static_cast<size_t>(environment.encoding());
  VkPipeline bound = VK_NULL_HANDLE;
  r.lastDraw = DrawStats{};
  for (Object* object : objects) {
    if (!object) continue;
    const ObjectImpl& o = ObjectAccess::impl(*object);
    std::array<float, 3> lo{}, hi{};
    worldBounds(*object, lo, hi);
    if (r.info.frustumCulling && outsideFrustum(frustum, lo, hi)) {
      ++r.lastDraw.culled;
      continue;
    }
    ++r.lastDraw.drawn;
    const bool field = (mode == ShadingMode::Field || mode == ShadingMode::FieldExitDirection) && o.field;
    const bool exitDirection = mode == ShadingMode::FieldExitDirection && r.fieldExit[encoding];
    const bool perFragment = field && o.field->volumePerFragment;
    const VkPipeline pipeline = !field          ? r.singleInterface[encoding]
                                : exitDirection ? (perFragment ? r.volumeExit : r.fieldExit)[encoding]
                                                : (perFragment ? r.volume : r.field)[encoding];
    const VkPipelineLayout layout = field ? r.fieldLayout : r.objectLayout;
    if (pipeline != bound) {
      // Set 0 (environment) stays bound across the switch: both layouts share it.
      c.vk.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
      c.vk.vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &EnvironmentAccess::impl(environment).set, 0,
                                   nullptr);
      bound = pipeline;
    }
    if (field)
      c.vk.vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, r.fieldLayout, 1, 1, &o.field->distortionSet,
                                   0, nullptr);
    const uint32_t gpuMode = !field                                      ? gpu::kModeSingleInterface
                             : mode == ShadingMode::FieldExitDirection ? gpu::kModeFieldExitDirection
                                                                       : gpu::kModeField;
    const bool throughput = field && o.field->throughput;  // the distortion image carries it (gpu_layout.h)
    const gpu::ObjectPushConstants push =
        objectPushConstants(*object, clipFromWorld, camera.eye, r.info.exposure, gpuMode, throughput);
    c.vk.vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push),
                            &push);
    VkDeviceSize offset = 0;
    c.vk.vkCmdBindVertexBuffers(cmd, 0, 1, &o.vertices.buffer, &offset);
    c.vk.vkCmdBindIndexBuffer(cmd, o.indices.buffer, 0, VK_INDEX_TYPE_UINT32);
    c.vk.vkCmdDrawIndexed(cmd, o.indexCount, 1, 0, 0, 0);
  }
}

}  // namespace shrefract
