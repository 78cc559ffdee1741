// Seams: the same surface edge seen from its two triangles must reconstruct the same value when
// the layout is continuous there. Bakes builtin:sphere with the split layout (continuity-corrected
// gutters) and the charts layout, decompresses both on the GPU, reads the distortion images back
// and filters them bilinearly (as the sampler does) along every shared edge from both sides
// (SampleAtlas::sharedEdges). The split layout must be continuous to within one binary16 step of
// the stored values; the charts layout's jumps at chart borders are measured and reported.
#include <gtest/gtest.h>
#include <shrefract/bake/bake.h>
#include <shrefract/bake/layout.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/decompressor.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "engine/engine_test_support.h"
#include "offscreen/offscreen.h"
#include "session_test_support.h"

namespace shrefract {
namespace {


// One binary16 step (ulp) of the distortion image at the magnitude of v, and at least the step at
// 1: directions are unit vectors, so a component near zero still carries the rounding of its
// larger neighbours through the bilinear weights and the gutter sums.
float binary16Step(float v) {
  const float a = std::max(std::fabs(v), 1.0f);
  return std::ldexp(1.0f, static_cast<int>(std::floor(std::log2(a))) - 10);
}

struct SeamStats {
  uint32_t edges = 0, points = 0;
  float maxJump = 0.0f;        // largest |value_A - value_B| over x, y, z, tau
  float maxJumpInSteps = 0.0f; // the same in binary16 steps of the larger value
  float maxAngleDegrees = 0.0f;
  double meanAngleDegrees = 0.0;
  std::vector<float> angles;
};

SeamStats measureSeams(const bake::SampleAtlas& atlas, const reference::DistortionImage& image) {
  SeamStats s;
  constexpr int kSteps = 8;  // points per edge: t = 0, 1/8, ..., 1
  for (const auto& e : atlas.sharedEdges) {
    ++s.edges;
    for (int k = 0; k <= kSteps; ++k) {
      const float t = float(k) / float(kSteps);
      const float ua = e.a0[0] + t * (e.a1[0] - e.a0[0]), va = e.a0[1] + t * (e.a1[1] - e.a0[1]);
      const float ub = e.b0[0] + t * (e.b1[0] - e.b0[0]), vb = e.b0[1] + t * (e.b1[1] - e.b0[1]);
      const reference::Vec4 a = reference::sampleBilinear(image, ua, va);
      const reference::Vec4 b = reference::sampleBilinear(image, ub, vb);
      ++s.points;
      for (size_t c = 0; c < 4; ++c) {
        const float jump = std::fabs(a[c] - b[c]);
        s.maxJump = std::max(s.maxJump, jump);
        s.maxJumpInSteps = std::max(s.maxJumpInSteps, jump / binary16Step(std::max(std::fabs(a[c]), std::fabs(b[c]))));
      }
      const float la = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
      const float lb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
      if (la > 0.0f && lb > 0.0f) {
        const float cosine = std::clamp((a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (la * lb), -1.0f, 1.0f);
        const float angle = std::acos(cosine) * 180.0f / std::numbers::pi_v<float>;
        s.maxAngleDegrees = std::max(s.maxAngleDegrees, angle);
        s.meanAngleDegrees += double(angle);
        s.angles.push_back(angle);
      }
    }
  }
  if (!s.angles.empty()) s.meanAngleDegrees /= double(s.angles.size());
  std::sort(s.angles.begin(), s.angles.end());
  return s;
}

class Seams : public testing::SessionTest {
};

TEST_F(Seams, SplitIsContinuousChartsJumpsAreReported) {
  auto scene = bake::makeBuiltinScene("sphere", bake::BuiltinSceneOptions{});
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto decompressor = Decompressor::create(*session->context);
  ASSERT_TRUE(decompressor.ok());
  const std::array<std::array<float, 3>, 2> eyes{{{0.6f, 1.2f, 3.2f}, {-2.5f, -0.3f, 1.5f}}};

  SeamStats split, charts;
  for (SampleLayout layout : {SampleLayout::Split, SampleLayout::Charts}) {
    SCOPED_TRACE(toString(layout));
    bake::BakeOptions options;
    options.settings.source = "builtin:sphere";
    options.settings.order = 4;
    options.settings.directionsTheta = 16;
    options.settings.directionsPhi = 32;
    options.settings.layout = layout;
    options.settings.sampleBudget = 3000;
    options.settings.threads = 2;
    options.heldOutDirections = 0;
    auto field = bake::bakeField(scene.value(), options);
    ASSERT_TRUE(field.ok()) << field.error().message;
    // The same layout the bake used (deterministic for the same scene and budget), for its edges.
    bake::LayoutOptions layoutOptions;
    layoutOptions.sampleBudget = options.settings.sampleBudget;
    auto atlas = layout == SampleLayout::Split ? bake::buildSplitLayout(scene.value(), layoutOptions)
                                               : bake::buildChartsLayout(scene.value(), layoutOptions);
    ASSERT_TRUE(atlas.ok()) << atlas.error().message;
    ASSERT_EQ(atlas.value().width, field.value().width);
    ASSERT_EQ(atlas.value().height, field.value().height);
    ASSERT_FALSE(atlas.value().sharedEdges.empty());

    auto object = offscreen::uploadField(*session, field.value());
    ASSERT_TRUE(object.ok()) << object.error().message;
    SeamStats& stats = layout == SampleLayout::Split ? split : charts;
    for (const auto& eye : eyes) {
      auto submitted = session->harness->submitAndWait([&](VkCommandBuffer cmd) {
        ASSERT_TRUE(decompressor.value()->record(cmd, eye, {object.value().get()}).ok());
      });
      ASSERT_TRUE(submitted.ok());
      auto gpu = testing::readDistortion(*session->harness, *object.value());
      ASSERT_TRUE(gpu.ok()) << gpu.error().message;
      reference::DistortionImage image{field.value().width, field.value().height, std::move(gpu).value()};
      SeamStats s = measureSeams(atlas.value(), image);
      stats.edges = s.edges;
      stats.points += s.points;
      stats.maxJump = std::max(stats.maxJump, s.maxJump);
      stats.maxJumpInSteps = std::max(stats.maxJumpInSteps, s.maxJumpInSteps);
      stats.maxAngleDegrees = std::max(stats.maxAngleDegrees, s.maxAngleDegrees);
      stats.meanAngleDegrees += s.meanAngleDegrees / double(eyes.size());
      stats.angles.insert(stats.angles.end(), s.angles.begin(), s.angles.end());
    }
    std::sort(stats.angles.begin(), stats.angles.end());
    const float p99 = stats.angles.empty() ? 0.0f : stats.angles[stats.angles.size() * 99 / 100];
    std::printf("%-6s: %u shared edges, %u points x %zu eyes: max jump %.3g (%.2f binary16 steps), "
                "direction jump mean %.3f deg, p99 %.3f deg, max %.3f deg\n",
                toString(layout), stats.edges, stats.points / uint32_t(eyes.size()), eyes.size(),
                double(stats.maxJump), double(stats.maxJumpInSteps), stats.meanAngleDegrees, double(p99),
                double(stats.maxAngleDegrees));
    object.value().reset();
    session->context->releaseDeferred();
  }
  // Split: continuous. Both sides read the same stored texels (shared edge samples are one surface
  // point, gutters are rebuilt from them), so only binary16 rounding of the gutter sums remains.
  EXPECT_LE(split.maxJumpInSteps, 1.0f) << "split layout: a jump larger than one binary16 step";
  // Charts: seams exist (otherwise this test measures nothing).
  EXPECT_GT(charts.maxAngleDegrees, split.maxAngleDegrees);
  decompressor.value().reset();
}

}  // namespace
}  // namespace shrefract
