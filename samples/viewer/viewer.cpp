#include "viewer/viewer.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <shrefract/context.h>
#include <shrefract/decompressor.h>
#include <shrefract/environment.h>

#include <algorithm>
#include <cmath>
#include <array>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "offscreen/offscreen.h"
#include "viewer/field_order.h"
#include "viewer/orbit_camera.h"
#include "viewer/swapchain.h"
#include "viewer/view_state.h"
#include "viewer/window_input.h"

namespace shrefract::viewer {
namespace {

// Frames the CPU records ahead of the GPU. Equal to ContextCreateInfo::framesInFlight (the
// offscreen session creates the context with the default, 2): beginFrame() then releases what was
// retired two frames ago, which is safe once this frame slot's fence has been waited on.
constexpr uint32_t kFramesInFlight = 2;
// Timestamp queries per frame: decompression begin/end, raster begin/end.
constexpr uint32_t kTimestamps = 4;
// How often the window title (frame and GPU times) is refreshed.
constexpr double kTitleIntervalSeconds = 0.25;
// The engine draws into a float target: screenshots keep the renderer's linear values, and the
// blit to the swapchain does the sRGB encoding.
constexpr VkFormat kColorFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

// GLFW reports errors through a process-wide callback; the viewer runs on one thread.
std::string gGlfwError = "no error reported";
void onGlfwError(int code, const char* text) {
  gGlfwError = std::string(text ? text : "(no text)") + " (GLFW error " + std::to_string(code) + ")";
}

int fail(const std::string& message) {
  std::fprintf(stderr, "shrefract view: %s\n", message.c_str());
  return 1;
}

Error vkError(const char* what, VkResult r) {
  return makeError(ErrorCode::Vulkan, std::string(what) + " failed (VkResult " + std::to_string(r) + ")", r);
}

// Per frame in flight: the command buffer, the fence that says the GPU is done with it, the
// semaphore the swapchain signals when the acquired image may be written, and the timestamps.
struct FrameSlot {
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  VkSemaphore acquired = VK_NULL_HANDLE;
  VkQueryPool queries = VK_NULL_HANDLE;
  bool timestampsWritten = false;  // the queries hold this slot's last frame
};

// Everything the viewer owns, torn down in dependency order.
struct Host {
  bool glfwReady = false;
  GLFWwindow* window = nullptr;
  std::unique_ptr<offscreen::Session> session;
  VkSurfaceKHR surface = VK_NULL_HANDLE;
  std::unique_ptr<Swapchain> swapchain;
  VkCommandPool pool = VK_NULL_HANDLE;
  std::array<FrameSlot, kFramesInFlight> slots{};
  harness::Harness::Image color{}, depth{};
  // With MSAA, color and depth are multisampled and `resolve` is the single-sample image the frame
  // is averaged into: what is blitted and read back (shown()).
  harness::Harness::Image resolve{};
  VkExtent2D targetExtent{};
  bool linearBlit = false;  // the colour format can be blitted with a linear filter

  std::vector<std::unique_ptr<Environment>> environments;
  std::unique_ptr<Renderer> renderer;
  std::unique_ptr<Decompressor> decompressor;
  std::vector<std::unique_ptr<Object>> sceneObjects;
  std::vector<std::unique_ptr<Object>> fieldObjects;  // one per field, built at fieldObjectOrders[i]
  std::vector<uint32_t> fieldObjectOrders;
  // Extra instances of the shown field object (ViewState::instances - 1), rebuilt with it.
  std::vector<std::unique_ptr<Object>> instances;
  // Which field object they are instances of: (field, order) names it (an address could be reused).
  std::pair<size_t, uint32_t> instancesOf{SIZE_MAX, 0};

  VkDevice device() const { return session->harness->device(); }
  const harness::Harness::Image& shown() const { return resolve.image ? resolve : color; }

  // Destroys every Vulkan object but the device and instance (which the session owns; the frame
  // loop's end then destroys the session and counts what the layer reported through it).
  void releaseGpuObjects() {
    if (!session) return;
    vkDeviceWaitIdle(device());
    instances.clear();
    fieldObjects.clear();
    sceneObjects.clear();
    environments.clear();
    renderer.reset();
    decompressor.reset();
    session->context->releaseDeferred();  // the device is idle: nothing retired is in use
    session->harness->destroyImage(color);
    session->harness->destroyImage(depth);
    session->harness->destroyImage(resolve);
    for (FrameSlot& s : slots) {
      if (s.queries) vkDestroyQueryPool(device(), s.queries, nullptr);
      if (s.fence) vkDestroyFence(device(), s.fence, nullptr);
      if (s.acquired) vkDestroySemaphore(device(), s.acquired, nullptr);
      s = FrameSlot{};
    }
    if (pool) vkDestroyCommandPool(device(), pool, nullptr);
    pool = VK_NULL_HANDLE;
    swapchain.reset();
    if (surface) vkDestroySurfaceKHR(session->harness->instance(), surface, nullptr);
    surface = VK_NULL_HANDLE;
  }

