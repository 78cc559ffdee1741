// shrefract integration sample: the smallest host engine that draws refractive glass with
// shrefract next to its own geometry. Copy this when adding shrefract to an engine.
//
//   shrefract_integration OUT.ppm [--field FILE.shrf] [--no-glass] [--frames N] [--size WxH]
//
// What the host owns (shrefract never creates or destroys any of it): the Vulkan instance with the
// validation layer and a debug messenger, the device (created with what shrefract asks for), one
// graphics+compute queue, colour and depth render targets (headless: no window), the command
// buffers and fences of two frames in flight, and its own pipeline for opaque boxes.
//
// Per frame, everything goes into the host's command buffer, in this order:
//   1. shrefract's decompression (compute, outside any rendering),
//   2. the host's barriers that make its targets attachments,
//   3. vkCmdBeginRendering on the host's targets; the host's opaque boxes; shrefract's background
//      (the environment, behind everything) and glass (depth-tested against the boxes);
//      vkCmdEndRendering,
//   4. (last frame) a copy of the colour target into a buffer the host reads.
// The image (a binary PPM, sRGB) shows a red box in front of the glass, a green box behind it and
// the glass refracting the environment. See docs/integration.md for the contract step by step.
//
// The host's own Vulkan objects (instance, device, frames, images, barriers) are in host.h.
//
// Exit codes: 0 success; 1 failure (one line on stderr), also when the validation layer reported
// anything; 77 when no Vulkan 1.3 device exists (ctest's skip code).
#include <cstdint>  // before the generated SPIR-V headers, which use uint32_t

#include <shrefract/context.h>
#include <shrefract/decompressor.h>
#include <shrefract/environment.h>
#include <shrefract/field.h>
#include <shrefract/renderer.h>
#include <vulkan/vulkan.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "box.frag.h"  // kSpirv_box_frag, compiled at build time (CMakeLists.txt)
#include "box.vert.h"  // kSpirv_box_vert
#include "host.h"

