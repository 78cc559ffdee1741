// Charts layout: the chart rectangles shelf-packed into the atlas, and each triangle placed.
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
#include <glm/ext/vector_uint2_sized.hpp>
#include <numeric>

namespace shrefract::bake::layout_detail {

Packing pack(const GeneratedCharts& generated, double scale) {
  const size_t count = generated.charts.size();
  std::vector<glm::u64vec2> size(count, glm::u64vec2(0));
  double area = 0.0;
  uint64_t widest = 1;
  for (size_t c = 0; c < count; ++c) {
    const glm::dvec2 extent = (generated.charts[c].hi - generated.charts[c].lo) * scale;
    // Texel centres within kGutter of the chart: the chart starts kGutter + 0.5 into its rectangle.
    const auto side = [](double e) {
      return static_cast<uint64_t>(std::floor(std::min(e, 1e12) + 2.0 * kGutter)) + 1;
    };
    size[c] = glm::u64vec2(side(extent.x), side(extent.y));
    area += double(size[c].x) * double(size[c].y);
    widest = std::max(widest, size[c].x);
  }
  std::vector<uint32_t> order(count);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    if (size[a].y != size[b].y) return size[a].y > size[b].y;
    return size[a].x > size[b].x;
  });
  // Shelves of a few widths from the square root of the total area up; keep the squarest atlas.
  Packing best;
  for (int attempt = 0; attempt <= 12; ++attempt) {
    const uint64_t shelfWidth =
        std::max(widest, static_cast<uint64_t>(std::ceil(std::sqrt(area) * (1.0 + 0.05 * attempt))));
    Packing packing;
    packing.origin.assign(count, glm::u64vec2(0));
    uint64_t x = 0, y = 0, shelfHeight = 0;
    for (uint32_t c : order) {
      if (x + size[c].x > shelfWidth) {
        y += shelfHeight;
        x = 0;
        shelfHeight = 0;
      }
      packing.origin[c] = glm::u64vec2(x, y);
      x += size[c].x;
      packing.width = std::max(packing.width, x);
      shelfHeight = std::max(shelfHeight, size[c].y);
    }
    packing.height = y + shelfHeight;
    const auto side = [](const Packing& p) { return std::max(p.width, p.height); };
    if (attempt == 0 || side(packing) < side(best) ||
        (side(packing) == side(best) && packing.width * packing.height < best.width * best.height)) {
      best = std::move(packing);
    }
  }
  return best;
}

Placement place(const GeneratedCharts& generated, const Packing& packing, double scale) {
  Placement placement;
  placement.width = static_cast<uint32_t>(packing.width);
  placement.height = static_cast<uint32_t>(packing.height);
  placement.chartOf = generated.chartOf;
  placement.chartCount = static_cast<uint32_t>(generated.charts.size());
  placement.corners.resize(generated.projected.size());
  for (size_t t = 0; t < generated.projected.size(); ++t) {
    const uint32_t c = generated.chartOf[t];
    const glm::dvec2 origin = glm::dvec2(packing.origin[c]) + (kGutter + 0.5);
    for (int k = 0; k < 3; ++k) {
      placement.corners[t][k] = origin + (generated.projected[t][k] - generated.charts[c].lo) * scale;
    }
  }
  return placement;
}

}  // namespace shrefract::bake::layout_detail