  ~Host() {
    releaseGpuObjects();
    session.reset();
    if (window) glfwDestroyWindow(window);
    if (glfwReady) glfwTerminate();
  }
};

Result<void> createFrameSlots(Host& h, bool timestamps) {
  VkCommandPoolCreateInfo pci{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = h.session->harness->queueFamily();
  VkResult r = vkCreateCommandPool(h.device(), &pci, nullptr, &h.pool);
  if (r != VK_SUCCESS) return vkError("vkCreateCommandPool", r);
  for (FrameSlot& s : h.slots) {
    VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ai.commandPool = h.pool;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    if ((r = vkAllocateCommandBuffers(h.device(), &ai, &s.cmd)) != VK_SUCCESS)
      return vkError("vkAllocateCommandBuffers", r);
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    fci.flags = VK_FENCE_CREATE_SIGNALED_BIT;  // the first wait on each slot returns at once
    if ((r = vkCreateFence(h.device(), &fci, nullptr, &s.fence)) != VK_SUCCESS) return vkError("vkCreateFence", r);
    VkSemaphoreCreateInfo sci{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    if ((r = vkCreateSemaphore(h.device(), &sci, nullptr, &s.acquired)) != VK_SUCCESS)
      return vkError("vkCreateSemaphore", r);
    if (timestamps) {
      VkQueryPoolCreateInfo qci{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
      qci.queryType = VK_QUERY_TYPE_TIMESTAMP;
      qci.queryCount = kTimestamps;
      if ((r = vkCreateQueryPool(h.device(), &qci, nullptr, &s.queries)) != VK_SUCCESS)
        return vkError("vkCreateQueryPool", r);
    }
  }
  return {};
}

// (Re)creates the colour and depth targets the engine draws into, with `samples` per pixel (and
// then the single-sample resolve target). Precondition: the device is idle.
Result<void> createTargets(Host& h, VkExtent2D extent, VkSampleCountFlagBits samples) {
  harness::Harness& hr = *h.session->harness;
  hr.destroyImage(h.color);
  hr.destroyImage(h.depth);
  hr.destroyImage(h.resolve);
  const VkImageUsageFlags shownUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  const bool msaa = samples != VK_SAMPLE_COUNT_1_BIT;
  auto color = hr.createImage(extent.width, extent.height, kColorFormat,
                              msaa ? VkImageUsageFlags(VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT) : shownUsage,
                              VK_IMAGE_ASPECT_COLOR_BIT, samples);
  if (!color) return color.error();
  h.color = color.value();
  auto depth = hr.createImage(extent.width, extent.height, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                              VK_IMAGE_ASPECT_DEPTH_BIT, samples);
  if (!depth) return depth.error();
  h.depth = depth.value();
  if (msaa) {
    auto resolve = hr.createImage(extent.width, extent.height, kColorFormat, shownUsage, VK_IMAGE_ASPECT_COLOR_BIT);
    if (!resolve) return resolve.error();
    h.resolve = resolve.value();
  }
  h.targetExtent = extent;
  return {};
}

VkExtent2D framebufferExtent(GLFWwindow* window) {
  int width = 0, height = 0;
  glfwGetFramebufferSize(window, &width, &height);
  return {static_cast<uint32_t>(std::max(width, 0)), static_cast<uint32_t>(std::max(height, 0))};
}

// How the title names a field's encoding: SH shows its run-time order instead.
std::string encodingLabel(const Field& f) {
  if (f.encoding == Encoding::Table) return "table " + std::to_string(f.tableSize) + "x" + std::to_string(f.tableSize);
  if (f.encoding == Encoding::Pca) return "pca K=" + std::to_string(f.components);
  if (f.encoding == Encoding::Volume) return "volume " + std::to_string(f.volume.size) + "^3";
  return "sh";
}

// Makes sure the shown field has an engine object at the state's order, recording the upload into
// `cmd` (the frame's own command buffer: the engine's uploads end with the barriers that make them
// visible to the decompression and raster passes recorded after them). The replaced object retires
// through the context's deferred destruction, so frames still in flight keep using it safely.
Result<void> ensureFieldObject(Host& h, const ViewerOptions& options, const ViewState& state, VkCommandBuffer cmd) {
  const size_t i = state.field;
  if (h.fieldObjects[i] && h.fieldObjectOrders[i] == state.order) return {};
  const Field& baked = options.fields[i];
  Result<std::unique_ptr<Object>> created = makeError(ErrorCode::InvalidArgument, "not created");
  if (state.order == baked.order) {
    created = Object::createFromField(*h.session->context, baked, cmd);
  } else {
    auto truncated = truncateOrder(baked, state.order);
    if (!truncated) return truncated.error();
    created = Object::createFromField(*h.session->context, truncated.value(), cmd);
  }
  if (!created) return makeError(created.error().code, options.fieldNames[i] + ": " + created.error().message);
  h.fieldObjects[i] = std::move(created).value();
  h.fieldObjectOrders[i] = state.order;
  return {};
}

// Makes the shown field object's extra instances match the state: state.instances - 1 of them,
// side by side along x (a bounds width and a half apart), each turned about y, so that they are
// seen from other sides. Uploads nothing: the instances share the object's data.
Result<void> ensureInstances(Host& h, const ViewState& state, Object& shown, VkCommandBuffer cmd) {
  const size_t wanted = state.instances - 1;
  const std::pair<size_t, uint32_t> of{state.field, state.order};
  if (h.instancesOf == of && h.instances.size() == wanted) return {};
  h.instances.clear();  // retired through the context, as replaced field objects are
  h.instancesOf = of;
  const std::array<float, 3> lo = shown.objectBoundsMin(), hi = shown.objectBoundsMax();
  const float step = 1.5f * std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  for (size_t k = 0; k < wanted; ++k) {
    auto created = Object::createInstance(*h.session->context, shown, cmd);
    if (!created) return created.error();
    Object& o = *created.value();
    const float side = k % 2 == 0 ? 1.0f : -1.0f, angle = side * 0.6f * float(k / 2 + 1);
    o.worldFromObject.rotation = std::array<float, 4>{0.0f, std::sin(0.5f * angle), 0.0f, std::cos(0.5f * angle)};
    // Turned about the object's own centre, then moved aside.
    const std::array<float, 3> centre{0.5f * (lo[0] + hi[0]), 0.5f * (lo[1] + hi[1]), 0.5f * (lo[2] + hi[2])};
    const std::array<float, 3> turned = rotateDirection(o.worldFromObject, centre);
    for (int a = 0; a < 3; ++a) o.worldFromObject.translation[size_t(a)] = centre[size_t(a)] - turned[size_t(a)];
    o.worldFromObject.translation[0] += side * step * float(k / 2 + 1);
    h.instances.push_back(std::move(created).value());
  }
  return {};
}

using harness::imageBarrier;

struct FrameInputs {
  const Environment* environment = nullptr;
  std::vector<Object*> objects;
  ShadingMode mode = ShadingMode::SingleInterface;
  Camera camera;
  VkImage swapchainImage = VK_NULL_HANDLE;
};

// The engine's raster pass inside our dynamic rendering, on the targets harness::attachmentBarriers()
// made attachments.
void recordRendering(const Host& h, VkCommandBuffer cmd, const FrameInputs& in) {
  // With MSAA the frame is averaged into the resolve target; the samples are not kept.
  const bool msaa = h.resolve.image != VK_NULL_HANDLE;
  harness::beginDynamicRendering(cmd, h.color, h.depth, msaa ? &h.resolve : nullptr,
                                 msaa ? VK_ATTACHMENT_STORE_OP_DONT_CARE : VK_ATTACHMENT_STORE_OP_STORE);
  h.renderer->recordBackground(cmd, *in.environment, in.camera, h.targetExtent);
  h.renderer->recordObjects(cmd, *in.environment, in.camera, h.targetExtent, in.objects, in.mode);
  vkCmdEndRendering(cmd);
}

// Target -> swapchain image. The swapchain image's first use waits on the acquire semaphore at
// the blit stage (see the submit), so its barrier starts from that stage.
void recordBlitToSwapchain(const Host& h, VkCommandBuffer cmd, VkImage swapchainImage) {
  imageBarrier(cmd, h.shown().image, VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
               VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_BLIT_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
               VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  imageBarrier(cmd, swapchainImage, VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_BLIT_BIT, VK_ACCESS_2_NONE,
               VK_PIPELINE_STAGE_2_BLIT_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
               VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
  const VkExtent2D dst = h.swapchain->extent();
  VkImageBlit region{};
  region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.srcOffsets[1] = {static_cast<int32_t>(h.targetExtent.width), static_cast<int32_t>(h.targetExtent.height), 1};
  region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.dstOffsets[1] = {static_cast<int32_t>(dst.width), static_cast<int32_t>(dst.height), 1};
  const bool sameSize = dst.width == h.targetExtent.width && dst.height == h.targetExtent.height;
  vkCmdBlitImage(cmd, h.shown().image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, swapchainImage,
                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region,
                 !sameSize && h.linearBlit ? VK_FILTER_LINEAR : VK_FILTER_NEAREST);
  // Presentation needs no access mask: the present waits on the semaphore signalled after this.
  imageBarrier(cmd, swapchainImage, VK_IMAGE_ASPECT_COLOR_BIT, VK_PIPELINE_STAGE_2_BLIT_BIT,
               VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_NONE, VK_ACCESS_2_NONE,
               VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);
}

// One frame: decompression (outside rendering), the engine's raster pass inside our dynamic
// rendering, then the blit of the target to the swapchain image.
Result<void> recordFrame(Host& h, FrameSlot& slot, const FrameInputs& in) {
  VkCommandBuffer cmd = slot.cmd;
  if (slot.queries) {
    vkCmdResetQueryPool(cmd, slot.queries, 0, kTimestamps);
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT, slot.queries, 0);
  }
  if (in.mode == ShadingMode::Field && h.decompressor)
    if (auto r = h.decompressor->record(cmd, in.camera.eye, in.objects); !r) return r;
  if (slot.queries) vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, slot.queries, 1);

  // The targets are cleared every frame (old contents discarded), after the previous frame's
  // blit out of them on the same queue.
  harness::attachmentBarriers(cmd, h.color, h.depth, h.resolve.image ? &h.resolve : nullptr);

  if (slot.queries) vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, slot.queries, 2);
  recordRendering(h, cmd, in);
  if (slot.queries) vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, slot.queries, 3);

  recordBlitToSwapchain(h, cmd, in.swapchainImage);
  return {};
}

// The set-up steps before the frame loop return the exit code to stop with (its line already
// printed), or nothing to go on: unlike the loop's failures, some of theirs exit with 2.
using Exit = std::optional<int>;

Exit openWindow(Host& h, const ViewerOptions& options) {
  glfwSetErrorCallback(onGlfwError);
  if (!glfwInit()) return fail("cannot open a window: " + gGlfwError);
  h.glfwReady = true;
  if (!glfwVulkanSupported()) return fail("GLFW finds no Vulkan loader: " + gGlfwError);
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);  // Vulkan draws; no OpenGL context
  // A screenshot is taken at the requested size: the window must not be resized under it.
  glfwWindowHint(GLFW_RESIZABLE, options.screenshot.empty() ? GLFW_TRUE : GLFW_FALSE);
  h.window = glfwCreateWindow(static_cast<int>(options.width), static_cast<int>(options.height), "shrefract view",
                              nullptr, nullptr);
  if (!h.window) return fail("cannot create a window: " + gGlfwError);
  return std::nullopt;
}

// The session, and the checks of the flags that name the device: a device index or an MSAA count it
// lacks exits with 2, as a usage error.
Exit startVulkan(Host& h, const ViewerOptions& options) {
  harness::HarnessOptions ho;
  ho.enableValidation = options.validation;
  ho.deviceIndex = options.deviceIndex;
  uint32_t glfwExtensionCount = 0;
  const char** glfwExtensions = glfwGetRequiredInstanceExtensions(&glfwExtensionCount);
  if (!glfwExtensions)
    return fail("no Vulkan driver offers a surface extension for this window system (no Vulkan device that can "
                "present?): " + gGlfwError);
  ho.instanceExtensions.assign(glfwExtensions, glfwExtensions + glfwExtensionCount);
  ho.deviceExtensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
  auto session = offscreen::createSession(ho);
  if (!session && options.deviceIndex >= 0 && session.error().code == ErrorCode::InvalidArgument) {
    // A device index the machine does not have is a usage error naming the flag (as in render).
    std::fprintf(stderr, "shrefract view: --device %d: %s\n", options.deviceIndex, session.error().message.c_str());
    return 2;
  }
  if (!session) return fail(session.error().message);
  h.session = std::move(session).value();
  harness::Harness& hr = *h.session->harness;
  // An MSAA count the device lacks is the flag's fault, as in render: named before any target.
  const VkPhysicalDeviceLimits& limits = hr.properties().limits;
  if (!(limits.framebufferColorSampleCounts & limits.framebufferDepthSampleCounts & options.msaa)) {
    std::fprintf(stderr, "shrefract view: --msaa %u: %s offers no %u-sample colour and depth targets\n",
                 uint32_t(options.msaa), hr.deviceName().c_str(), uint32_t(options.msaa));
    return 2;
  }
  return std::nullopt;
}

// The window's surface and swapchain; `framebuffer` is set to the window size it was made for.
Exit createSwapchain(Host& h, const ViewerOptions& options, VkExtent2D& framebuffer) {
  harness::Harness& hr = *h.session->harness;
  const VkResult vr = glfwCreateWindowSurface(hr.instance(), h.window, nullptr, &h.surface);
  if (vr != VK_SUCCESS) return fail("glfwCreateWindowSurface failed (VkResult " + std::to_string(vr) + "): " + gGlfwError);
  VkBool32 presentable = VK_FALSE;
  vkGetPhysicalDeviceSurfaceSupportKHR(hr.physicalDevice(), hr.queueFamily(), h.surface, &presentable);
  if (!presentable)
    return fail("the queue family of " + hr.deviceName() + " cannot present to this window");
  h.swapchain = std::make_unique<Swapchain>(hr.physicalDevice(), hr.device(), h.surface);
  framebuffer = framebufferExtent(h.window);
  if (auto r = h.swapchain->create(framebuffer, options.vsync); !r) return fail(r.error().message);
  VkFormatProperties colorProps{};
  vkGetPhysicalDeviceFormatProperties(hr.physicalDevice(), kColorFormat, &colorProps);
  h.linearBlit = (colorProps.optimalTilingFeatures & VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT) != 0;
  return std::nullopt;
}

// The environments and the renderer, created with `rci` (which the frame loop keeps: T rebuilds
// the renderer from it).
Exit createEnvironmentsAndRenderer(Host& h, const ViewerOptions& options, RendererCreateInfo& rci) {
  for (size_t i = 0; i < options.environments.size(); ++i) {
    auto env = offscreen::uploadEnvironment(*h.session, options.environments[i]);
    if (!env) return fail(options.environmentNames[i] + ": " + env.error().message);
    h.environments.push_back(std::move(env).value());
  }
  rci.colorFormat = kColorFormat;
  rci.depthFormat = kDepthFormat;
  rci.exposure = options.exposure;
  rci.environmentTapsPerAxis = options.environmentTaps;
  rci.sampleCount = options.msaa;
  auto renderer = Renderer::create(*h.session->context, rci);
  if (!renderer) return fail(renderer.error().message);
  h.renderer = std::move(renderer).value();
  return std::nullopt;
}

// What is shown first, and the camera that frames it: the scene's objects, or the fields' state
// (their engine objects are created by the frames, at the order shown) and the decompressor.
Exit prepareContent(Host& h, const ViewerOptions& options, ViewState& state, Camera& initialCamera) {
  state.environmentTaps = options.environmentTaps;
  state.environmentCount = options.environments.size();
  state.absorption = options.absorption;
  if (options.scene) {
    auto uploaded = offscreen::uploadScene(*h.session, *options.scene);
    if (!uploaded) return fail(options.sceneName + ": " + uploaded.error().message);
    h.sceneObjects = std::move(uploaded).value();
    state.mode = ShadingMode::SingleInterface;
    initialCamera = offscreen::defaultCamera(*options.scene, options.verticalFovDegrees);
    return std::nullopt;
  }
  for (size_t i = 0; i < options.fields.size(); ++i)
    state.fields.push_back({options.fieldNames[i], options.fields[i].order, toString(options.fields[i].settings.layout),
                            encodingLabel(options.fields[i])});
  state.order = std::min(options.order.value_or(options.fields[0].order), options.fields[0].order);
  state.mode = options.mode;
  h.fieldObjects.resize(options.fields.size());
  h.fieldObjectOrders.assign(options.fields.size(), 0);
  auto decompressor = Decompressor::create(*h.session->context);
  if (!decompressor) return fail(decompressor.error().message);
  h.decompressor = std::move(decompressor).value();
  // The pipeline now, so that the first frames time the work and not the shader compiler.
  if (auto r = h.decompressor->prepare(state.order); !r) return fail(r.error().message);
  std::array<float, 3> lo{}, hi{};
  offscreen::meshBounds(options.fields[0].mesh, lo, hi);
  initialCamera = offscreen::frameBounds(lo, hi, options.verticalFovDegrees);
  return std::nullopt;
}

const char* presentModeName(VkPresentModeKHR mode) {
  return mode == VK_PRESENT_MODE_FIFO_KHR        ? "fifo"
         : mode == VK_PRESENT_MODE_IMMEDIATE_KHR ? "immediate"
         : mode == VK_PRESENT_MODE_MAILBOX_KHR   ? "mailbox"
                                                 : "other";
}

// The frame loop and what it keeps from frame to frame: the view state the keys change, the
// camera the mouse moves, the swapchain's size and the timings the title shows. Its failures are
// errors that runViewer() prints (exit code 1).
struct FrameLoop {
  using Clock = std::chrono::steady_clock;

