// Charts layout: the samples a placement puts at texel centres, the gutters around charts, and
// charts extended across smooth seams.
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

SurfacePoint interpolate(const Scene& scene, const FrontTriangle& tri, glm::dvec3 weights) {
  const Surface& surface = scene.surfaces[tri.surface];
  const glm::vec3 p0 = surface.positions[tri.vertex[0]], p1 = surface.positions[tri.vertex[1]],
                  p2 = surface.positions[tri.vertex[2]];
  const glm::vec3 n0 = surface.normals[tri.vertex[0]], n1 = surface.normals[tri.vertex[1]],
                  n2 = surface.normals[tri.vertex[2]];
  const glm::vec3 w(weights);
  SurfacePoint point;
  point.geometricNormal = layout_detail::triangleNormal(
      p0, p1, p2, layout_detail::normalizeOr(n0 + n1 + n2, glm::vec3(0.0f, 0.0f, 1.0f)));
  point.position = p0 * w.x + p1 * w.y + p2 * w.z;
  point.shadingNormal = layout_detail::normalizeOr(n0 * w.x + n1 * w.y + n2 * w.z, point.geometricNormal);
  point.surface = tri.surface;
  point.triangle = tri.triangle;
  return point;
}

// Barycentric weights (sum 1) of texel (x, y)'s centre in the atlas triangle q of signed doubled
// area area2, or nothing where the centre lies outside it. A little slack so that no centre falls
// through the crack between two triangles.
std::optional<glm::dvec3> centreWeights(const Tri2& q, double area2, uint32_t x, uint32_t y) {
  const glm::dvec2 c(x + 0.5, y + 0.5);
  glm::dvec3 w(cross2(q[2] - q[1], c - q[1]), cross2(q[0] - q[2], c - q[2]), cross2(q[1] - q[0], c - q[0]));
  w /= area2;
  constexpr double kSlack = -1e-9;
  if (w.x < kSlack || w.y < kSlack || w.z < kSlack) return std::nullopt;
  w = glm::max(w, glm::dvec3(0.0));
  return w / (w.x + w.y + w.z);
}

// True when the square of half-size `half` around `c` meets the triangle (closed sets).
bool boxMeetsTriangle(glm::dvec2 c, double half, const Tri2& q) {
  const glm::dvec2 lo = glm::min(q[0], glm::min(q[1], q[2]));
  const glm::dvec2 hi = glm::max(q[0], glm::max(q[1], q[2]));
  if (hi.x < c.x - half || lo.x > c.x + half || hi.y < c.y - half || lo.y > c.y + half) return false;
  for (int e = 0; e < 3; ++e) {
    const glm::dvec2 edge = q[(e + 1) % 3] - q[e];
    const glm::dvec2 axis(-edge.y, edge.x);
    const double radius = half * (std::abs(axis.x) + std::abs(axis.y));
    const double centre = glm::dot(c, axis);
    double tmin = std::numeric_limits<double>::max(), tmax = -tmin;
    for (const glm::dvec2& p : q) {
      tmin = std::min(tmin, glm::dot(p, axis));
      tmax = std::max(tmax, glm::dot(p, axis));
    }
    if (tmax < centre - radius || tmin > centre + radius) return false;
  }
  return true;
}

struct NearestTexel {
  uint32_t texel = kNoSample;
  double distance2 = std::numeric_limits<double>::infinity();  // squared, in texels
};

