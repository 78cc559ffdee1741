// Charts layout: which chart triangles overlap another one (a scene atlas that folds over itself,
// a generated chart to split).
#include "layout/charts_common.h"

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

namespace shrefract::bake::layout_detail {
namespace {

// Separating axis test on the six edge normals; intervals that overlap by no more than eps
// (scaled to the axis length) count as separated.
bool separated(const Tri2& a, const Tri2& b, double eps) {
  for (int k = 0; k < 6; ++k) {
    const Tri2& t = k < 3 ? a : b;
    const glm::dvec2 edge = t[(k + 1) % 3] - t[k % 3];
    const glm::dvec2 axis(-edge.y, edge.x);
    const double slack = eps * glm::length(axis);
    double amin = std::numeric_limits<double>::max(), amax = -amin;
    double bmin = amin, bmax = -amin;
    for (int c = 0; c < 3; ++c) {
      const double pa = glm::dot(a[c], axis), pb = glm::dot(b[c], axis);
      amin = std::min(amin, pa);
      amax = std::max(amax, pa);
      bmin = std::min(bmin, pb);
      bmax = std::max(bmax, pb);
    }
    if (amax <= bmin + slack || bmax <= amin + slack) return true;
  }
  return false;
}

// Grid buckets over the triangles' bounds: each triangle of nonzero area (above `eps`) is listed in
// every cell its box covers.
struct TriangleGrid {
  struct Box {
    uint32_t x0, y0, x1, y1;
  };
  uint32_t cells = 0;
  std::vector<Box> boxes;
  std::vector<std::vector<uint32_t>> buckets;

  TriangleGrid(const std::vector<Tri2>& tris, glm::dvec2 lo, double extent, double eps)
      : cells(static_cast<uint32_t>(std::clamp(std::ceil(std::sqrt(static_cast<double>(tris.size()))), 1.0, 512.0))),
        boxes(tris.size()), buckets(size_t(cells) * cells) {
    const double cellSize = extent / cells;
    const auto cellOf = [&](double v, double origin) {
      return static_cast<uint32_t>(std::clamp(std::floor((v - origin) / cellSize), 0.0, double(cells - 1)));
    };
    for (uint32_t i = 0; i < tris.size(); ++i) {
      const Tri2& t = tris[i];
      if (std::abs(signedArea2(t)) <= eps * eps * 1e-6) continue;
      const glm::dvec2 tlo = glm::min(t[0], glm::min(t[1], t[2]));
      const glm::dvec2 thi = glm::max(t[0], glm::max(t[1], t[2]));
      boxes[i] = {cellOf(tlo.x, lo.x), cellOf(tlo.y, lo.y), cellOf(thi.x, lo.x), cellOf(thi.y, lo.y)};
      for (uint32_t y = boxes[i].y0; y <= boxes[i].y1; ++y) {
        for (uint32_t x = boxes[i].x0; x <= boxes[i].x1; ++x) {
          buckets[size_t(y) * cells + x].push_back(i);
        }
      }
    }
  }
};

}  // namespace

std::vector<uint8_t> overlapFlags(const std::vector<Tri2>& tris, double tolerance) {
  std::vector<uint8_t> flags(tris.size(), 0);
  if (tris.size() < 2) return flags;
  glm::dvec2 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
  for (const Tri2& t : tris) {
    for (const glm::dvec2& p : t) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
  }
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, std::numeric_limits<double>::min()});
  const double eps = tolerance * extent;
  const TriangleGrid grid(tris, lo, extent, eps);
  for (uint32_t cy = 0; cy < grid.cells; ++cy) {
    for (uint32_t cx = 0; cx < grid.cells; ++cx) {
      const std::vector<uint32_t>& bucket = grid.buckets[size_t(cy) * grid.cells + cx];
      for (size_t m = 0; m < bucket.size(); ++m) {
        for (size_t k = m + 1; k < bucket.size(); ++k) {
          const TriangleGrid::Box& a = grid.boxes[bucket[m]];
          const TriangleGrid::Box& b = grid.boxes[bucket[k]];
          // Test each pair once: in the first cell the two boxes share.
          if (std::max(a.x0, b.x0) != cx || std::max(a.y0, b.y0) != cy) continue;
          if (!separated(tris[bucket[m]], tris[bucket[k]], eps)) {
            flags[bucket[m]] = 1;
            flags[bucket[k]] = 1;
          }
        }
      }
    }
  }
  return flags;
}

}  // namespace shrefract::bake::layout_detail