  FrameLoop(Host& host, const ViewerOptions& viewerOptions, const RendererCreateInfo& rendererInfo,
            const ViewState& initialState, const Camera& initialCamera, bool withTimestamps, bool fixed,
            VkExtent2D framebuffer)
      : h(host), options(viewerOptions), rci(rendererInfo), state(initialState), orbit(initialCamera),
        timestamps(withTimestamps), fixedTarget(fixed), swapchainFramebuffer(framebuffer) {
    input.camera = &orbit;
    listenForInput(h.window, input);
  }
  FrameLoop(const FrameLoop&) = delete;  // the window's callbacks hold &input
  FrameLoop& operator=(const FrameLoop&) = delete;

  Result<void> run();
  int finish();

  Host& h;
  const ViewerOptions& options;
  RendererCreateInfo rci;
  ViewState state;
  OrbitCamera orbit;
  Input input;
  const bool timestamps;   // the frame slots have query pools
  const bool fixedTarget;  // the target keeps the screenshot's size instead of following the window
  VkExtent2D swapchainFramebuffer;  // the window size the swapchain was made for

  Clock::time_point titleTime, lastFrame;
  double frameMsSum = 0.0;
  uint32_t frameMsCount = 0;
  double frameMs = -1.0, decompressionMs = -1.0, rasterMs = -1.0;
  bool titleDirty = true;
  bool recreate = false;
  uint64_t frame = 0;
  size_t keyCursor = 0;
  const double period = double(h.session->harness->properties().limits.timestampPeriod) * 1e-6;  // ticks -> ms

