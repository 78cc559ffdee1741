// Charts layout (the straightforward technique): samples are the texels of a chart atlas. The
// scene's TEXCOORD_0 is used when it is a valid atlas; otherwise triangles are grouped by dominant
// normal axis and connectivity, each chart is projected on its axis plane, and the charts are
// shelf-packed with a gutter. Filtering is continuous inside a chart and breaks at chart borders
// (docs/technique.md).
#include <shrefract/bake/layout.h>

#include "layout/layout_common.h"

#include <glm/ext/vector_uint2_sized.hpp>
#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace shrefract::bake {
namespace {

using layout_detail::EdgeUse;
using layout_detail::FrontMesh;
using layout_detail::FrontTriangle;

// Texels around every chart that hold copies of its border samples: bilinear filtering at a point
// of a chart reads texels less than 1 texel away, so 1 would do; 2 leaves room for the rounding of
// interpolated UVs and for a future coarser mip level.
constexpr uint32_t kGutter = 2;

// Accept the sample count when it is within this factor of the target.
constexpr double kCountTolerance = 0.1;

using Tri2 = std::array<glm::dvec2, 3>;

double cross2(glm::dvec2 a, glm::dvec2 b) { return a.x * b.y - a.y * b.x; }

double signedArea2(const Tri2& t) { return cross2(t[1] - t[0], t[2] - t[0]); }

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

// Flags the triangles whose interior overlaps another one's. Triangles that only touch (a shared
// edge or vertex, up to `tolerance` times the extent of all triangles) do not count; triangles of
// zero area are skipped. Grid buckets keep the pair tests local.
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

// Where every triangle lands in the atlas.
struct Placement {
  uint32_t width = 0, height = 0;
  std::vector<Tri2> corners;      // per front triangle: corner positions in texels (centre i at i+0.5)
  std::vector<uint32_t> chartOf;  // per front triangle
  uint32_t chartCount = 0;
};

// Texel contents before gutters: samples at texel centres inside triangles.
struct Raster {
  std::vector<uint32_t> texelSample;
  std::vector<uint32_t> texelChart;  // chart of the texel's sample, kNoSample where none
  std::vector<uint8_t> primary;      // the texel's centre lies in its chart: its own sample
  std::vector<SurfacePoint> samples;
};

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

// Samples at every texel centre inside a triangle (the first triangle wins a centre on a shared
// edge). A chart that covers no texel centre gets one sample, at the centroid of its largest
// triangle, in the texel under that centroid when the texel is free.
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

// Fills the texels within kGutter texels of each chart (and not inside one) with the sample of the
// nearest texel of that chart; where two charts reach a texel, the nearer sample wins. Returns,
// per texel, the squared distance in texels to the sample it copies (infinity where none).
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

// Gutter texels beside a smooth seam (an edge whose two triangles share welded vertices, so the
// surface and its normals go on across it) hold the surface beyond the seam instead of a copy of
// the nearest sample. Bilinear filtering inside a chart reads the gutter texels next to its
// border; with copies, the exit held still over the last half texel before a seam and changed
// in steps along a seam that runs across the texel grid: refracted edges of the environment broke
// into sawteeth there (the sphere's default field at 960x720). Each texel next to a chart's own
// texels (squared distance <= 2) whose centre lies in the unfolded image of a triangle welded to
// a chart triangle gets its own sample on that triangle; the others keep their copies (a sharp
// edge, a cube's, has nothing beyond it to hold).
void extendAcrossSmoothSeams(const Scene& scene, const FrontMesh& front, const Placement& placement,
                             const std::vector<EdgeUse>& uses, const std::vector<double>& assigned, Raster& raster) {
  std::vector<uint8_t> extended(raster.texelSample.size(), 0);
  const auto clampTexel = [](double v, uint32_t size) {
    return static_cast<uint32_t>(std::clamp(v, 0.0, double(size - 1)));
  };
  for (size_t k = 0; k < uses.size();) {
    size_t end = k + 1;
    while (end < uses.size() && uses[end].key == uses[k].key) ++end;
    for (size_t m = k; m < end; ++m)
      for (size_t n = k; n < end; ++n) {
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
    k = end;
  }
}

// --- the scene's own atlas -------------------------------------------------------------------------

// Per front triangle, its TEXCOORD_0 corners when every front surface has a valid atlas.
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

// Charts of the scene's atlas: triangles joined by welded edges with the same UVs on both sides.
uint32_t uvCharts(const FrontMesh& front, const std::vector<EdgeUse>& uses, const std::vector<Tri2>& uvs,
                  std::vector<uint32_t>& chartOf) {
  std::vector<uint32_t> parent(front.triangles.size());
  std::iota(parent.begin(), parent.end(), 0u);
  const auto find = [&](uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  const auto uvAt = [&](const EdgeUse& use, uint32_t id) {
    const FrontTriangle& tri = front.triangles[use.triangle];
    const uint32_t c = tri.weld[use.edge] == id ? use.edge : (use.edge + 1) % 3;
    return uvs[use.triangle][c];
  };
  for (size_t k = 0; k < uses.size();) {
    size_t end = k + 1;
    while (end < uses.size() && uses[end].key == uses[k].key) ++end;
    const uint32_t lo = static_cast<uint32_t>(uses[k].key >> 32), hi = static_cast<uint32_t>(uses[k].key);
    for (size_t other = k + 1; other < end && lo != hi; ++other) {
      if (uvAt(uses[k], lo) == uvAt(uses[other], lo) && uvAt(uses[k], hi) == uvAt(uses[other], hi)) {
        const uint32_t a = find(uses[k].triangle), b = find(uses[other].triangle);
        parent[std::max(a, b)] = std::min(a, b);
      }
    }
    k = end;
  }
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

// --- generated charts ------------------------------------------------------------------------------

struct Chart {
  std::vector<uint32_t> triangles;
  glm::dvec2 lo{0.0}, hi{0.0};  // bounds of the projection, world units
};

// The two world axes a class projects on, ordered so that the projection keeps the winding:
// +x (y,z), -x (z,y), +y (z,x), -y (x,z), +z (x,y), -z (y,x).
glm::dvec2 project(glm::vec3 p, uint32_t axisClass) {
  static constexpr std::array<std::array<int, 2>, 6> kAxes = {
      {{1, 2}, {2, 1}, {2, 0}, {0, 2}, {0, 1}, {1, 0}}};
  const auto& a = kAxes[axisClass];
  return glm::dvec2(p[a[0]], p[a[1]]);
}

struct GeneratedCharts {
  std::vector<Chart> charts;
  std::vector<uint32_t> chartOf;
  std::vector<Tri2> projected;  // per front triangle, world units on its chart's plane
  double projectedArea = 0.0;
};

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
  for (size_t k = 0; k < uses.size();) {
    size_t end = k + 1;
    while (end < uses.size() && uses[end].key == uses[k].key) ++end;
    for (size_t a = k; a < end; ++a) {
      for (size_t b = a + 1; b < end; ++b) {
        const uint32_t ta = uses[a].triangle, tb = uses[b].triangle;
        if (ta != tb && axisClass[ta] == axisClass[tb]) {
          adjacent[ta].push_back(tb);
          adjacent[tb].push_back(ta);
        }
      }
    }
    k = end;
  }
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

// Shelf packing of the chart rectangles (tallest first) at `scale` texels per world unit. Sizes
// are 64-bit: the caller shrinks the scale until they fit its limit.
struct Packing {
  uint64_t width = 0, height = 0;
  std::vector<glm::u64vec2> origin;  // per chart: corner of its rectangle
};

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

// The chosen placement and the samples rasterized in it.
struct Fitted {
  Placement placement;
  Raster raster;
};

// Choose the placement: rasterize, compare the sample count with the target, rescale. With the
// scene's atlas only its resolution can change.
Fitted fitSceneAtlas(const Scene& scene, const FrontMesh& front, const std::vector<EdgeUse>& uses,
                     const std::vector<Tri2>& uvs, double target, uint32_t maxSize) {
  Fitted fitted;
  Placement& placement = fitted.placement;
  placement.chartCount = uvCharts(front, uses, uvs, placement.chartOf);
  double coverage = 0.0;
  for (const Tri2& t : uvs) coverage += 0.5 * std::abs(signedArea2(t));
  double side = std::sqrt(target / coverage);
  for (int round = 0; round < 6; ++round) {
    const uint32_t size = static_cast<uint32_t>(std::clamp(std::round(side), 1.0, double(maxSize)));
    placement.width = placement.height = size;
    placement.corners = uvs;
    for (Tri2& t : placement.corners) {
      for (glm::dvec2& p : t) p *= double(size);
    }
    fitted.raster = rasterize(scene, front, placement);
    const double ratio = target / std::max<double>(1.0, double(fitted.raster.samples.size()));
    if (std::abs(ratio - 1.0) <= kCountTolerance || (size == maxSize && ratio > 1.0)) break;
    side = size * std::sqrt(ratio);
  }
  return fitted;
}

// As fitSceneAtlas, for generated charts: the scale changes, and shrinks until the packing fits
// maxSize.
Result<Fitted> fitGeneratedCharts(const Scene& scene, const FrontMesh& front, const std::vector<EdgeUse>& uses,
                                  double target, uint32_t maxSize) {
  Fitted fitted;
  const GeneratedCharts generated = generateCharts(scene, front, uses);
  double scale = std::sqrt(target / std::max(generated.projectedArea, 1e-30));
  for (int round = 0; round < 6; ++round) {
    bool shrunk = false;
    Packing packing = pack(generated, scale);
    for (int fit = 0; std::max(packing.width, packing.height) > maxSize; ++fit) {
      if (fit == 40) {
        return makeError(ErrorCode::InvalidArgument,
                         "charts layout: " + std::to_string(generated.charts.size()) +
                             " charts do not fit in a " + std::to_string(maxSize) + " x " +
                             std::to_string(maxSize) + " atlas");
      }
      scale *= 0.97 * maxSize / double(std::max(packing.width, packing.height));
      packing = pack(generated, scale);
      shrunk = true;
    }
    fitted.placement = place(generated, packing, scale);
    fitted.raster = rasterize(scene, front, fitted.placement);
    const double ratio = target / std::max<double>(1.0, double(fitted.raster.samples.size()));
    if (std::abs(ratio - 1.0) <= kCountTolerance || (shrunk && ratio > 1.0)) break;
    scale *= std::sqrt(ratio);
  }
  return fitted;
}

// The atlas's size, texels and samples; takes the raster's samples.
SampleAtlas atlasFromRaster(const Placement& placement, bool useSceneUvs, Raster& raster) {
  SampleAtlas atlas;
  atlas.width = placement.width;
  atlas.height = placement.height;
  atlas.chartCount = placement.chartCount;
  atlas.usesSceneUvs = useSceneUvs;
  atlas.texelSample = raster.texelSample;
  atlas.texelKinds.assign(raster.texelSample.size(), kTexelEmpty);
  for (size_t texel = 0; texel < atlas.texelKinds.size(); ++texel) {
    if (raster.texelSample[texel] != kNoSample) atlas.texelKinds[texel] = kTexelSample;
  }
  atlas.samples = std::move(raster.samples);
  return atlas;
}

// Neighbours: 4-neighbour texels of one chart that both hold their own sample.
void addChartNeighbours(const Raster& raster, SampleAtlas& atlas) {
  for (uint32_t y = 0; y < atlas.height; ++y) {
    for (uint32_t x = 0; x < atlas.width; ++x) {
      const uint32_t texel = y * atlas.width + x;
      if (!raster.primary[texel]) continue;
      const auto link = [&](uint32_t other) {
        if (raster.primary[other] && raster.texelChart[other] == raster.texelChart[texel]) {
          atlas.neighbours.push_back({atlas.texelSample[texel], atlas.texelSample[other]});
        }
      };
      if (x + 1 < atlas.width) link(texel + 1);
      if (y + 1 < atlas.height) link(texel + atlas.width);
    }
  }
  layout_detail::canonicalizePairs(atlas.neighbours);
}

// Render mesh: vertices shared within a chart (the scene's atlas: as the scene indexes them).
// Returns, per front triangle, the render vertex of each corner.
std::vector<std::array<uint32_t, 3>> appendRenderMesh(const Scene& scene, const FrontMesh& front,
                                                      const Placement& placement, bool useSceneUvs,
                                                      SampleAtlas& atlas) {
  std::map<std::array<uint32_t, 3>, uint32_t> vertexIds;
  std::vector<std::array<uint32_t, 3>> cornerVertex(front.triangles.size());
  for (uint32_t t = 0; t < front.triangles.size(); ++t) {
    const FrontTriangle& tri = front.triangles[t];
    const Surface& surface = scene.surfaces[tri.surface];
    for (uint32_t c = 0; c < 3; ++c) {
      const std::array<uint32_t, 3> key = {useSceneUvs ? 0u : placement.chartOf[t], tri.surface, tri.vertex[c]};
      const auto [it, inserted] =
          vertexIds.try_emplace(key, static_cast<uint32_t>(atlas.mesh.positions.size() / 3));
      if (inserted) {
        const glm::dvec2 q = placement.corners[t][c];
        const glm::vec2 uv = useSceneUvs ? surface.uvs[tri.vertex[c]]
                                         : glm::vec2(static_cast<float>(q.x / atlas.width),
                                                     static_cast<float>(q.y / atlas.height));
        layout_detail::appendVertex(
            atlas.mesh, surface.positions[tri.vertex[c]],
            layout_detail::normalizeOr(surface.normals[tri.vertex[c]], glm::vec3(0.0f, 0.0f, 1.0f)),
            glm::clamp(uv, glm::vec2(0.0f), glm::vec2(1.0f)), layout_detail::frontIor(scene, surface));
      }
      cornerVertex[t][c] = it->second;
      atlas.mesh.indices.push_back(it->second);
    }
  }
  return cornerVertex;
}

// Seams: welded edges whose two triangles show them at different atlas positions.
void addSeams(const FrontMesh& front, const std::vector<EdgeUse>& uses,
              const std::vector<std::array<uint32_t, 3>>& cornerVertex, SampleAtlas& atlas) {
  const auto uvOf = [&](const EdgeUse& use, uint32_t id) {
    const FrontTriangle& tri = front.triangles[use.triangle];
    const uint32_t c = tri.weld[use.edge] == id ? use.edge : (use.edge + 1) % 3;
    const uint32_t v = cornerVertex[use.triangle][c];
    return std::array<float, 2>{atlas.mesh.uvs[2 * v], atlas.mesh.uvs[2 * v + 1]};
  };
  for (size_t k = 0; k < uses.size();) {
    size_t end = k + 1;
    while (end < uses.size() && uses[end].key == uses[k].key) ++end;
    const uint32_t lo = static_cast<uint32_t>(uses[k].key >> 32), hi = static_cast<uint32_t>(uses[k].key);
    for (size_t other = k + 1; other < end && lo != hi; ++other) {
      const SampleAtlas::SharedEdge edge{uvOf(uses[k], lo), uvOf(uses[k], hi), uvOf(uses[other], lo),
                                         uvOf(uses[other], hi)};
      if (edge.a0 != edge.b0 || edge.a1 != edge.b1) atlas.sharedEdges.push_back(edge);
    }
    k = end;
  }
}

}  // namespace

Result<SampleAtlas> buildChartsLayout(const Scene& scene, const LayoutOptions& options) {
  Result<FrontMesh> collected = layout_detail::collectFront(scene);
  if (!collected) {
    return collected.error();
  }
  const FrontMesh& front = collected.value();
  Result<double> target = layout_detail::sampleTarget(options, front.area);
  if (!target) {
    return target.error();
  }
  const uint32_t maxSize = std::min(options.maxAtlasSize, layout_detail::kLargestAtlas);
  const std::vector<EdgeUse> uses = layout_detail::sortedEdgeUses(front);

  std::vector<Tri2> uvs;
  const bool useSceneUvs = sceneAtlas(scene, front, uvs);
  Result<Fitted> fitted = useSceneUvs
                              ? Result<Fitted>(fitSceneAtlas(scene, front, uses, uvs, target.value(), maxSize))
                              : fitGeneratedCharts(scene, front, uses, target.value(), maxSize);
  if (!fitted) {
    return fitted.error();
  }
  const Placement& placement = fitted->placement;
  Raster& raster = fitted->raster;
  const std::vector<double> assigned = fillGutters(front, placement, raster);
  if (options.extendSmoothSeams) extendAcrossSmoothSeams(scene, front, placement, uses, assigned, raster);

  SampleAtlas atlas = atlasFromRaster(placement, useSceneUvs, raster);
  addChartNeighbours(raster, atlas);
  const std::vector<std::array<uint32_t, 3>> cornerVertex =
      appendRenderMesh(scene, front, placement, useSceneUvs, atlas);
  addSeams(front, uses, cornerVertex, atlas);
  return atlas;
}

}  // namespace shrefract::bake
