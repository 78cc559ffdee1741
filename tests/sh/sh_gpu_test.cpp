// GPU check of spirv/include/shrefract/sh.glsl: a compute shader evaluates the basis for 10,000+
// directions (a Fibonacci sphere plus both poles, the equator and points near the poles) for every
// order 0..20, through both the streaming macro and shEvaluate, and the result is compared with
// the CPU evaluation (engine/src/sh/sh.cpp) of the same float directions.
#include <gtest/gtest.h>
#include <shrefract/sh.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <optional>
#include <vector>

#include "gpu_test_support.h"
#include "test_spirv.h"

namespace {

namespace sh = shrefract::sh;
using shrefract::harness::Harness;

// Must match tests/sh/sh_eval_test.comp.
constexpr uint32_t kLocalSize = 64;
constexpr int kShaderMaxOrder = 20;
struct Push {
  uint32_t count;
  int32_t order;
  uint32_t useArray;
};

// Tolerance (absolute), every order 0..20. The GPU runs the same float recurrences as the CPU
// float overload, which stays within 5e-6 of double up to order 20 (sh_test); the GPU adds
// per-step constants computed in float at run time (a few ulps each) and its own contraction and
// sqrt/division precision. Lavapipe measures 2.5e-6 at order 16 and 3.3e-6 at order 20.
constexpr double kTolerance = 1e-5;

std::vector<float> testDirections() {
  std::vector<float> dirs;  // xyzw
  auto push = [&](double x, double y, double z) {
    dirs.insert(dirs.end(),
                {static_cast<float>(x), static_cast<float>(y), static_cast<float>(z), 0.0f});
  };
  constexpr int kFibonacci = 10000;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < kFibonacci; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / kFibonacci;
    const double r = std::sqrt(1.0 - z * z);
    const double phi = golden * i;
    push(r * std::cos(phi), r * std::sin(phi), z);
  }
  push(0, 0, 1);
  push(0, 0, -1);
  for (int k = 0; k < 32; ++k) {
    const double phi = 2.0 * std::numbers::pi * k / 32.0;
    push(std::cos(phi), std::sin(phi), 0.0);
  }
  for (double theta : {1e-4, 1e-3, 1e-2, 3e-2}) {
    for (int k = 0; k < 8; ++k) {
      const double phi = 2.0 * std::numbers::pi * k / 8.0 + 0.1;
      const double r = std::sin(theta);
      push(r * std::cos(phi), r * std::sin(phi), std::cos(theta));
      push(r * std::cos(phi), r * std::sin(phi), -std::cos(theta));
    }
  }
  return dirs;
}

TEST(ShGpuTest, GlslMatchesCpuUpToOrder20) {
  auto h = shrefract::testing::harnessOrSkip();
  ASSERT_TRUE(h);
  std::printf("device: %s\n", h->deviceName().c_str());
  VkDevice device = h->device();

  const std::vector<float> dirs = testDirections();
  const uint32_t count = static_cast<uint32_t>(dirs.size() / 4);
  const VkDeviceSize dirBytes = dirs.size() * sizeof(float);
  const VkDeviceSize valueBytes = VkDeviceSize{count} *
                                  static_cast<VkDeviceSize>(sh::basisCount(kShaderMaxOrder)) *
                                  sizeof(float);

  auto dirBuffer = h->createHostBuffer(dirBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  ASSERT_TRUE(dirBuffer.ok()) << dirBuffer.error().message;
  auto valueBuffer = h->createHostBuffer(valueBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  ASSERT_TRUE(valueBuffer.ok()) << valueBuffer.error().message;
  std::memcpy(dirBuffer->mapped, dirs.data(), static_cast<size_t>(dirBytes));

  // Pipeline: two storage buffers and a push constant block.
  std::optional<shrefract::testing::TestComputeShader> shader;
  shader.emplace(device, kSpirv_sh_eval_test_comp, sizeof(kSpirv_sh_eval_test_comp), uint32_t(sizeof(Push)),
                 dirBuffer->buffer, valueBuffer->buffer);
  ASSERT_TRUE(shader->ok());

  std::vector<double> cpuDouble(static_cast<size_t>(sh::basisCount(kShaderMaxOrder)));
  std::vector<float> cpuFloat(cpuDouble.size());
  for (uint32_t useArray = 0; useArray < 2; ++useArray) {
    for (int order = 0; order <= kShaderMaxOrder; ++order) {
      const Push push{count, order, useArray};
      auto submitted = h->submitAndWait(
          [&](VkCommandBuffer cmd) { shader->record(cmd, &push, (count + kLocalSize - 1) / kLocalSize); });
      ASSERT_TRUE(submitted.ok()) << submitted.error().message;

      const float* gpu = static_cast<const float*>(valueBuffer->mapped);
      const size_t n = static_cast<size_t>(sh::basisCount(order));
      double worstDouble = 0.0, worstFloat = 0.0;
      size_t failures = 0;
      for (uint32_t d = 0; d < count; ++d) {
        const float x = dirs[4 * d], y = dirs[4 * d + 1], z = dirs[4 * d + 2];
        sh::evaluate(order, static_cast<double>(x), static_cast<double>(y), static_cast<double>(z),
                     cpuDouble.data());
        sh::evaluate(order, x, y, z, cpuFloat.data());
        for (size_t i = 0; i < n; ++i) {
          const double g = static_cast<double>(gpu[d * n + i]);
          const double errDouble = std::abs(g - cpuDouble[i]);
          worstDouble = std::max(worstDouble, errDouble);
          worstFloat = std::max(worstFloat, std::abs(g - static_cast<double>(cpuFloat[i])));
          if (!(errDouble <= kTolerance) && failures++ < 5) {
            ADD_FAILURE() << (useArray ? "shEvaluate" : "SH_FOR_EACH_BASIS") << " order " << order
                          << " direction (" << x << ", " << y << ", " << z << ") basis " << i
                          << ": gpu " << g << " cpu " << cpuDouble[i];
          }
        }
      }
      std::printf(
          "%-17s order %2d: max |gpu - cpu double| = %.3g, max |gpu - cpu float| = %.3g (tolerance "
          "%.0e)\n",
          useArray ? "shEvaluate" : "SH_FOR_EACH_BASIS", order, worstDouble, worstFloat,
          kTolerance);
      EXPECT_EQ(failures, 0u) << "order " << order;
    }
  }

  shader.reset();
  h->destroyBuffer(*valueBuffer);
  h->destroyBuffer(*dirBuffer);
  shrefract::testing::expectNoMessagesThroughDestruction(h);
}

}  // namespace