namespace {

// The host's own Vulkan objects and error handling (host.h), as an engine already has them.
using namespace integration;

// ------------------------------------------------------------------------------------------------
// Matrices. The host must draw its own geometry with the projection the engine uses for a
// shrefract::Camera, or the depth test between host geometry and glass is meaningless:
//   view  = right-handed look-at (camera looks down -Z of view space),
//   clip  = right-handed perspective with depth in [0, 1] (Vulkan), then y negated (Vulkan's
//           clip-space y points down), near/far from the Camera, aspect = width / height.
// Column-major 4x4, as GLSL expects: m[column * 4 + row].

using Mat4 = std::array<float, 16>;
using Vec3 = std::array<float, 3>;

Vec3 sub(Vec3 a, Vec3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
float dot(Vec3 a, Vec3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(Vec3 a, Vec3 b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
Vec3 normalize(Vec3 a) {
  const float l = std::sqrt(dot(a, a));
  return {a[0] / l, a[1] / l, a[2] / l};
}

Mat4 multiply(const Mat4& a, const Mat4& b) {
  Mat4 m{};
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      for (int k = 0; k < 4; ++k) m[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
  return m;
}

Mat4 clipFromWorld(const shrefract::Camera& camera, VkExtent2D extent) {
  const Vec3 f = normalize(sub(camera.target, camera.eye));
  const Vec3 s = normalize(cross(f, camera.up));
  const Vec3 u = cross(s, f);
  const Mat4 viewFromWorld = {s[0], u[0], -f[0], 0.0f, s[1], u[1], -f[1], 0.0f, s[2], u[2], -f[2], 0.0f,
                              -dot(s, camera.eye), -dot(u, camera.eye), dot(f, camera.eye), 1.0f};
  const float aspect = float(extent.width) / float(extent.height);
  const float t = std::tan(0.5f * camera.verticalFovDegrees * 3.14159265358979f / 180.0f);
  const float n = camera.nearPlane, fa = camera.farPlane;
  Mat4 clipFromView{};
  clipFromView[0] = 1.0f / (aspect * t);
  clipFromView[5] = -1.0f / t;  // y negated: Vulkan clip space points down
  clipFromView[10] = fa / (n - fa);
  clipFromView[11] = -1.0f;
  clipFromView[14] = -(fa * n) / (fa - n);
  return multiply(clipFromView, viewFromWorld);
}

// ------------------------------------------------------------------------------------------------
// Content the host makes itself: a small procedural environment and a refraction field built by
// hand (the installed package has no baker; a game would load a .shrf its content pipeline baked).

// A lat-long environment (shrefract/environment.h convention: +Y up, row 0 = zenith): a blue sky
// brightening toward the horizon over a grey checkerboard ground. No red or green anywhere, so the
// host's red and green boxes are easy to tell apart in the output.
std::vector<float> makeEnvironment(uint32_t width, uint32_t height) {
  std::vector<float> rgba(size_t(width) * height * 4);
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      const float theta = 3.14159265f * (float(y) + 0.5f) / float(height);  // from the zenith
      const float phi = 2.0f * 3.14159265f * (float(x) + 0.5f) / float(width);
      float* p = &rgba[(size_t(y) * width + x) * 4];
      const float elevation = std::cos(theta);
      if (elevation > 0.0f) {
        const float h = 1.0f - elevation;  // 0 at the zenith, 1 at the horizon
        p[0] = 0.25f + 0.6f * h * h;
        p[1] = 0.45f + 0.45f * h * h;
        p[2] = 0.95f;
      } else {
        const bool dark = (int(std::floor(phi * 8.0f / 3.14159265f)) + int(std::floor(-elevation * 12.0f))) % 2 != 0;
        const float g = dark ? 0.18f : 0.6f;
        p[0] = p[1] = p[2] = g;
      }
      p[3] = 1.0f;
    }
  return rgba;
}

// A thin glass lens: a square in the plane z = 0 facing +Z, with an analytic refraction field.
// For a texel at surface point p and the direction toward the eye w (the texel's local frame is
// the world frame here, translated to p, so w = normalize(eye - p)), the exit direction is
//   d = -w + b(p),  b(p) = -kLensPower * (p.x, p.y, 0)
// (straight through, bent toward the axis: a converging lens), and the optical depth is
//   tau(p) = kLensThickness * (1 - |p|^2 / (2 h^2))  (thicker in the middle).
// The decompressor normalizes d, so it need not be unit length. Both are polynomials of degree <= 1
// in w, so SH order 1 holds them exactly (order 2 is used to show that extra bands cost nothing
// but zeros): with Y_0 = 0.282095, Y_1 = 0.488603 y, Y_2 = 0.488603 z, Y_3 = 0.488603 x,
//   d.x = b.x / 0.282095 * Y_0 - 1 / 0.488603 * Y_3,  d.y likewise with Y_1,  d.z with Y_2,
//   tau = tau(p) / 0.282095 * Y_0.
constexpr float kLensHalfSize = 0.8f;  // world units
constexpr float kLensPower = 0.15f;    // bend per unit distance from the axis (a weak magnifier)
constexpr float kLensThickness = 0.8f; // optical depth at the centre
constexpr uint32_t kLensAtlas = 32;    // texels per side: the field is smooth, few are needed

shrefract::Field makeLensField() {
  using namespace shrefract;
  Field f;
  f.width = f.height = kLensAtlas;
  f.order = 2;
  f.channels = 4;  // x, y, z of the exit direction and the optical depth tau
  f.quantization = Quantization::U8;
  f.settings.source = "shrefract_integration: analytic thin lens";
  f.settings.order = f.order;
  f.settings.quantization = f.quantization;
  f.settings.directionsTheta = f.settings.directionsPhi = 1;  // not baked: no direction grid
  f.media = {FieldMedium{"air", 1.0f, 0.0f, {1.0f, 1.0f, 1.0f}}, FieldMedium{"glass", 1.5f, 1.0f, {1.0f, 1.0f, 1.0f}}};

  // Render mesh: two triangles, counter-clockwise seen from +Z (the side the eye is on). Atlas
  // coordinates: u grows with x, v grows downward (row 0 at the top, +Y).
  const float h = kLensHalfSize;
  f.mesh.positions = {-h, -h, 0, h, -h, 0, h, h, 0, -h, h, 0};
  f.mesh.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
  f.mesh.uvs = {0, 1, 1, 1, 1, 0, 0, 0};
  f.mesh.frontIor = {1.5f, 1.5f, 1.5f, 1.5f};
  f.mesh.indices = {0, 1, 2, 0, 2, 3};

  const uint32_t texels = f.width * f.height;
  const uint32_t layers = f.basisCount();
  f.texelKinds.assign(texels, kTexelSample);  // every texel holds a sample: no gutters, no empties
  f.frames.assign(size_t(texels) * 12, 0.0f);
  std::vector<float> coefficients(size_t(layers) * texels * f.channels, 0.0f);
  auto coefficient = [&](uint32_t layer, uint32_t texel, uint32_t channel) -> float& {
    return coefficients[(size_t(layer) * texels + texel) * f.channels + channel];
  };
  constexpr float kY0 = 0.282095f, kY1 = 0.488603f;
  for (uint32_t j = 0; j < f.height; ++j)
    for (uint32_t i = 0; i < f.width; ++i) {
      const uint32_t t = j * f.width + i;
      // The texel centre i sits at u = (i + 0.5) / width (field.h); invert the mesh's mapping.
      const float px = -h + 2.0f * h * (float(i) + 0.5f) / float(f.width);
      const float py = h - 2.0f * h * (float(j) + 0.5f) / float(f.height);
      // M_s maps a world-space eye position to the direction toward it in the local frame
      // (rows: tangent, bitangent, normal; fourth column: -axis . p).
      float* m = &f.frames[size_t(t) * 12];
      m[0] = 1.0f;   // tangent   = +X
      m[3] = -px;
      m[5] = 1.0f;   // bitangent = +Y
      m[7] = -py;
      m[10] = 1.0f;  // normal    = +Z (p.z = 0)
      coefficient(0, t, 0) = -kLensPower * px / kY0;
      coefficient(0, t, 1) = -kLensPower * py / kY0;
      coefficient(3, t, 0) = -1.0f / kY1;  // -w.x
      coefficient(1, t, 1) = -1.0f / kY1;  // -w.y
      coefficient(2, t, 2) = -1.0f / kY1;  // -w.z
      coefficient(0, t, 3) = kLensThickness * (1.0f - (px * px + py * py) / (2.0f * h * h)) / kY0;
    }
  require(encodeCoefficients(f, coefficients), "encodeCoefficients");
  // The engine validates again in createFromField; checking here names the problem sooner.
  require(validateField(f), "the hand-built lens field");
  return f;
}

constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_SRGB;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

// The host's pipeline for its opaque boxes: dynamic rendering into the same attachment formats the
// engine's Renderer was created with, depth test LESS with writes (what the engine expects of a
// depth attachment it shares), counter-clockwise front faces, back faces culled.
struct BoxPipeline {
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
};

struct BoxPush {
  Mat4 clipFromWorld;
  std::array<float, 4> centerHalf;
  std::array<float, 4> color;
};

VkShaderModule createShaderModule(VkDevice device, const uint32_t* code, size_t bytes) {
  VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  smci.codeSize = bytes;
  smci.pCode = code;
  VkShaderModule m = VK_NULL_HANDLE;
  check(vkCreateShaderModule(device, &smci, nullptr, &m), "vkCreateShaderModule");
  return m;
}

// The boxes' fixed-function state, kept together because the create info points into it.
struct BoxFixedState {
  VkPipelineVertexInputStateCreateInfo vertexInput{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  VkPipelineInputAssemblyStateCreateInfo assembly{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  VkPipelineViewportStateCreateInfo viewport{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  VkPipelineRasterizationStateCreateInfo raster{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  VkPipelineMultisampleStateCreateInfo multisample{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  VkPipelineDepthStencilStateCreateInfo depth{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  VkPipelineColorBlendAttachmentState blendAttachment{};
  VkPipelineColorBlendStateCreateInfo blend{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  std::array<VkDynamicState, 2> dynamicStates{VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  VkFormat colorFormat = kColorFormat;
  VkPipelineRenderingCreateInfo rendering{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};

  BoxFixedState() {
    assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    viewport.viewportCount = viewport.scissorCount = 1;
    raster.polygonMode = VK_POLYGON_MODE_FILL;
    raster.cullMode = VK_CULL_MODE_BACK_BIT;
    raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
    raster.lineWidth = 1.0f;
    multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    depth.depthTestEnable = VK_TRUE;
    depth.depthWriteEnable = VK_TRUE;
    depth.depthCompareOp = VK_COMPARE_OP_LESS;
    blendAttachment.colorWriteMask =
        VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    blend.attachmentCount = 1;
    blend.pAttachments = &blendAttachment;
    dynamic.dynamicStateCount = static_cast<uint32_t>(dynamicStates.size());
    dynamic.pDynamicStates = dynamicStates.data();
    rendering.colorAttachmentCount = 1;
    rendering.pColorAttachmentFormats = &colorFormat;
    rendering.depthAttachmentFormat = kDepthFormat;
  }
  BoxFixedState(const BoxFixedState&) = delete;  // its members point at each other
  BoxFixedState& operator=(const BoxFixedState&) = delete;
};

BoxPipeline createBoxPipeline(VkDevice device) {
  BoxPipeline p;
  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(BoxPush)};
  VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  plci.pushConstantRangeCount = 1;
  plci.pPushConstantRanges = &range;
  check(vkCreatePipelineLayout(device, &plci, nullptr, &p.layout), "vkCreatePipelineLayout");

  const VkShaderModule vert = createShaderModule(device, kSpirv_box_vert, sizeof(kSpirv_box_vert));
  const VkShaderModule frag = createShaderModule(device, kSpirv_box_frag, sizeof(kSpirv_box_frag));
  std::array<VkPipelineShaderStageCreateInfo, 2> stages{};
  stages[0] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
  stages[0].module = vert;
  stages[0].pName = "main";
  stages[1] = stages[0];
  stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
  stages[1].module = frag;

  const BoxFixedState state;
  VkGraphicsPipelineCreateInfo gpci{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  gpci.pNext = &state.rendering;  // dynamic rendering: no VkRenderPass
  gpci.stageCount = static_cast<uint32_t>(stages.size());
  gpci.pStages = stages.data();
  gpci.pVertexInputState = &state.vertexInput;
  gpci.pInputAssemblyState = &state.assembly;
  gpci.pViewportState = &state.viewport;
  gpci.pRasterizationState = &state.raster;
  gpci.pMultisampleState = &state.multisample;
  gpci.pDepthStencilState = &state.depth;
  gpci.pColorBlendState = &state.blend;
  gpci.pDynamicState = &state.dynamic;
  gpci.layout = p.layout;
  const VkResult r = vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &gpci, nullptr, &p.pipeline);
  vkDestroyShaderModule(device, vert, nullptr);
  vkDestroyShaderModule(device, frag, nullptr);
  check(r, "vkCreateGraphicsPipelines (boxes)");
  return p;
}

// The transform that centres `object` at the origin with its largest extent `size` (unrotated).
shrefract::Transform fitInto(const shrefract::Object& object, float size) {
  const std::array<float, 3> lo = object.objectBoundsMin(), hi = object.objectBoundsMax();
  const float extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  shrefract::Transform t;
  t.scale = extent > 0.0f ? size / extent : 1.0f;
  for (int k = 0; k < 3; ++k) t.translation[size_t(k)] = -0.5f * (lo[size_t(k)] + hi[size_t(k)]) * t.scale;
  return t;
}

struct Options {
  std::string output;
  std::string fieldPath;  // empty: the hand-built lens
  bool glass = true;
  uint32_t frames = 3;
  VkExtent2D extent{320, 240};
};

Options parseOptions(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw Failure{a + " needs a value", 2};
      return argv[++i];
    };
    if (a == "--field") o.fieldPath = value();
    else if (a == "--no-glass") o.glass = false;
    else if (a == "--frames") o.frames = static_cast<uint32_t>(std::max(1, std::atoi(value().c_str())));
    else if (a == "--size") {
      const std::string s = value();
      unsigned w = 0, h = 0;
      if (std::sscanf(s.c_str(), "%ux%u", &w, &h) != 2 || w == 0 || h == 0 || w > 8192 || h > 8192)
        throw Failure{"--size expects WxH, got '" + s + "'", 2};
      o.extent = {w, h};
    } else if (a.rfind("--", 0) == 0) throw Failure{"unknown flag " + a, 2};
    else if (o.output.empty()) o.output = a;
    else throw Failure{"more than one output path", 2};
  }
  if (o.output.empty())
    throw Failure{"usage: shrefract_integration OUT.ppm [--field FILE.shrf] [--no-glass] [--frames N] [--size WxH]", 2};
  return o;
}

std::unique_ptr<shrefract::Context> createContext(const Host& host) {
  shrefract::ContextCreateInfo info;
  info.instance = host.instance;
  info.physicalDevice = host.physicalDevice;
  info.device = host.device;
  info.queueFamilyIndex = host.queueFamily;
  info.queue = host.queue;
  info.getInstanceProcAddr = vkGetInstanceProcAddr;  // every engine call goes through this
  info.framesInFlight = kFramesInFlight;
  return take(shrefract::Context::create(info), "shrefract::Context::create");
}

// The host-visible buffer the last frame's colour target is copied into.
struct Readback {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
};

Readback createReadback(const Host& host, VkExtent2D extent) {
  Readback readback;
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = VkDeviceSize(extent.width) * extent.height * 4;
  bci.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  check(vkCreateBuffer(host.device, &bci, nullptr, &readback.buffer), "vkCreateBuffer");
  VkMemoryRequirements req{};
  vkGetBufferMemoryRequirements(host.device, readback.buffer, &req);
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex =
      host.memoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  check(vkAllocateMemory(host.device, &mai, nullptr, &readback.memory), "vkAllocateMemory");
  check(vkBindBufferMemory(host.device, readback.buffer, readback.memory, 0), "vkBindBufferMemory");
  return readback;
}

// The engine's objects the frames draw with. Declared in creation order, so that a failure part
// way destroys them in reverse; the teardown in run() orders them itself.
struct EngineObjects {
  std::unique_ptr<shrefract::Environment> environment;
  std::unique_ptr<shrefract::Object> glass;
  std::unique_ptr<shrefract::Renderer> renderer;
  std::unique_ptr<shrefract::Decompressor> decompressor;
};

EngineObjects createEngineObjects(Host& host, shrefract::Context& context, const Options& options) {
  // The create calls only record copies and barriers into `cmd`; the host decides when to submit.
  // Staging buffers are retired through the context and released by later beginFrame() calls.
  const shrefract::Field field =
      options.fieldPath.empty() ? makeLensField() : take(shrefract::readField(options.fieldPath), "readField");
  const uint32_t envWidth = 512, envHeight = 256;
  const std::vector<float> envPixels = makeEnvironment(envWidth, envHeight);
  EngineObjects e;
  host.submitNow([&](VkCommandBuffer cmd) {
    e.environment = take(shrefract::Environment::createLatLong(context, {envWidth, envHeight, envPixels.data()}, cmd),
                         "Environment::createLatLong");
    e.glass = take(shrefract::Object::createFromField(context, field, cmd), "Object::createFromField");
  });
  e.glass->shading.tint = {0.85f, 0.95f, 1.0f};  // a faint cyan glass
  // A field from a file was baked at whatever scale it was modelled in (the bunny: a few
  // centimetres, off the origin): place it where the host's camera looks, 1.6 units across. Only
  // worldFromObject changes; the field is decoded for the eye in its own space.
  if (!options.fieldPath.empty()) e.glass->worldFromObject = fitInto(*e.glass, 1.6f);

  shrefract::RendererCreateInfo rci;
  rci.colorFormat = kColorFormat;  // the engine's pipelines are built for the host's formats
  rci.depthFormat = kDepthFormat;
  e.renderer = take(shrefract::Renderer::create(context, rci), "Renderer::create");
  e.decompressor = take(shrefract::Decompressor::create(context), "Decompressor::create");
  // Optional: build the pipeline now rather than on the first record() (no hitch in frame 1).
  require(e.decompressor->prepare(e.glass->fieldOrder()), "Decompressor::prepare");
  return e;
}

shrefract::Camera sceneCamera() {
  shrefract::Camera camera;
  camera.eye = {0.0f, 0.0f, 4.0f};
  camera.target = {0.0f, 0.0f, 0.0f};
  camera.verticalFovDegrees = 45.0f;
  camera.nearPlane = 0.05f;
  camera.farPlane = 100.0f;
  return camera;
}

// What every frame draws, and into what.
struct FrameScene {
  VkExtent2D extent{};
  const Image& color;
  const Image& depth;
  const BoxPipeline& boxes;
  const std::array<BoxPush, 2>& boxList;
  const shrefract::Camera& camera;
  const std::vector<shrefract::Object*>& drawList;
  const EngineObjects& engine;
};

// (b) The host's targets become attachments (contents discarded: both are cleared). The source
//     stages order this frame's writes after the previous frame's (same targets, same queue).
void recordAttachmentBarriers(VkCommandBuffer cmd, const FrameScene& s) {
  imageBarrier(cmd, s.color.image, VK_IMAGE_ASPECT_COLOR_BIT,
               VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_NONE,
               VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
               VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
  imageBarrier(cmd, s.depth.image, VK_IMAGE_ASPECT_DEPTH_BIT,
               VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
               VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
               VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
               VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
               VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
}

// (c) One dynamic rendering scope for everything: host opaque geometry first (it fills depth),
//     then the engine's background (drawn at the far plane, so only where nothing was drawn),
//     then the glass (depth-tested: hidden behind the red box, covering the green one).
void recordDrawing(VkCommandBuffer cmd, const FrameScene& s) {
  VkRenderingAttachmentInfo colorAttachment{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  colorAttachment.imageView = s.color.view;
  colorAttachment.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  colorAttachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  colorAttachment.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingAttachmentInfo depthAttachment{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAttachment.imageView = s.depth.view;
  depthAttachment.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depthAttachment.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  depthAttachment.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  depthAttachment.clearValue.depthStencil = {1.0f, 0};  // the engine expects LESS against 1.0
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, s.extent};
  ri.layerCount = 1;
  ri.colorAttachmentCount = 1;
  ri.pColorAttachments = &colorAttachment;
  ri.pDepthAttachment = &depthAttachment;
  vkCmdBeginRendering(cmd, &ri);
  const VkViewport viewport{0.0f, 0.0f, float(s.extent.width), float(s.extent.height), 0.0f, 1.0f};
  const VkRect2D scissor{{0, 0}, s.extent};
  vkCmdSetViewport(cmd, 0, 1, &viewport);  // dynamic state the engine's pipelines use too
  vkCmdSetScissor(cmd, 0, 1, &scissor);

  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, s.boxes.pipeline);
  for (const BoxPush& box : s.boxList) {
    vkCmdPushConstants(cmd, s.boxes.layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                       sizeof(BoxPush), &box);
    vkCmdDraw(cmd, 36, 1, 0, 0);
  }
  // The engine binds its own pipelines, descriptor sets and push constants; a host drawing after
  // these calls must bind its own state again.
  s.engine.renderer->recordBackground(cmd, *s.engine.environment, s.camera, s.extent);
  s.engine.renderer->recordObjects(cmd, *s.engine.environment, s.camera, s.extent, s.drawList,
                                   shrefract::ShadingMode::Field);
  vkCmdEndRendering(cmd);
}

// (d) Last frame: copy the colour target into the host-visible buffer.
void recordReadback(VkCommandBuffer cmd, const FrameScene& s, VkBuffer readback) {
  imageBarrier(cmd, s.color.image, VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
               VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
               VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {s.extent.width, s.extent.height, 1};
  vkCmdCopyImageToBuffer(cmd, s.color.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback, 1, &region);
  bufferBarrier(cmd, readback, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

// One frame in `frame`'s slot, submitted; with `readback`, the last one, which copies its image
// there.
void drawFrame(Host& host, Frame& frame, shrefract::Context& context, const FrameScene& s, VkBuffer readback) {
  // Wait until the GPU is done with this slot's previous frame, then tell the engine: it releases
  // what it retired kFramesInFlight frames ago (here: the upload's staging buffers).
  host.wait(frame);
  context.beginFrame();
  host.beginRecording(frame);
  VkCommandBuffer cmd = frame.cmd;

  // (a) Decompression: a compute pass, so it must be recorded outside dynamic rendering. It
  //     brings its own barriers (waits for last frame's fragment reads, hands the distortion
  //     image to this frame's fragment shaders). Pass the eye the raster pass will use.
  require(s.engine.decompressor->record(cmd, s.camera.eye, s.drawList), "Decompressor::record");
  recordAttachmentBarriers(cmd, s);
  recordDrawing(cmd, s);
  if (readback) recordReadback(cmd, s, readback);
  host.submit(frame);
}

// RGBA8 sRGB texels -> binary PPM (RGB).
void writePpm(const Host& host, const Readback& readback, VkExtent2D extent, const std::string& path) {
  void* mapped = nullptr;
  check(vkMapMemory(host.device, readback.memory, 0, VK_WHOLE_SIZE, 0, &mapped), "vkMapMemory");
  const auto* texels = static_cast<const uint8_t*>(mapped);
  std::ofstream out(path, std::ios::binary);
  out << "P6\n" << extent.width << " " << extent.height << "\n255\n";
  for (size_t i = 0; i < size_t(extent.width) * extent.height; ++i) out.write(reinterpret_cast<const char*>(texels + 4 * i), 3);
  vkUnmapMemory(host.device, readback.memory);
  if (!out) throw Failure{path + ": cannot write"};
}

// What run() creates on the host's device, released by the destructor in reverse order of
// creation whether the run completes or a step throws: a Failure part-way (a missing field file,
// an unwritable output) must not leave objects for the device's destruction, which the validation
// layer reports as leaks.
struct RunResources {
  explicit RunResources(Host& h) : host(h) {}
  RunResources(const RunResources&) = delete;
  RunResources& operator=(const RunResources&) = delete;
  ~RunResources();

  Host& host;
  std::unique_ptr<shrefract::Context> context;
  Image color, depth;
  Readback readback;
  BoxPipeline boxes;
  EngineObjects engine;
};

RunResources::~RunResources() {
  vkDeviceWaitIdle(host.device);  // after a throw, frames may still be in flight
  // The engine's destructors retire their Vulkan objects; with the device idle, releaseDeferred()
  // frees them now. The context goes before the device it borrows.
  engine.glass.reset();
  engine.environment.reset();
  engine.decompressor.reset();
  engine.renderer.reset();
  if (context) context->releaseDeferred();
  context.reset();
  vkDestroyPipeline(host.device, boxes.pipeline, nullptr);
  vkDestroyPipelineLayout(host.device, boxes.layout, nullptr);
  vkDestroyBuffer(host.device, readback.buffer, nullptr);
  vkFreeMemory(host.device, readback.memory, nullptr);
  host.destroy(color);
  host.destroy(depth);
}

void run(const Options& options) {
  Host host;
  RunResources r(host);  // 7. Teardown: its destructor, before the Host's
  const VkExtent2D extent = options.extent;

  // --- 1. The engine borrows the host's handles. ------------------------------------------------
  r.context = createContext(host);

  // --- 2. Host render targets: colour (copied out at the end) and depth, shared with the engine.
  r.color = host.createImage(extent, kColorFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                             VK_IMAGE_ASPECT_COLOR_BIT);
  r.depth = host.createImage(extent, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                             VK_IMAGE_ASPECT_DEPTH_BIT);
  r.readback = createReadback(host, extent);
  r.boxes = createBoxPipeline(host.device);

  // --- 3. Engine resources, uploaded through a host command buffer. -----------------------------
  r.engine = createEngineObjects(host, *r.context, options);

  // --- 4. The scene: camera, the host's boxes, the glass. ---------------------------------------
  const shrefract::Camera camera = sceneCamera();
  const Mat4 clip = clipFromWorld(camera, extent);
  // Red box in front of the glass, overlapping its lower-left corner; green box behind it,
  // half behind the glass's right edge.
  const std::array<BoxPush, 2> boxList = {BoxPush{clip, {-0.75f, -0.55f, 1.2f, 0.35f}, {0.85f, 0.08f, 0.06f, 1.0f}},
                                          BoxPush{clip, {1.1f, 0.7f, -1.5f, 0.5f}, {0.08f, 0.75f, 0.12f, 1.0f}}};
  const std::vector<shrefract::Object*> drawList = options.glass
                                                       ? std::vector<shrefract::Object*>{r.engine.glass.get()}
                                                       : std::vector<shrefract::Object*>{};
  const FrameScene scene{extent, r.color, r.depth, r.boxes, boxList, camera, drawList, r.engine};

  // --- 5. Frames. -------------------------------------------------------------------------------
  for (uint32_t frameIndex = 0; frameIndex < options.frames; ++frameIndex)
    drawFrame(host, host.frames[frameIndex % kFramesInFlight], *r.context, scene,
              frameIndex + 1 == options.frames ? r.readback.buffer : VK_NULL_HANDLE);
  check(vkDeviceWaitIdle(host.device), "vkDeviceWaitIdle");

  // --- 6. The image: RGBA8 sRGB texels -> binary PPM (RGB). ------------------------------------
  writePpm(host, r.readback, extent, options.output);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  try {
    options = parseOptions(argc, argv);
    run(options);  // the Host (device, instance) is destroyed on return, with the messenger last
  } catch (const integration::Failure& f) {
    std::fprintf(stderr, "shrefract_integration: %s\n", f.message.c_str());
    return f.exitCode;
  }
  if (const uint32_t messages = integration::validationMessageCount(); messages != 0) {
    std::fprintf(stderr, "shrefract_integration: %u Vulkan validation message(s)\n", messages);
    return 1;
  }
  std::printf("shrefract_integration: wrote %s (%ux%u, %s), 0 validation messages\n", options.output.c_str(),
              options.extent.width, options.extent.height, options.glass ? "with glass" : "no glass");
  return 0;
}
