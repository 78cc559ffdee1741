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

// The harness's handles, lent to a Context (harness.h); tests that need more set the rest.
using harness::contextInfo;
using harness::createContext;

// A harness and a context on it for each test. The test's engine objects are gone when its body
// returns; then the context releases what they retired, and the test fails on any validation
// message of the harness's whole life (device and instance teardown included).
class ContextTest : public ::testing::Test {
 protected:
  void SetUp() override {
    h = harnessOrSkip();
    ASSERT_TRUE(h);
    auto created = createContext(*h);
    ASSERT_TRUE(created.ok()) << created.error().message;
    context = std::move(created).value();
  }
  void TearDown() override {
    if (context) context->releaseDeferred();
    context.reset();
    expectNoMessagesThroughDestruction(h);
  }
  std::unique_ptr<harness::Harness> h;
  std::unique_ptr<Context> context;
};

inline float halfToFloat(uint16_t h) {
  const int exponent = (h >> 10) & 0x1f;
  const int mantissa = h & 0x3ff;
  float value = 0.0f;
  if (exponent == 0) value = std::ldexp(float(mantissa), -24);
  else if (exponent == 31) value = mantissa ? std::nanf("") : INFINITY;
  else value = std::ldexp(float(mantissa | 0x400), exponent - 25);
  return (h & 0x8000) ? -value : value;
}

// One of the object's images of extent fieldExtent() (SHADER_READ_ONLY_OPTIMAL, as the engine
// leaves them, and left so) on the host as `bytesPerTexel` bytes a texel.
inline Result<std::vector<uint8_t>> readFieldImage(harness::Harness& h, const Object& object, VkImage image,
                                                   uint32_t bytesPerTexel) {
  return h.readImage(image, object.fieldExtent(), bytesPerTexel, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
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