 private:
  void takeInput();
  Result<void> applyCameraAndTaps();
  Result<void> recreateSwapchainIfNeeded(VkExtent2D fb);
  Result<std::optional<uint32_t>> acquireImage(FrameSlot& slot);
  Result<FrameInputs> frameInputs(VkCommandBuffer cmd, uint32_t imageIndex);
  Result<void> recordAndSubmit(FrameSlot& slot, uint32_t imageIndex);
  Result<void> present(uint32_t imageIndex);
  void readTimestamps(FrameSlot& slot);
  std::string makeTitle() const;
  void countFrameTime();
};

Result<void> FrameLoop::run() {
  titleTime = Clock::now();
  lastFrame = Clock::now();
  while (!glfwWindowShouldClose(h.window) && (options.frames == 0 || frame < options.frames)) {
    glfwPollEvents();
    takeInput();
    if (state.quit) break;
    if (auto r = applyCameraAndTaps(); !r) return r;

    // A minimized window has no area to present to: wait for it to come back.
    const VkExtent2D fb = framebufferExtent(h.window);
    if (fb.width == 0 || fb.height == 0) {
      glfwWaitEvents();
      continue;
    }
    if (auto r = recreateSwapchainIfNeeded(fb); !r) return r;

    FrameSlot& slot = h.slots[frame % kFramesInFlight];
    auto acquired = acquireImage(slot);
    if (!acquired) return acquired.error();
    if (!acquired.value()) continue;  // out of date: re-created at the top of the loop
    const uint32_t imageIndex = *acquired.value();
    if (auto r = recordAndSubmit(slot, imageIndex); !r) return r;
    if (auto r = present(imageIndex); !r) return r;
    ++frame;
    countFrameTime();
  }
  return {};
}

void FrameLoop::takeInput() {
  // --keys: character i acts at the start of frame i (once, even if the frame is retried).
  if (keyCursor <= frame && keyCursor < options.keys.size())
    if (auto action = actionForCharacter(options.keys[keyCursor++])) input.actions.push_back(*action);
  for (Action a : input.actions) titleDirty = apply(state, a) || titleDirty;
  input.actions.clear();
}

Result<void> FrameLoop::applyCameraAndTaps() {
  if (state.resetCamera) {
    orbit.reset();
    state.resetCamera = false;
  }
  // T, P: the tap count and the volume's refinement are specialization constants of the renderer's
  // pipelines, so a new setting is a new renderer; the frames in flight may still use the old
  // one's pipelines (a key press is rare enough to wait for them).
  if (state.environmentTaps != rci.environmentTapsPerAxis || state.refineVolumePaths != rci.refineVolumePaths) {
    vkDeviceWaitIdle(h.device());
    rci.environmentTapsPerAxis = state.environmentTaps;
    rci.refineVolumePaths = state.refineVolumePaths;
    auto rebuilt = Renderer::create(*h.session->context, rci);
    if (!rebuilt) return rebuilt.error();
    h.renderer = std::move(rebuilt).value();
  }
  return {};
}

Result<void> FrameLoop::recreateSwapchainIfNeeded(VkExtent2D fb) {
  // Re-create on a new window size (compared with the size it was made for: the surface may
  // pick another extent) or when presentation reported the swapchain out of date.
  if (recreate || fb.width != swapchainFramebuffer.width || fb.height != swapchainFramebuffer.height) {
    vkDeviceWaitIdle(h.device());
    if (auto r = h.swapchain->create(fb, options.vsync); !r) return r;
    swapchainFramebuffer = fb;
    if (!fixedTarget)
      if (auto r = createTargets(h, h.swapchain->extent(), options.msaa); !r) return r;
    recreate = false;
  }
  return {};
}

// Waits for the slot's previous frame, then acquires the image to draw: none when the swapchain
// is out of date.
Result<std::optional<uint32_t>> FrameLoop::acquireImage(FrameSlot& slot) {
  vkWaitForFences(h.device(), 1, &slot.fence, VK_TRUE, UINT64_MAX);
  // The slot's previous frame is complete: its timestamps can be read and what the engine retired
  // framesInFlight frames ago can be released.
  readTimestamps(slot);
  uint32_t imageIndex = 0;
  const VkResult vr = vkAcquireNextImageKHR(h.device(), h.swapchain->handle(), UINT64_MAX, slot.acquired,
                                            VK_NULL_HANDLE, &imageIndex);
  if (vr == VK_ERROR_OUT_OF_DATE_KHR) {
    recreate = true;  // nothing was signalled; the slot's fence is still signalled
    return std::optional<uint32_t>{};
  }
  if (vr != VK_SUCCESS && vr != VK_SUBOPTIMAL_KHR) return vkError("vkAcquireNextImageKHR", vr);
  return std::optional<uint32_t>{imageIndex};
}

// What the frame draws. Creates the shown field object and its instances when the state changed
// them, recording their uploads into `cmd`.
Result<FrameInputs> FrameLoop::frameInputs(VkCommandBuffer cmd, uint32_t imageIndex) {
  FrameInputs in;
  in.environment = h.environments[state.environment].get();
  in.camera = orbit.camera();
  in.swapchainImage = h.swapchain->image(imageIndex);
  in.mode = state.mode;
  if (state.hasFields()) {
    if (auto r = ensureFieldObject(h, options, state, cmd); !r) return r.error();
    Object* shown = h.fieldObjects[state.field].get();
    shown->shading.absorptionScale = state.absorption;
    in.objects.push_back(shown);
    if (auto r = ensureInstances(h, state, *shown, cmd); !r) return r.error();
    for (auto& instance : h.instances) {
      instance->shading = shown->shading;
      in.objects.push_back(instance.get());
    }
  } else {
    for (auto& o : h.sceneObjects) in.objects.push_back(o.get());
  }
  return in;
}

Result<void> FrameLoop::recordAndSubmit(FrameSlot& slot, uint32_t imageIndex) {
  // Once per submitted frame, after its slot's fence: releases what the engine retired
  // framesInFlight frames ago (replaced field objects, upload staging buffers).
  h.session->context->beginFrame();

  vkResetFences(h.device(), 1, &slot.fence);
  vkResetCommandBuffer(slot.cmd, 0);
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  vkBeginCommandBuffer(slot.cmd, &bi);
  auto in = frameInputs(slot.cmd, imageIndex);
  if (!in) return in.error();
  if (auto r = recordFrame(h, slot, in.value()); !r) return r;
  VkResult vr = vkEndCommandBuffer(slot.cmd);
  if (vr != VK_SUCCESS) return vkError("vkEndCommandBuffer", vr);

  VkSemaphoreSubmitInfo wait{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  wait.semaphore = slot.acquired;
  wait.stageMask = VK_PIPELINE_STAGE_2_BLIT_BIT;  // the swapchain image is first touched by the blit
  VkSemaphoreSubmitInfo signal{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  signal.semaphore = h.swapchain->renderDone(imageIndex);
  signal.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  VkCommandBufferSubmitInfo cbi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
  cbi.commandBuffer = slot.cmd;
  VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  si.waitSemaphoreInfoCount = 1;
  si.pWaitSemaphoreInfos = &wait;
  si.commandBufferInfoCount = 1;
  si.pCommandBufferInfos = &cbi;
  si.signalSemaphoreInfoCount = 1;
  si.pSignalSemaphoreInfos = &signal;
  if ((vr = vkQueueSubmit2(h.session->harness->queue(), 1, &si, slot.fence)) != VK_SUCCESS)
    return vkError("vkQueueSubmit2", vr);
  slot.timestampsWritten = slot.queries != VK_NULL_HANDLE;
  return {};
}

Result<void> FrameLoop::present(uint32_t imageIndex) {
  VkSemaphore renderDone = h.swapchain->renderDone(imageIndex);
  VkSwapchainKHR swapchainHandle = h.swapchain->handle();
  VkPresentInfoKHR pi{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
  pi.waitSemaphoreCount = 1;
  pi.pWaitSemaphores = &renderDone;
  pi.swapchainCount = 1;
  pi.pSwapchains = &swapchainHandle;
  pi.pImageIndices = &imageIndex;
  const VkResult vr = vkQueuePresentKHR(h.session->harness->queue(), &pi);
  if (vr == VK_ERROR_OUT_OF_DATE_KHR || vr == VK_SUBOPTIMAL_KHR) recreate = true;
  else if (vr != VK_SUCCESS) return vkError("vkQueuePresentKHR", vr);
  return {};
}

// GPU times of the frame last submitted from `slot`. Precondition: its fence has signalled.
void FrameLoop::readTimestamps(FrameSlot& slot) {
  if (!slot.queries || !slot.timestampsWritten) return;
  std::array<uint64_t, kTimestamps> ticks{};
  if (vkGetQueryPoolResults(h.device(), slot.queries, 0, kTimestamps, sizeof(ticks), ticks.data(),
                            sizeof(uint64_t), VK_QUERY_RESULT_64_BIT) != VK_SUCCESS)
    return;
  // Near zero while the eye stands still: the Decompressor leaves out objects whose distortion
  // image already holds this eye's decompression.
  decompressionMs = ticks[1] >= ticks[0] ? double(ticks[1] - ticks[0]) * period : 0.0;
  rasterMs = ticks[3] >= ticks[2] ? double(ticks[3] - ticks[2]) * period : 0.0;
}

std::string FrameLoop::makeTitle() const {
  const bool decompressing = state.hasFields() && state.mode == ShadingMode::Field;
  return title(state, options.environmentNames, frameMs, decompressing ? decompressionMs : -1.0,
               timestamps ? rasterMs : -1.0);
}

// Adds the frame just presented to the frame time, and refreshes the title when a key changed the
// state or the interval has passed.
void FrameLoop::countFrameTime() {
  const auto now = Clock::now();
  frameMsSum += std::chrono::duration<double, std::milli>(now - lastFrame).count();
  ++frameMsCount;
  lastFrame = now;
  if (titleDirty || std::chrono::duration<double>(now - titleTime).count() >= kTitleIntervalSeconds) {
    if (frameMsCount) frameMs = frameMsSum / frameMsCount;
    frameMsSum = 0.0;
    frameMsCount = 0;
    titleTime = now;
    titleDirty = false;
    glfwSetWindowTitle(h.window, makeTitle().c_str());
  }
}

// Reads the last frame back, tears down, counts validation messages; returns the exit code.
int FrameLoop::finish() {
  harness::Harness& hr = *h.session->harness;
  vkDeviceWaitIdle(hr.device());
  if (frame > 0) readTimestamps(h.slots[(frame - 1) % kFramesInFlight]);
  if (frameMsCount) frameMs = frameMsSum / frameMsCount;
  const std::string lastTitle = makeTitle();
  std::optional<bake::Image> shot;
  if (!options.screenshot.empty()) {
    if (frame == 0) return fail("no frame was rendered; no screenshot written");
    // The last frame left the target in TRANSFER_SRC_OPTIMAL after its blit.
    auto pixels = hr.readbackColor(h.shown(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    if (!pixels) return fail(pixels.error().message);
    shot = bake::Image{h.targetExtent.width, h.targetExtent.height, std::move(pixels).value()};
  }
  const char* presentMode = presentModeName(h.swapchain->presentMode());
  h.releaseGpuObjects();
  // Counted through the device's and instance's destruction too (leaks are reported only then).
  const std::string deviceName = hr.deviceName();
  const uint32_t messages = offscreen::endSession(std::move(h.session));
  if (messages != 0)
    return fail(std::to_string(messages) + " Vulkan validation message(s)" + (shot ? "; no screenshot written" : ""));
  if (shot)
    if (auto written = bake::writeImage(options.screenshot, *shot); !written) return fail(written.error().message);
  std::printf("shrefract view: %llu frames on %s (present mode %s), 0 validation messages%s%s\n",
              static_cast<unsigned long long>(frame), deviceName.c_str(), presentMode,
              shot ? "; screenshot " : "", shot ? options.screenshot.c_str() : "");
  std::printf("last title: %s\n", lastTitle.c_str());  // the state and the last frame's timings
  return 0;
}

}  // namespace

int runViewer(const ViewerOptions& options) {
  if (options.environments.empty()) return fail("no environment");
  Host h;

  // --- window -------------------------------------------------------------------------------
  if (auto exit = openWindow(h, options)) return *exit;

  // --- Vulkan: the harness creates instance and device with the surface and swapchain extensions
  if (auto exit = startVulkan(h, options)) return *exit;
  VkExtent2D swapchainFramebuffer{};
  if (auto exit = createSwapchain(h, options, swapchainFramebuffer)) return *exit;
  const bool timestamps = h.session->harness->hasTimestamps();
  if (auto r = createFrameSlots(h, timestamps); !r) return fail(r.error().message);
  // A screenshot is taken at the requested size; otherwise the target follows the window.
  const bool fixedTarget = !options.screenshot.empty();
  if (auto r = createTargets(h, fixedTarget ? VkExtent2D{options.width, options.height} : h.swapchain->extent(),
                             options.msaa);
      !r)
    return fail(r.error().message);

  // --- engine objects -----------------------------------------------------------------------
  RendererCreateInfo rci;
  if (auto exit = createEnvironmentsAndRenderer(h, options, rci)) return *exit;
  ViewState state;
  Camera initialCamera;
  if (auto exit = prepareContent(h, options, state, initialCamera)) return *exit;

  // --- frame loop ---------------------------------------------------------------------------
  FrameLoop loop(h, options, rci, state, initialCamera, timestamps, fixedTarget, swapchainFramebuffer);
  if (auto r = loop.run(); !r) return fail(r.error().message);

  // --- exit: read the last frame back, tear down, count validation messages -----------------
  return loop.finish();
}

}  // namespace shrefract::viewer
