// Charts layout: where the charts come from: the scene's own atlas (TEXCOORD_0) when it is a valid
// one, else triangles grouped by dominant normal axis and connectivity, projected on that axis.
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
#include <map>
#include <numeric>
#include <utility>

namespace shrefract::bake::layout_detail {
namespace {

// The two world axes a class projects on, ordered so that the projection keeps the winding:
// +x (y,z), -x (z,y), +y (z,x), -y (x,z), +z (x,y), -z (y,x).
glm::dvec2 project(glm::vec3 p, uint32_t axisClass) {
  static constexpr std::array<std::array<int, 2>, 6> kAxes = {
      {{1, 2}, {2, 1}, {2, 0}, {0, 2}, {0, 1}, {1, 0}}};
  const auto& a = kAxes[axisClass];
  return glm::dvec2(p[a[0]], p[a[1]]);
}

// Per front triangle, the class (see project) of its dominant normal axis and sign.
std::vector<uint32_t> axisClasses(const Scene& scene, const FrontMesh& front) {
  const uint32_t count = static_cast<uint32_t>(front.triangles.size());
  std::vector<uint32_t> axisClass(count);
  for (uint32_t t = 0; t < count; ++t) {
    const FrontTriangle& tri = front.triangles[t];
    const Surface& surface = scene.surfaces[tri.surface];
    const glm::vec3 n = layout_detail::triangleNormal(
        surface.positions[tri.vertex[0]], surface.positions[tri.vertex[1]], surface.positions[tri.vertex[2]],
        layout_detail::normalizeOr(surface.normals[tri.vertex[0]] + surface.normals[tri.vertex[1]] +
                                       surface.normals[tri.vertex[2]],
                                   glm::vec3(0.0f, 0.0f, 1.0f)));
    int k = 0;
    if (std::abs(n.y) > std::abs(n[k])) k = 1;
    if (std::abs(n.z) > std::abs(n[k])) k = 2;
    axisClass[t] = static_cast<uint32_t>(2 * k + (n[k] < 0.0f ? 1 : 0));
  }
  return axisClass;
}

// Adjacency over welded edges, within a class.
std::vector<std::vector<uint32_t>> classAdjacency(const std::vector<EdgeUse>& uses,
                                                  const std::vector<uint32_t>& axisClass) {
  std::vector<std::vector<uint32_t>> adjacent(axisClass.size());
  forEachWeldedEdge(uses, [&](size_t first, size_t end) {
    for (size_t a = first; a < end; ++a) {
      for (size_t b = a + 1; b < end; ++b) {
        const uint32_t ta = uses[a].triangle, tb = uses[b].triangle;
        if (ta != tb && axisClass[ta] == axisClass[tb]) {
          adjacent[ta].push_back(tb);
          adjacent[tb].push_back(ta);
        }
      }
    }
  });
  return adjacent;
}

// Per front triangle, its corners projected on the plane of its class.
std::vector<Tri2> projectOnClassPlanes(const Scene& scene, const FrontMesh& front,
                                       const std::vector<uint32_t>& axisClass) {
  const uint32_t count = static_cast<uint32_t>(front.triangles.size());
  std::vector<Tri2> projected(count);
  for (uint32_t t = 0; t < count; ++t) {
    const FrontTriangle& tri = front.triangles[t];
    const Surface& surface = scene.surfaces[tri.surface];
    for (int c = 0; c < 3; ++c) projected[t][c] = project(surface.positions[tri.vertex[c]], axisClass[t]);
  }
  return projected;
}

// Connected components of `adjacent`, seeded in triangle order; chartOf gets each triangle's
// component.
std::vector<Chart> floodCharts(const std::vector<std::vector<uint32_t>>& adjacent, std::vector<uint32_t>& chartOf) {
  const uint32_t count = static_cast<uint32_t>(adjacent.size());
  chartOf.assign(count, kNoSample);
  std::vector<Chart> flooded;
  for (uint32_t seed = 0; seed < count; ++seed) {
    if (chartOf[seed] != kNoSample) continue;
    const uint32_t id = static_cast<uint32_t>(flooded.size());
    Chart chart;
    chartOf[seed] = id;
    chart.triangles.push_back(seed);
    for (size_t head = 0; head < chart.triangles.size(); ++head) {
      for (uint32_t next : adjacent[chart.triangles[head]]) {
        if (chartOf[next] == kNoSample) {
          chartOf[next] = id;
          chart.triangles.push_back(next);
        }
      }
    }
    flooded.push_back(std::move(chart));
  }
  return flooded;
}

// A chart whose projection folds over itself (a spiral ramp, say) loses the overlapping
// triangles to charts of their own.
std::vector<Chart> splitFolds(std::vector<Chart> flooded, const std::vector<Tri2>& projected) {
  std::vector<Chart> charts;
  std::vector<uint32_t> singles;
  for (Chart& chart : flooded) {
    std::vector<Tri2> tris;
    for (uint32_t t : chart.triangles) tris.push_back(projected[t]);
    const std::vector<uint8_t> flags = overlapFlags(tris, 1e-6);
    std::vector<uint32_t> kept;
    for (size_t k = 0; k < chart.triangles.size(); ++k) {
      (flags[k] ? singles : kept).push_back(chart.triangles[k]);
    }
    if (!kept.empty()) {
      chart.triangles = std::move(kept);
      charts.push_back(std::move(chart));
    }
  }
  std::sort(singles.begin(), singles.end());
  for (uint32_t t : singles) charts.push_back(Chart{{t}, {}, {}});
  return charts;
}

// Numbers the final charts in chartOf and measures their bounds and the projected area.
void measureCharts(GeneratedCharts& result) {
  for (uint32_t c = 0; c < result.charts.size(); ++c) {
    Chart& chart = result.charts[c];
    chart.lo = glm::dvec2(std::numeric_limits<double>::max());
    chart.hi = -chart.lo;
    for (uint32_t t : chart.triangles) {
      result.chartOf[t] = c;
      result.projectedArea += 0.5 * std::abs(signedArea2(result.projected[t]));
      for (const glm::dvec2& p : result.projected[t]) {
        chart.lo = glm::min(chart.lo, p);
        chart.hi = glm::max(chart.hi, p);
      }
    }
  }
}

}  // namespace

bool sceneAtlas(const Scene& scene, const FrontMesh& front, std::vector<Tri2>& uvs) {
  uvs.clear();
  for (const FrontTriangle& tri : front.triangles) {
    const Surface& surface = scene.surfaces[tri.surface];
    if (surface.uvs.empty()) return false;
    Tri2 t;
    for (int c = 0; c < 3; ++c) {
      const glm::vec2 uv = surface.uvs[tri.vertex[c]];
      if (!(uv.x >= 0.0f && uv.x <= 1.0f && uv.y >= 0.0f && uv.y <= 1.0f)) return false;
      t[c] = glm::dvec2(uv);
    }
    // Degenerate: below a millionth of a texel of a 1024 x 1024 atlas.
    if (!(std::abs(signedArea2(t)) > 1e-12)) return false;
    uvs.push_back(t);
  }
  const std::vector<uint8_t> flags = overlapFlags(uvs, 1e-6);
  return std::none_of(flags.begin(), flags.end(), [](uint8_t f) { return f != 0; });
}

uint32_t uvCharts(const FrontMesh& front, const std::vector<EdgeUse>& uses, const std::vector<Tri2>& uvs,
                  std::vector<uint32_t>& chartOf) {
  std::vector<uint32_t> parent(front.triangles.size());
  std::iota(parent.begin(), parent.end(), 0u);
  const auto find = [&](uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  const auto uvAt = [&](const EdgeUse& use, uint32_t id) { return uvs[use.triangle][cornerAt(front, use, id)]; };
  forEachWeldedEdge(uses, [&](size_t first, size_t end) {
    const uint32_t lo = lowerEnd(uses[first].key), hi = higherEnd(uses[first].key);
    for (size_t other = first + 1; other < end && lo != hi; ++other) {
      if (uvAt(uses[first], lo) == uvAt(uses[other], lo) && uvAt(uses[first], hi) == uvAt(uses[other], hi)) {
        const uint32_t a = find(uses[first].triangle), b = find(uses[other].triangle);
        parent[std::max(a, b)] = std::min(a, b);
      }
    }
  });
  chartOf.assign(front.triangles.size(), 0);
  std::vector<uint32_t> id(front.triangles.size(), kNoSample);
  uint32_t count = 0;
  for (uint32_t t = 0; t < front.triangles.size(); ++t) {
    const uint32_t root = find(t);
    if (id[root] == kNoSample) id[root] = count++;
    chartOf[t] = id[root];
  }
  return count;
}

GeneratedCharts generateCharts(const Scene& scene, const FrontMesh& front, const std::vector<EdgeUse>& uses) {
  const std::vector<uint32_t> axisClass = axisClasses(scene, front);
  const std::vector<std::vector<uint32_t>> adjacent = classAdjacency(uses, axisClass);
  GeneratedCharts result;
  result.projected = projectOnClassPlanes(scene, front, axisClass);
  std::vector<Chart> flooded = floodCharts(adjacent, result.chartOf);
  result.charts = splitFolds(std::move(flooded), result.projected);
  measureCharts(result);
  return result;
}

}  // namespace shrefract::bake::layout_detail