// The nearest texel of `chart` holding its own sample to texel (x, y): rings of growing Chebyshev
// radius until no closer one can come.
NearestTexel nearestChartTexel(const Raster& raster, uint32_t width, uint32_t height, uint32_t x, uint32_t y,
                               uint32_t chart) {
  NearestTexel best;
  const int64_t cx = x, cy = y;
  for (int64_t r = 1;; ++r) {
    for (int64_t dy = -r; dy <= r; ++dy) {
      const int64_t yy = cy + dy;
      if (yy < 0 || yy >= int64_t(height)) continue;
      const bool edgeRow = dy == -r || dy == r;
      for (int64_t dx = -r; dx <= r; dx += edgeRow ? 1 : 2 * r) {
        const int64_t xx = cx + dx;
        if (xx < 0 || xx >= int64_t(width)) continue;
        const uint32_t other = static_cast<uint32_t>(yy * width + xx);
        if (!raster.primary[other] || raster.texelChart[other] != chart) continue;
        const double d2 = double(dx * dx + dy * dy);
        if (d2 < best.distance2) best = {other, d2};
      }
    }
    if (best.distance2 <= double((r + 1) * (r + 1)) || r > int64_t(std::max(width, height))) return best;
  }
}

// The atlas triangle of `across`, a triangle welded to the chart triangle `t` along one edge, as
// t's part of the atlas would map it if the chart went on: `across` unfolded about the shared edge
// into t's plane (lengths kept), then placed by the affine map that carries t's corners to its
// atlas corners. Corners in `across`'s own vertex order. False where the edge is not shared.
bool unfoldAcross(const Scene& scene, const FrontMesh& front, const Placement& placement, uint32_t t,
                  uint32_t across, Tri2& out) {
  const FrontTriangle& a = front.triangles[t];
  const FrontTriangle& b = front.triangles[across];
  const auto position = [&](const FrontTriangle& tri, int c) {
    return glm::dvec3(scene.surfaces[tri.surface].positions[tri.vertex[c]]);
  };
  std::array<int, 3> match{-1, -1, -1};  // b's corner -> a's corner with the same welded id
  int shared = 0, free = -1;
  for (int c = 0; c < 3; ++c) {
    for (int d = 0; d < 3; ++d)
      if (b.weld[c] == a.weld[d]) match[c] = d;
    if (match[c] >= 0) ++shared; else free = c;
  }
  if (shared != 2) return false;
  const std::array<glm::dvec3, 3> p{position(a, 0), position(a, 1), position(a, 2)};
  int i = -1, j = -1;
  for (int c = 0; c < 3; ++c)
    if (match[c] >= 0) (i < 0 ? i : j) = match[c];
  const int k = 3 - i - j;  // a's corner off the shared edge
  const glm::dvec3 e = p[j] - p[i];
  const double e2 = glm::dot(e, e);
  if (!(e2 > 0.0)) return false;
  const glm::dvec3 r = position(b, free) - p[i];
  const glm::dvec3 foot = p[i] + (glm::dot(r, e) / e2) * e;
  glm::dvec3 away = (p[k] - p[i]) - (glm::dot(p[k] - p[i], e) / e2) * e;  // toward a's third corner
  const double awayLength = glm::length(away);
  if (!(awayLength > 0.0)) return false;
  const glm::dvec3 unfolded = foot - (glm::length(position(b, free) - foot) / awayLength) * away;
  // Affine coordinates of the unfolded corner on a's edges (in a's plane), then a's atlas map.
  const glm::dvec3 u = p[1] - p[0], v = p[2] - p[0], w = unfolded - p[0];
  const double uu = glm::dot(u, u), uv = glm::dot(u, v), vv = glm::dot(v, v), det = uu * vv - uv * uv;
  if (!(std::abs(det) > 0.0)) return false;
  const double su = (vv * glm::dot(w, u) - uv * glm::dot(w, v)) / det;
  const double sv = (uu * glm::dot(w, v) - uv * glm::dot(w, u)) / det;
  const Tri2& q = placement.corners[t];
  for (int c = 0; c < 3; ++c)
    out[c] = match[c] >= 0 ? q[match[c]] : q[0] + su * (q[1] - q[0]) + sv * (q[2] - q[0]);
  return true;
}

}  // namespace

