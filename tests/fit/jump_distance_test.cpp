// bake::jumpDistances (jump_distance.h) against closed forms: exit functions of the grid coordinates
// with straight jumps at known places, whose distance to each node is known exactly.
#include <shrefract/bake/jump_distance.h>
#include <shrefract/field.h>
#include <shrefract/field_decode.h>
#include <shrefract/gpu_layout.h>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <cmath>
#include <functional>
#include <numbers>
#include <vector>

namespace shrefract::bake {
namespace {

constexpr uint32_t kN = 16;
// 4 bisections place a crossing within 1/32 of a cell; a distance combines two of them.
constexpr float kTolerance = 0.05f;

// The exit jumps by 90 deg across the line side(x, y) = 0; the straight-through direction is
// constant, so the decode's moved exits are the exits themselves.
struct LineField {
  std::function<float(float, float)> side;
  int traces = 0;
  TracedView at(float x, float y) {
    ++traces;
    return {side(x, y) < 0.0f ? glm::vec3(1.0f, 0.0f, 0.0f) : glm::vec3(0.0f, 1.0f, 0.0f), glm::vec3(0.0f, 0.0f, -1.0f)};
  }
  std::vector<float> distances() {
    std::vector<TracedView> nodes;
    for (uint32_t j = 0; j < kN; ++j)
      for (uint32_t i = 0; i < kN; ++i) nodes.push_back(at(float(i), float(j)));
    traces = 0;
    return jumpDistances(kN, nodes, [this](float x, float y) { return at(x, y); });
  }
};

float cosDegrees(float degrees) { return std::cos(degrees * std::numbers::pi_v<float> / 180.0f); }

TEST(JumpDistance, ThresholdsScaleWithTheCellDownToTheirFloors) {
  // Up to 16 nodes a side the angles chosen at 16x16 (25 and 45 deg); finer tables scale them by
  // 16 / N, not under 16 and 28 deg (gpu_layout.h kJumpFullDegrees).
  const struct {
    uint32_t n;
    float full, none;
  } cases[] = {{2, 25, 45}, {12, 25, 45}, {16, 25, 45}, {20, 20, 36}, {25, 16, 28.8f}, {32, 16, 28}, {64, 16, 28}};
  for (const auto& c : cases) {
    const JumpCosines j = jumpCosines(c.n);
    EXPECT_NEAR(j.full, cosDegrees(c.full), 1e-6f) << c.n;
    EXPECT_NEAR(j.none, cosDegrees(c.none), 1e-6f) << c.n;
  }
}

TEST(JumpDistance, ASmallerJumpIsFoundInAFinerTable) {
  // A 30 deg jump across x = 4.6 is under the 35 deg midway of a 16x16 table's thresholds, and over
  // the 22 deg of a 64x64 table's.
  auto distances = [](uint32_t n) {
    auto at = [](float x, float) {
      const float a = x < 4.6f ? 0.0f : 30.0f * std::numbers::pi_v<float> / 180.0f;
      return TracedView{glm::vec3(std::sin(a), 0.0f, std::cos(a)), glm::vec3(0.0f, 0.0f, -1.0f)};
    };
    std::vector<TracedView> nodes;
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i < n; ++i) nodes.push_back(at(float(i), float(j)));
    return jumpDistances(n, nodes, at);
  };
  const std::vector<float> coarse = distances(16), fine = distances(64);
  EXPECT_EQ(coarse[4], gpu::kJumpDistanceMaxCells);
  EXPECT_EQ(coarse[5], gpu::kJumpDistanceMaxCells);
  EXPECT_NEAR(fine[4], 0.6f, kTolerance);
  EXPECT_NEAR(fine[5], 0.4f, kTolerance);
  EXPECT_EQ(fine[3], gpu::kJumpDistanceMaxCells);
}

TEST(JumpDistance, DiagonalJumpIsItsPerpendicularDistance) {
  LineField f{[](float x, float y) { return x + y - 7.3f; }};
  const std::vector<float> d = f.distances();
  for (uint32_t j = 0; j < kN; ++j)
    for (uint32_t i = 0; i < kN; ++i) {
      const float s = float(i + j) - 7.3f;
      // Nodes next to the line (i + j = 7 or 8) cross it along both axes within a cell, but for
      // (0, 8) and (8, 0), whose other crossing lies outside the grid: the one along the axis.
      const bool oneAxis = s > 0.0f && (i == 0 || j == 0);
      const float expected = std::abs(s) >= 1.0f ? gpu::kJumpDistanceMaxCells
                             : oneAxis           ? s
                                                 : std::abs(s) / std::sqrt(2.0f);
      EXPECT_NEAR(d[j * kN + i], expected, kTolerance) << "node " << i << ", " << j;
    }
  // The line crosses 8 row edges and 8 column edges inside the grid; each is bisected 4 times.
  EXPECT_EQ(f.traces, 16 * kJumpBisections);
}

TEST(JumpDistance, AxisJumpIsTheDistanceAlongTheAxis) {
  LineField f{[](float x, float) { return x - 4.6f; }};
  const std::vector<float> d = f.distances();
  for (uint32_t j = 0; j < kN; ++j) {
    EXPECT_NEAR(d[j * kN + 4], 0.6f, kTolerance) << j;
    EXPECT_NEAR(d[j * kN + 5], 0.4f, kTolerance) << j;
    for (uint32_t i : {0u, 3u, 6u, 15u}) EXPECT_EQ(d[j * kN + i], gpu::kJumpDistanceMaxCells) << i << ", " << j;
  }
}

TEST(JumpDistance, SmoothExitsHaveNoJumpAndTraceNothing) {
  // Exits turning by 2 deg per cell: neighbours agree, nothing is bisected.
  std::vector<TracedView> nodes;
  for (uint32_t j = 0; j < kN; ++j)
    for (uint32_t i = 0; i < kN; ++i) {
      const float a = 0.035f * float(i), b = 0.035f * float(j);
      nodes.push_back({glm::vec3(std::sin(a), std::sin(b), std::cos(a)), glm::vec3(0.0f, 0.0f, -1.0f)});
    }
  int traces = 0;
  const std::vector<float> d = jumpDistances(kN, nodes, [&](float, float) {
    ++traces;
    return TracedView{};
  });
  EXPECT_EQ(traces, 0);
  for (float v : d) EXPECT_EQ(v, gpu::kJumpDistanceMaxCells);
}

TEST(JumpDistance, TrappedNodesAreNoSideOfAJump) {
  // The axis jump of the test above, with the nodes right of it trapped (stopped at the bake's
  // interaction cap): their exits are where the path happened to stop, so their edges are not
  // bisected and the distances stay at the cap.
  LineField f{[](float x, float) { return x - 4.6f; }};
  std::vector<TracedView> nodes;
  for (uint32_t j = 0; j < kN; ++j)
    for (uint32_t i = 0; i < kN; ++i) {
      nodes.push_back(f.at(float(i), float(j)));
      nodes.back().trapped = i >= 5;
    }
  f.traces = 0;
  const std::vector<float> d = jumpDistances(kN, nodes, [&](float x, float y) { return f.at(x, y); });
  EXPECT_EQ(f.traces, 0);
  for (float v : d) EXPECT_EQ(v, gpu::kJumpDistanceMaxCells);
}

TEST(JumpDistance, TheStraightThroughCorrectionIsNotAJump) {
  // A slab: every exit is its own view direction, 12 deg apart between nodes, so the raw exits of
  // far-apart nodes disagree; moved by the change of the straight-through direction they agree.
  std::vector<TracedView> nodes;
  for (uint32_t j = 0; j < kN; ++j)
    for (uint32_t i = 0; i < kN; ++i) {
      const glm::vec3 v = glm::normalize(glm::vec3(float(i) - 7.5f, float(j) - 7.5f, -2.0f));
      nodes.push_back({v, v});
    }
  const std::vector<float> d = jumpDistances(kN, nodes, [](float, float) { return TracedView{}; });
  for (float v : d) EXPECT_EQ(v, gpu::kJumpDistanceMaxCells);
}

}  // namespace
}  // namespace shrefract::bake
