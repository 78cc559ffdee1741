// The environment's level selection (docs/technique.md) on the GPU against the CPU reference:
// spirv/include/shrefract/environment.glsl (directionFootprint, environmentLevel) evaluated by a
// compute shader for known and random screen derivatives, and cpu_reference's mirror of both. A
// known derivative gives a known level: a direction turning through 8 texel angles across the
// pixel reads level 3 (log2 8 and the bias of 0, gpu_layout.h kEnvironmentLevelBias). Also the CPU mirror of the level chain the upload builds (environmentLevels).
#include <gtest/gtest.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/environment.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <random>
#include <optional>
#include <vector>

#include "gpu_test_support.h"
#include "test_spirv.h"

namespace {

namespace reference = shrefract::reference;

struct Case {  // tests/engine/environment_level_test.comp
  float ddx[4];
  float ddy[4];
  float params[4];  // texel angle, max level
};
struct Expected {
  float footprint = -1.0f, level = -1.0f;  // negative: only compared with the CPU
};
constexpr uint32_t kLocalSize = 64;
// The GPU's asin, log2 and length against the CPU's: lavapipe measures about 1e-6; a wrong formula
// is off by a tenth of a level or more.
constexpr float kLevelTolerance = 1e-3f;

Case makeCase(reference::Vec3 ddx, reference::Vec3 ddy, float texelAngle, float maxLevel) {
  return Case{{ddx[0], ddx[1], ddx[2], 0.0f}, {ddy[0], ddy[1], ddy[2], 0.0f}, {texelAngle, maxLevel, 0.0f, 0.0f}};
}

TEST(EnvironmentLevel, GpuMatchesCpuAndKnownLevels) {
  auto h = shrefract::testing::harnessOrSkip();
  ASSERT_TRUE(h);
  VkDevice device = h->device();

  const float texel = reference::latLongTexelAngle(256.0f);  // a 256 x 128 lat-long map, 9 levels
  auto chordFor = [](float angle) { return 2.0f * std::sin(0.5f * angle); };
  std::vector<Case> cases;
  std::vector<Expected> expected;
  auto add = [&](const Case& c, Expected e) {
    cases.push_back(c);
    expected.push_back(e);
  };
  // A direction turning through 8 texels across the pixel in x: level 3; in y, the same.
  add(makeCase({chordFor(8.0f * texel), 0, 0}, {0, 0, 0}, texel, 8.0f), {8.0f * texel, 3.0f});
  add(makeCase({0, 0, 0}, {0, chordFor(8.0f * texel), 0}, texel, 8.0f), {8.0f * texel, 3.0f});
  // The larger of the two axes decides (isotropic): 2 texels in x, 32 in y -> level 5.
  add(makeCase({0, chordFor(2.0f * texel), 0}, {0, 0, chordFor(32.0f * texel)}, texel, 8.0f), {32.0f * texel, 5.0f});
  // Two texels: level 1; 1.4 texels: log2 1.4; half a texel, or no change at all: level 0.
  add(makeCase({chordFor(2.0f * texel), 0, 0}, {0, 0, 0}, texel, 8.0f), {2.0f * texel, 1.0f});
  add(makeCase({chordFor(1.4f * texel), 0, 0}, {0, 0, 0}, texel, 8.0f), {1.4f * texel, std::log2(1.4f)});
  add(makeCase({chordFor(0.5f * texel), 0, 0}, {0, 0, 0}, texel, 8.0f), {0.5f * texel, 0.0f});
  add(makeCase({0, 0, 0}, {0, 0, 0}, texel, 8.0f), {0.0f, 0.0f});
  // Opposite directions across the pixel (chord 2 and beyond): a half turn, 128 texels, level 7 ...
  add(makeCase({0, 2.5f, 0}, {0, 0, 0}, texel, 8.0f), {std::numbers::pi_v<float>, 7.0f});
  // ... clamped to the last level of a shorter chain.
  add(makeCase({0, 2.0f, 0}, {0, 0, 0}, texel, 5.0f), {std::numbers::pi_v<float>, 5.0f});
  // A cube map of 64 texels a face: 12 texels -> log2(12).
  const float cubeTexel = reference::cubeTexelAngle(64.0f);
  add(makeCase({chordFor(12.0f * cubeTexel), 0, 0}, {0, 0, 0}, cubeTexel, 6.0f),
      {12.0f * cubeTexel, std::log2(12.0f)});
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> component(-0.3f, 0.3f);
  for (int i = 0; i < 1000; ++i)
    add(makeCase({component(rng), component(rng), component(rng)}, {component(rng), component(rng), component(rng)},
                 texel, 8.0f),
        {});

  const uint32_t count = uint32_t(cases.size());
  auto caseBuffer = h->createHostBuffer(count * sizeof(Case), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  ASSERT_TRUE(caseBuffer.ok()) << caseBuffer.error().message;
  auto resultBuffer = h->createHostBuffer(count * 2 * sizeof(float), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  ASSERT_TRUE(resultBuffer.ok()) << resultBuffer.error().message;
  std::memcpy(caseBuffer->mapped, cases.data(), count * sizeof(Case));

  std::optional<shrefract::testing::TestComputeShader> shader;
  shader.emplace(device, kSpirv_environment_level_test_comp, sizeof(kSpirv_environment_level_test_comp),
                 uint32_t(sizeof(uint32_t)), caseBuffer->buffer, resultBuffer->buffer);
  ASSERT_TRUE(shader->ok());
  auto submitted = h->submitAndWait(
      [&](VkCommandBuffer cmd) { shader->record(cmd, &count, (count + kLocalSize - 1) / kLocalSize); });
  ASSERT_TRUE(submitted.ok()) << submitted.error().message;

  const float* gpu = static_cast<const float*>(resultBuffer->mapped);
  float worst = 0.0f;
  uint32_t nonZeroLevels = 0;
  for (uint32_t i = 0; i < count; ++i) {
    const Case& c = cases[i];
    const float cpuFootprint =
        reference::directionFootprint({c.ddx[0], c.ddx[1], c.ddx[2]}, {c.ddy[0], c.ddy[1], c.ddy[2]});
    const float cpuLevel = reference::environmentLevel(cpuFootprint, c.params[0], c.params[1]);
    const float gpuFootprint = gpu[2 * i], gpuLevel = gpu[2 * i + 1];
    ASSERT_TRUE(std::isfinite(gpuFootprint) && std::isfinite(gpuLevel)) << "case " << i;
    worst = std::max(worst, std::fabs(gpuLevel - cpuLevel));
    nonZeroLevels += cpuLevel > 0.0f;
    EXPECT_NEAR(gpuLevel, cpuLevel, kLevelTolerance) << "case " << i;
    EXPECT_NEAR(gpuFootprint, cpuFootprint, 1e-5f + 1e-4f * cpuFootprint) << "case " << i;
    if (expected[i].level >= 0.0f) {
      EXPECT_NEAR(cpuLevel, expected[i].level, kLevelTolerance) << "case " << i << " (cpu)";
      EXPECT_NEAR(gpuLevel, expected[i].level, kLevelTolerance) << "case " << i << " (gpu)";
      EXPECT_NEAR(gpuFootprint, expected[i].footprint, 1e-5f + 1e-4f * expected[i].footprint) << "case " << i;
    }
  }
  std::printf("%u cases (%u above level 0): max |gpu level - cpu level| %.3g (tolerance %.0e)\n", count,
              nonZeroLevels, double(worst), double(kLevelTolerance));
  EXPECT_GT(nonZeroLevels, count / 2);  // the random cases reach the filtered levels

  shader.reset();
  h->destroyBuffer(*resultBuffer);
  h->destroyBuffer(*caseBuffer);
  shrefract::testing::expectNoMessagesThroughDestruction(h);
}

// The CPU chain is the linear blit's: 2x2 boxes at even sizes, binary16 values, down to 1 x 1;
// lookups between levels blend linearly, and a zero footprint reads level 0.
TEST(EnvironmentLevel, CpuChainIsTheBlitsBoxes) {
  std::vector<float> pixels(8 * 4 * 4);
  for (size_t i = 0; i < pixels.size() / 4; ++i) pixels[i * 4] = float(i % 8) + 0.1f * float(i / 8);
  reference::LatLongImage env{8, 4, pixels.data()};
  const std::vector<std::vector<float>> levels = reference::environmentLevels(env);
  ASSERT_EQ(levels.size() + 1, shrefract::environmentLevelCount(8, 4));
  ASSERT_EQ(levels.size(), 3u);  // 4x2, 2x1, 1x1
  ASSERT_EQ(levels[0].size(), 4u * 2 * 4);
  // Level 1 texel (1, 1): texels (2..3, 2..3) of level 0.
  const float box = 0.25f * (pixels[(2 * 8 + 2) * 4] + pixels[(2 * 8 + 3) * 4] + pixels[(3 * 8 + 2) * 4] +
                             pixels[(3 * 8 + 3) * 4]);
  EXPECT_NEAR(levels[0][(1 * 4 + 1) * 4], box, 2e-3f);
  float mean = 0.0f;
  for (size_t i = 0; i < pixels.size() / 4; ++i) mean += pixels[i * 4] / 32.0f;
  EXPECT_NEAR(levels[2][0], mean, 1e-2f);
  env.levels = &levels;
  const reference::Vec3 d{0.3f, 0.2f, -0.9f};
  const float texel = reference::latLongTexelAngle(8.0f);
  EXPECT_EQ(reference::sampleLatLong(env, d, 0.0f)[0], reference::sampleLatLong(env, d)[0]);
  EXPECT_NEAR(reference::sampleLatLong(env, d, 1000.0f)[0], levels[2][0], 1e-6f);  // the last level
  // Level L is read at a footprint of 2^L texels (the bias of 0).
  const float l1 = reference::sampleLatLong(env, d, 2.0f * texel)[0];  // level 1
  const float l2 = reference::sampleLatLong(env, d, 4.0f * texel)[0];  // level 2
  EXPECT_NE(l1, l2);
  EXPECT_NEAR(reference::sampleLatLong(env, d, std::sqrt(8.0f) * texel)[0], 0.5f * (l1 + l2), 1e-5f);
}

// sampleLatLongOverPixel (the engine's lookupEnvironmentOverPixel, mirrored): zero derivatives read
// one lookup; over a linear ramp in u (level chain and bilinear taps keep a ramp linear away from
// the seam and the poles) the mean of taps placed symmetrically about the direction is the value
// at the direction itself, whatever the derivatives, and a single tap of the blurrier level is
// too; where the image curves (u^2) the taps' mean is above the centre value by the variance of
// u over the taps. A tap that cancels to zero reads the direction itself (a finite result).
// Planted once: taps at a, b = 0 and 1/2 instead of +-1/4 move the ramp's mean by 4 texels and
// fail.
TEST(EnvironmentLevel, OverPixelTapsAreCentredOnTheDirection) {
  constexpr uint32_t kW = 256, kH = 128;
  auto uOf = [](const reference::Vec3& d) { return 0.5f + std::atan2(d[0], -d[2]) / (2.0f * std::numbers::pi_v<float>); };
  for (bool square : {false, true}) {
    std::vector<float> pixels(size_t(kW) * kH * 4, 1.0f);
    for (uint32_t y = 0; y < kH; ++y)
      for (uint32_t x = 0; x < kW; ++x) {
        const float u = (float(x) + 0.5f) / float(kW);
        pixels[(size_t(y) * kW + x) * 4] = square ? u * u : u;
      }
    reference::LatLongImage env{kW, kH, pixels.data()};
    const std::vector<std::vector<float>> levels = reference::environmentLevels(env);
    env.levels = &levels;
    const float angle = 0.3f;  // looking at u = 0.5 + 0.3 / (2 pi) on the equator
    const reference::Vec3 d{std::sin(angle), 0.0f, -std::cos(angle)};
    const reference::Vec3 east{std::cos(angle), 0.0f, std::sin(angle)};  // +u
    const float texel = reference::latLongTexelAngle(float(kW));
    const float span = 16.0f * texel;  // the direction sweeps 16 texels in u across the pixel
    const reference::Vec3 ddx{east[0] * span, 0.0f, east[2] * span}, ddy{0.0f, 0.2f * span, 0.0f};
    const float centre = reference::sampleLatLong(env, d)[0];
    EXPECT_EQ(reference::sampleLatLongOverPixel(env, d, {0, 0, 0}, {0, 0, 0})[0], centre);
    const float taps = reference::sampleLatLongOverPixel(env, d, ddx, ddy)[0];
    const float u0 = uOf(d);
    if (!square) {
      EXPECT_NEAR(centre, u0, 2e-3f);
      EXPECT_NEAR(taps, centre, 2e-3f) << "taps symmetric about the direction";
      EXPECT_NEAR(reference::sampleLatLong(env, d, span)[0], centre, 2e-3f);
    } else {
      // Over u^2 a filter adds its variance in u to the centre value. Taps at u0 +- 4 texels
      // (a = +-1/4 of 16) add (4 / 256)^2 by their spread, plus each tap's own blur (level 3: its
      // 8-texel box and bilinear tent); one lookup at the whole footprint (level 4: a 16-texel box
      // and tent, 64 texel^2) adds more than that, the pixel's 16-texel box (21 texel^2) less.
      const float du = 4.0f / float(kW);
      const float single = reference::sampleLatLong(env, d, reference::directionFootprint(ddx, ddy))[0];
      std::printf("u^2: centre %.6f, taps +%.2e, one lookup +%.2e (tap spread alone +%.2e)\n", double(centre),
                  double(taps - centre), double(single - centre), double(du * du));
      EXPECT_GT(taps - centre, 0.9f * du * du);
      EXPECT_LT(taps - centre, 0.85f * (single - centre)) << "the taps are closer to the pixel's box";
    }
  }
  // Derivatives as long as a half turn, along the direction itself: the tap at a = b = -1/4
  // cancels to zero and reads the direction.
  std::vector<float> flat(size_t(8) * 4 * 4, 0.5f);
  const reference::LatLongImage small{8, 4, flat.data()};
  const reference::Vec3 d{0.0f, 0.0f, -1.0f}, twice{0.0f, 0.0f, -2.0f};
  const reference::Vec3 c = reference::sampleLatLongOverPixel(small, d, twice, twice);
  for (float v : c) EXPECT_TRUE(std::isfinite(v));
  EXPECT_NEAR(c[0], 0.5f, 1e-3f);
}

}  // namespace