Raster rasterize(const Scene& scene, const FrontMesh& front, const Placement& placement) {
  const size_t texels = size_t(placement.width) * placement.height;
  Raster raster;
  raster.texelSample.assign(texels, kNoSample);
  raster.texelChart.assign(texels, kNoSample);
  raster.primary.assign(texels, 0);
  std::vector<uint8_t> chartHasSample(placement.chartCount, 0);
  const auto clampX = [&](double v) {
    return static_cast<uint32_t>(std::clamp(v, 0.0, double(placement.width - 1)));
  };
  const auto clampY = [&](double v) {
    return static_cast<uint32_t>(std::clamp(v, 0.0, double(placement.height - 1)));
  };
  const auto claim = [&](uint32_t texel, uint32_t t, glm::dvec3 weights) {
    raster.samples.push_back(interpolate(scene, front.triangles[t], weights));
    raster.texelSample[texel] = static_cast<uint32_t>(raster.samples.size() - 1);
    raster.texelChart[texel] = placement.chartOf[t];
    raster.primary[texel] = 1;
    chartHasSample[placement.chartOf[t]] = 1;
  };
  for (uint32_t t = 0; t < front.triangles.size(); ++t) {
    const Tri2& q = placement.corners[t];
    const double area2 = signedArea2(q);
    if (!(std::abs(area2) > 1e-12)) continue;
    const glm::dvec2 lo = glm::min(q[0], glm::min(q[1], q[2]));
    const glm::dvec2 hi = glm::max(q[0], glm::max(q[1], q[2]));
    const uint32_t x0 = clampX(std::floor(lo.x - 0.5)), x1 = clampX(std::ceil(hi.x - 0.5));
    const uint32_t y0 = clampY(std::floor(lo.y - 0.5)), y1 = clampY(std::ceil(hi.y - 0.5));
    for (uint32_t y = y0; y <= y1; ++y) {
      for (uint32_t x = x0; x <= x1; ++x) {
        const uint32_t texel = y * placement.width + x;
        if (raster.primary[texel]) continue;
        const std::optional<glm::dvec3> w = centreWeights(q, area2, x, y);
        if (w) claim(texel, t, *w);
      }
    }
  }
  // Charts that cover no texel centre.
  std::vector<uint32_t> largest(placement.chartCount, kNoSample);
  std::vector<double> largestArea(placement.chartCount, -1.0);
  for (uint32_t t = 0; t < front.triangles.size(); ++t) {
    const uint32_t chart = placement.chartOf[t];
    const double area = std::abs(signedArea2(placement.corners[t]));
    if (area > largestArea[chart]) {
      largestArea[chart] = area;
      largest[chart] = t;
    }
  }
  for (uint32_t chart = 0; chart < placement.chartCount; ++chart) {
    if (chartHasSample[chart] || largest[chart] == kNoSample) continue;
    const Tri2& q = placement.corners[largest[chart]];
    const glm::dvec2 centroid = (q[0] + q[1] + q[2]) / 3.0;
    const uint32_t texel = clampY(std::floor(centroid.y)) * placement.width + clampX(std::floor(centroid.x));
    if (raster.texelChart[texel] == kNoSample) {
      claim(texel, largest[chart], glm::dvec3(1.0 / 3.0));
    }
  }
  return raster;
}

