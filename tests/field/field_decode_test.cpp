// The hemi-octahedral decode of Table and Pca fields (field_decode.h): nodes, the horizon, exits
// that are linear in the direction, and cells that a jump crosses.
#include <shrefract/field.h>
#include <shrefract/field_decode.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "field/field_test_support.h"

namespace shrefract {
namespace {

using namespace fieldtest;

// The hemi-octahedral map: nodes map back to their grid positions, the border is the horizon, and
// evaluateSample at a node direction returns that node's value exactly (bilinear weight 1).
TEST(HemiOctahedral, NodesRoundTripAndTheBorderIsTheHorizon) {
  const uint32_t n = 9;
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      const std::array<float, 3> w = hemiOctDirection(i, j, n);
      EXPECT_NEAR(std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]), 1.0f, 1e-6f);
      EXPECT_GE(w[2], 0.0f);
      if (i == 0 || j == 0 || i == n - 1 || j == n - 1) {
        EXPECT_NEAR(w[2], 0.0f, 1e-6f);
      }
      const HemiOctCoordinates uv = hemiOctFromDirection(w[0], w[1], w[2]);
      EXPECT_NEAR(uv.u, float(i) / float(n - 1), 1e-6f);
      EXPECT_NEAR(uv.v, float(j) / float(n - 1), 1e-6f);
    }
  const std::array<float, 3> pole = hemiOctDirection(4, 4, 9);
  EXPECT_NEAR(pole[2], 1.0f, 1e-6f);
}

TEST(HemiOctahedral, EvaluateSampleReturnsNodeValuesAtNodes) {
  for (Encoding e : {Encoding::Table, Encoding::Pca}) {
    const Field f = makeEncodedField(e, Quantization::U8, false);
    const uint64_t texel = 3;
    for (uint32_t j = 0; j < 3; ++j)
      for (uint32_t i = 0; i < 3; ++i) {
        const uint32_t node = j * 3 + i;
        float out[4];
        evaluateSample(f, texel, hemiOctDirection(i, j, 3), out);
        for (uint32_t c = 0; c < 4; ++c) {
          float expected = 0.0f;
          if (e == Encoding::Table) expected = fieldCoefficient(f, node, texel, c);
          else
            for (uint32_t k = 0; k < f.components; ++k)
              expected += fieldCoefficient(f, k, texel, 0) * f.basis[(k * 9 + node) * 4 + c];
          EXPECT_NEAR(out[c], expected, 1e-5f) << toString(e) << " node " << node << " channel " << c;
        }
      }
  }
}

// A node-sampled table of exits that are a linear map of the direction (a slab's straight-through
// exit -w, and a rotation of it) decodes to the exit at w itself inside a quadrant's cells: the
// exits blend by b_j |o_j| (field_decode.cpp interpolateCorners). Plain bilinear weights, which a
// least-squares table keeps, err there by up to 0.09 deg at N = 32.
TEST(HemiOctahedral, NodeSampledLinearExitsDecodeExactlyInsideQuadrants) {
  const uint32_t n = 32;
  const float c = std::cos(0.4f), s = std::sin(0.4f);  // a rotation about x
  const auto exitOf = [&](const std::array<float, 3>& w, bool rotated) {
    const std::array<float, 3> e{-w[0], -w[1], -w[2]};
    return rotated ? std::array<float, 3>{e[0], c * e[1] - s * e[2], s * e[1] + c * e[2]} : e;
  };
  for (bool rotated : {false, true}) {
    std::vector<float> table(size_t(n) * n * 3);
    for (uint32_t node = 0; node < n * n; ++node) {
      const std::array<float, 3> e = exitOf(hemiOctDirection(node % n, node / n, n), rotated);
      std::copy(e.begin(), e.end(), table.begin() + node * 3);
    }
    EncodingShape shape;
    shape.encoding = Encoding::Table;
    shape.tableSize = n;
    shape.channels = 3;
    shape.sampleFrameExits = true;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    float worstNodes = 0.0f, worstBilinear = 0.0f;
    for (int i = 0; i < 20000; ++i) {
      std::array<float, 3> w{uniform(rng), uniform(rng), std::fabs(uniform(rng))};
      const float len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
      if (!(len > 0.1f) || w[2] / len < 0.05f) continue;
      for (float& x : w) x /= len;
      // Cells that a quadrant boundary (x = 0 or y = 0, the grid's diagonals) crosses are not linear.
      const HemiOctCoordinates uv = hemiOctFromDirection(w[0], w[1], w[2]);
      const uint32_t ci = std::min(uint32_t(uv.u * float(n - 1)), n - 2), cj = std::min(uint32_t(uv.v * float(n - 1)), n - 2);
      if (ci == cj || ci + cj + 2 == n) continue;
      const std::array<float, 3> exact = exitOf(w, rotated);
      for (bool nodeSampled : {true, false}) {
        shape.jumpAware = nodeSampled;
        float out[3];
        evaluateCoefficients(shape, table.data(), nullptr, w, out);
        // atan2 of the cross product's length and the dot: acos near 1 resolves only ~0.02 deg.
        const float cx = out[1] * exact[2] - out[2] * exact[1], cy = out[2] * exact[0] - out[0] * exact[2],
                    cz = out[0] * exact[1] - out[1] * exact[0];
        const float degrees = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz),
                                         out[0] * exact[0] + out[1] * exact[1] + out[2] * exact[2]) * 57.29578f;
        float& worst = nodeSampled ? worstNodes : worstBilinear;
        worst = std::max(worst, degrees);
      }
    }
    // Measured: 3e-5 deg (float rounding) against 0.087 for plain bilinear weights.
    EXPECT_LT(worstNodes, 1e-3f) << "rotated " << rotated;
    EXPECT_GT(worstBilinear, 0.05f) << "rotated " << rotated;
  }
}

