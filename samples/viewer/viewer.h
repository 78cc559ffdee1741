// `shrefract view`: an interactive window onto a refraction field (or a scene) through the engine,
// with a real swapchain. The viewer is a host engine like any other: it owns the window (GLFW),
// the surface and swapchain, an offscreen colour + depth target the engine draws into, the frame
// command buffers and their synchronization, and blits the target to the swapchain image.
#pragma once

#include <shrefract/assets/image.h>
#include <shrefract/assets/scene.h>
#include <shrefract/field.h>
#include <shrefract/renderer.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace shrefract::viewer {

struct ViewerOptions {
  // Either one or two fields (the second is shown with F) or a scene (single-interface only).
  std::vector<Field> fields;
  std::vector<std::string> fieldNames;
  std::optional<bake::Scene> scene;
  std::string sceneName;

  std::vector<bake::Image> environments;  // at least one; E cycles through them
  std::vector<std::string> environmentNames;

  uint32_t width = 960, height = 640;  // window size; with a screenshot also the rendered size
  float verticalFovDegrees = 40.0f;
  float exposure = 1.0f;
  float absorption = 1.0f;
  std::optional<uint32_t> order;       // initial SH order (default: the baked order)
  ShadingMode mode = ShadingMode::Field;
  uint32_t environmentTaps = RendererCreateInfo{}.environmentTapsPerAxis;  // initial; T cycles
  // The host's MSAA (RendererCreateInfo::sampleCount): multisampled targets resolved before the
  // blit and the screenshot. A count the device lacks fails with exit code 2.
  VkSampleCountFlagBits msaa = VK_SAMPLE_COUNT_1_BIT;

  uint32_t frames = 0;                 // 0: until the window closes; else exit after that many
  std::string screenshot;              // PNG/EXR of the last frame, written at exit ("" none)
  std::string keys;                    // --keys: one action character applied per frame, for tests
  int deviceIndex = -1;
  bool validation = true;
  bool vsync = true;                   // FIFO; false prefers IMMEDIATE/MAILBOX (--no-vsync)
};

// Runs the viewer; returns the process exit code (0, or 1 after printing one line to stderr; 2
// for an MSAA count the device lacks).
// Fails when any Vulkan validation message was reported, without writing the screenshot.
int runViewer(const ViewerOptions& options);

}  // namespace shrefract::viewer