std::vector<double> fillGutters(const FrontMesh& front, const Placement& placement, Raster& raster) {
  const uint32_t width = placement.width, height = placement.height;
  std::vector<std::vector<uint32_t>> chartTriangles(placement.chartCount);
  for (uint32_t t = 0; t < front.triangles.size(); ++t) chartTriangles[placement.chartOf[t]].push_back(t);
  std::vector<double> assigned(raster.texelSample.size(), std::numeric_limits<double>::infinity());
  std::vector<uint32_t> visited(raster.texelSample.size(), kNoSample);
  std::vector<uint8_t> chartHasSample(placement.chartCount, 0);
  for (size_t texel = 0; texel < raster.primary.size(); ++texel) {
    if (raster.primary[texel]) chartHasSample[raster.texelChart[texel]] = 1;
  }
  const double half = kGutter;
  for (uint32_t chart = 0; chart < placement.chartCount; ++chart) {
    if (!chartHasSample[chart]) continue;
    for (uint32_t t : chartTriangles[chart]) {
      const Tri2& q = placement.corners[t];
      const glm::dvec2 lo = glm::min(q[0], glm::min(q[1], q[2]));
      const glm::dvec2 hi = glm::max(q[0], glm::max(q[1], q[2]));
      const auto range = [&](double a, double b, uint32_t size) {
        const double first = std::clamp(std::floor(a - half - 0.5), 0.0, double(size - 1));
        const double last = std::clamp(std::ceil(b + half - 0.5), 0.0, double(size - 1));
        return std::array<uint32_t, 2>{static_cast<uint32_t>(first), static_cast<uint32_t>(last)};
      };
      const auto xs = range(lo.x, hi.x, width), ys = range(lo.y, hi.y, height);
      for (uint32_t y = ys[0]; y <= ys[1]; ++y) {
        for (uint32_t x = xs[0]; x <= xs[1]; ++x) {
          const uint32_t texel = y * width + x;
          if (raster.primary[texel] || visited[texel] == chart) continue;
          if (!boxMeetsTriangle(glm::dvec2(x + 0.5, y + 0.5), half, q)) continue;
          visited[texel] = chart;
          const NearestTexel nearest = nearestChartTexel(raster, width, height, x, y, chart);
          if (nearest.texel != kNoSample && nearest.distance2 < assigned[texel]) {
            assigned[texel] = nearest.distance2;
            raster.texelSample[texel] = raster.texelSample[nearest.texel];
            raster.texelChart[texel] = chart;
          }
        }
      }
    }
  }
  return assigned;
}

void extendAcrossSmoothSeams(const Scene& scene, const FrontMesh& front, const Placement& placement,
                             const std::vector<EdgeUse>& uses, const std::vector<double>& assigned, Raster& raster) {
  std::vector<uint8_t> extended(raster.texelSample.size(), 0);
  const auto clampTexel = [](double v, uint32_t size) {
    return static_cast<uint32_t>(std::clamp(v, 0.0, double(size - 1)));
  };
  forEachWeldedEdge(uses, [&](size_t first, size_t end) {
    for (size_t m = first; m < end; ++m)
      for (size_t n = first; n < end; ++n) {
        const uint32_t t = uses[m].triangle, across = uses[n].triangle;
        const uint32_t chart = placement.chartOf[t];
        if (t == across || placement.chartOf[across] == chart) continue;
        Tri2 q;
        if (!unfoldAcross(scene, front, placement, t, across, q)) continue;
        const double area2 = signedArea2(q);
        if (!(std::abs(area2) > 1e-12)) continue;
        const glm::dvec2 lo = glm::min(q[0], glm::min(q[1], q[2])), hi = glm::max(q[0], glm::max(q[1], q[2]));
        for (uint32_t y = clampTexel(std::floor(lo.y - 0.5), placement.height);
             y <= clampTexel(std::ceil(hi.y - 0.5), placement.height); ++y)
          for (uint32_t x = clampTexel(std::floor(lo.x - 0.5), placement.width);
               x <= clampTexel(std::ceil(hi.x - 0.5), placement.width); ++x) {
            const uint32_t texel = y * placement.width + x;
            if (raster.primary[texel] || extended[texel] || raster.texelChart[texel] != chart || assigned[texel] > 2.0)
              continue;
            const std::optional<glm::dvec3> w = centreWeights(q, area2, x, y);
            if (!w) continue;
            raster.samples.push_back(interpolate(scene, front.triangles[across], *w));
            raster.texelSample[texel] = static_cast<uint32_t>(raster.samples.size() - 1);
            extended[texel] = 1;
          }
      }
  });
}

}  // namespace shrefract::bake::layout_detail