// A cell that a jump crosses, three corners on the eye's side: the side's exits are the
// straight-through exit (-w in the sample's frame) tilted by a term linear across the grid, as a
// prism's side face bends them, so its estimate at w is the plane through its three corners
// (field_decode.cpp sideCoefficients), exact to rounding; their blend moved by the
// straight-through correction alone errs by a degree there.
TEST(HemiOctahedral, JumpCellSideExtrapolatesItsOwnCorners) {
  const uint32_t n = 16;  // jump-aware (>= gpu::kJumpMinTableSize)
  const float jump = 16.5f;  // the jump: grid coordinates with i + j = 16.5
  const auto sideA = [n](float i, float j) {
    const std::array<float, 3> w = hemiOctDirectionAt(i, j, n);
    return std::array<float, 3>{-w[0] - 0.3f + 0.08f * i, -w[1] + 0.1f + 0.06f * j, -w[2]};
  };
  std::vector<float> table(size_t(n) * n * 4);
  for (uint32_t node = 0; node < n * n; ++node) {
    const float i = float(node % n), j = float(node / n);
    const std::array<float, 3> e = i + j < jump ? sideA(i, j) : std::array<float, 3>{0.8f, 0.0f, -0.6f};
    const float cells = std::min(std::fabs(i + j - jump) / std::sqrt(2.0f), 1.0f);  // to the jump
    std::copy(e.begin(), e.end(), table.begin() + node * 4);
    table[node * 4 + 3] = cells * 3.14159265f / float(n - 1);  // the channel's scale (gpu_layout.h)
  }
  EncodingShape shape;
  shape.encoding = Encoding::Table;
  shape.tableSize = n;
  shape.channels = 4;
  shape.jumpAware = shape.jumpDistance = shape.sampleFrameExits = true;
  // Cell (7, 8): corners (7, 8), (8, 8), (7, 9) on side A, (8, 9) beyond the jump with bilinear
  // weight >= 1 / gpu::kJumpBlendGain, so that the jump-aware estimate replaces the bilinear blend.
  float worst = 0.0f;
  for (const auto& [gi, gj] : {std::pair{7.4f, 8.3f}, std::pair{7.2f, 8.6f}, std::pair{7.7f, 8.1f}, std::pair{7.5f, 8.5f}}) {
    float out[3];
    evaluateCoefficients(shape, table.data(), nullptr, hemiOctDirectionAt(gi, gj, n), out);
    const std::array<float, 3> exact = sideA(gi, gj);
    const float cx = out[1] * exact[2] - out[2] * exact[1], cy = out[2] * exact[0] - out[0] * exact[2],
                cz = out[0] * exact[1] - out[1] * exact[0];
    const float degrees = std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz),
                                     out[0] * exact[0] + out[1] * exact[1] + out[2] * exact[2]) * 57.29578f;
    worst = std::max(worst, degrees);
  }
  // Measured: 0.0075 deg (the slopes' ridge); the blend of the side's corners moved by the
  // straight-through correction (the decode before the plane fit): 0.69 deg.
  EXPECT_LT(worst, 0.05f);
}

}  // namespace
}  // namespace shrefract
