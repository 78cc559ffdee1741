// Split layout (the revised technique): every triangle gets its own (n+1) x (n+1) block of
// texels; texel (i, j) with i + j <= n is the point with barycentric weights (1 - i/n - j/n, i/n,
// j/n) on corners (0, 1, 2). Points on welded vertices and edges are one sample shared by every
// triangle that shows them, and the texels just past each hypotenuse (i + j = n + 1) are gutters
// rebuilt at run time so that bilinear filtering on the hypotenuse is linear between its samples.
// docs/sample-layouts.md derives the gutter rule.
#include <shrefract/bake/layout.h>

#include "layout/layout_common.h"

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace shrefract::bake {
namespace {

using layout_detail::EdgeUse;
using layout_detail::FrontMesh;
using layout_detail::FrontTriangle;

// Unique samples at edge resolution n of a mesh with V welded vertices, E welded edges and F
// triangles: every vertex once, n - 1 points per edge, (n-1)(n-2)/2 interior points per triangle.
uint64_t splitSampleCount(uint64_t vertices, uint64_t edges, uint64_t triangles, uint64_t n) {
  const uint64_t interior = n >= 2 ? (n - 1) * (n - 2) / 2 : 0;
  return vertices + edges * (n - 1) + triangles * interior;
}

}  // namespace

Result<SampleAtlas> buildSplitLayout(const Scene& scene, const LayoutOptions& options) {
  Result<FrontMesh> collected = layout_detail::collectFront(scene);
  if (!collected) {
    return collected.error();
  }
  const FrontMesh& front = collected.value();
  Result<double> target = layout_detail::sampleTarget(options, front.area);
  if (!target) {
    return target.error();
  }

  // Welded edges: uses of one edge are adjacent in `uses`; edge ids follow key order.
  const std::vector<EdgeUse> uses = layout_detail::sortedEdgeUses(front);
  std::vector<uint32_t> triangleEdge(front.triangles.size() * 3);
  uint32_t edgeCount = 0;
  for (size_t k = 0; k < uses.size(); ++k) {
    if (k > 0 && uses[k].key != uses[k - 1].key) {
      ++edgeCount;
    }
    triangleEdge[uses[k].triangle * 3 + uses[k].edge] = edgeCount;
  }
  ++edgeCount;

  // Blocks in rows of `perRow`, as square as the triangle count allows.
  const uint64_t triangles = front.triangles.size();
  uint64_t perRow = static_cast<uint64_t>(std::ceil(std::sqrt(static_cast<double>(triangles))));
  while (perRow * perRow < triangles) ++perRow;
  while (perRow > 1 && (perRow - 1) * (perRow - 1) >= triangles) --perRow;
  const uint64_t rows = (triangles + perRow - 1) / perRow;
  const uint64_t blocksAcross = std::max(perRow, rows);
  const uint32_t maxSize = std::min(options.maxAtlasSize, layout_detail::kLargestAtlas);
  const uint64_t maxBlock = maxSize / blocksAcross;  // block side n + 1 <= this
  if (maxBlock < 2) {
    return makeError(ErrorCode::InvalidArgument,
                     "split layout: " + std::to_string(triangles) + " triangles need at least " +
                         std::to_string(2 * blocksAcross) + " texels across, more than maxAtlasSize " +
                         std::to_string(maxSize));
  }
  const uint64_t maxN = maxBlock - 1;

  const uint64_t vertexCount = front.weldPositions.size();
  const auto count = [&](uint64_t n) { return splitSampleCount(vertexCount, edgeCount, triangles, n); };
  uint64_t n = 0;
  if (options.samplesPerUnitArea > 0.0f) {
    // Density: the n whose count is nearest the target (the first on a tie).
    n = 1;
    while (n + 1 <= maxN && static_cast<double>(count(n)) < target.value()) {
      const double below = target.value() - static_cast<double>(count(n));
      const double above = static_cast<double>(count(n + 1)) - target.value();
      if (above >= below) break;
      ++n;
    }
  } else {
    for (uint64_t m = 1; m <= maxN && static_cast<double>(count(m)) <= target.value(); ++m) {
      n = m;
    }
    if (n == 0) {
      return makeError(ErrorCode::InvalidArgument,
                       "split layout: sample budget " + std::to_string(static_cast<uint64_t>(target.value())) +
                           " is below the " + std::to_string(count(1)) +
                           " samples of one per welded vertex (edge resolution 1); raise --samples");
    }
  }

  const uint32_t n32 = static_cast<uint32_t>(n);
  const uint32_t block = n32 + 1;
  SampleAtlas atlas;
  atlas.edgeResolution = n32;
  atlas.width = static_cast<uint32_t>(perRow) * block;
  atlas.height = static_cast<uint32_t>(rows) * block;
  const size_t texelCount = size_t(atlas.width) * atlas.height;
  atlas.texelKinds.assign(texelCount, kTexelEmpty);
  atlas.texelSample.assign(texelCount, kNoSample);
  atlas.samples.reserve(count(n));

  std::vector<uint32_t> vertexSample(vertexCount, kNoSample);
  std::vector<uint32_t> edgeSample(size_t(edgeCount) * (n32 - 1), kNoSample);
  const float nf = static_cast<float>(n32);
  const double width = atlas.width, height = atlas.height;

  for (uint32_t t = 0; t < front.triangles.size(); ++t) {
    const FrontTriangle& tri = front.triangles[t];
    const Surface& surface = scene.surfaces[tri.surface];
    const uint32_t bx = (t % static_cast<uint32_t>(perRow)) * block;
    const uint32_t by = (t / static_cast<uint32_t>(perRow)) * block;
    const auto texel = [&](uint32_t i, uint32_t j) { return (by + j) * atlas.width + bx + i; };

    const std::array<glm::vec3, 3> p = {front.weldPositions[tri.weld[0]], front.weldPositions[tri.weld[1]],
                                        front.weldPositions[tri.weld[2]]};
    const std::array<glm::vec3, 3> nv = {front.weldNormals[tri.weld[0]], front.weldNormals[tri.weld[1]],
                                         front.weldNormals[tri.weld[2]]};
    const glm::vec3 geometric = layout_detail::triangleNormal(
        p[0], p[1], p[2], layout_detail::normalizeOr(nv[0] + nv[1] + nv[2], nv[0]));
    const auto addSample = [&](glm::vec3 position, glm::vec3 normal) {
      SurfacePoint point;
      point.position = position;
      point.shadingNormal = layout_detail::normalizeOr(normal, geometric);
      point.geometricNormal = geometric;  // of the first triangle that shows the point
      point.surface = tri.surface;
      point.triangle = tri.triangle;
      atlas.samples.push_back(point);
      return static_cast<uint32_t>(atlas.samples.size() - 1);
    };
    const auto cornerSample = [&](uint32_t c) {
      uint32_t& s = vertexSample[tri.weld[c]];
      if (s == kNoSample) s = addSample(p[c], nv[c]);
      return s;
    };
    // k-th of n points along edge e (corner e toward corner (e+1)%3). The point is keyed from the
    // lower welded id, and computed from the key, so both triangles of the edge get the same one.
    const auto edgeSampleAt = [&](uint32_t e, uint32_t k) {
      const uint32_t a = tri.weld[e], b = tri.weld[(e + 1) % 3];
      const bool forward = a <= b;
      const uint32_t lo = forward ? a : b, hi = forward ? b : a;
      const uint32_t kk = forward ? k : n32 - k;
      uint32_t& s = edgeSample[size_t(triangleEdge[t * 3 + e]) * (n32 - 1) + (kk - 1)];
      if (s == kNoSample) {
        const float w = static_cast<float>(kk) / nf;
        const glm::vec3 plo = front.weldPositions[lo], phi = front.weldPositions[hi];
        const glm::vec3 nlo = front.weldNormals[lo], nhi = front.weldNormals[hi];
        s = addSample(plo + (phi - plo) * w, nlo + (nhi - nlo) * w);
      }
      return s;
    };

    for (uint32_t j = 0; j <= n32; ++j) {
      for (uint32_t i = 0; i <= n32; ++i) {
        const uint32_t sum = i + j;
        const uint32_t here = texel(i, j);
        if (sum > n32 + 1) {
          continue;  // never read: filtering inside the triangle stays within i + j <= n + 1
        }
        if (sum == n32 + 1) {
          atlas.texelKinds[here] = kTexelGutter;
          atlas.gutters.push_back({here, texel(i - 1, j), texel(i, j - 1), texel(i - 1, j - 1)});
          continue;
        }
        uint32_t s = kNoSample;
        if (i == 0 && j == 0) {
          s = cornerSample(0);
        } else if (i == n32 && j == 0) {
          s = cornerSample(1);
        } else if (i == 0 && j == n32) {
          s = cornerSample(2);
        } else if (j == 0) {
          s = edgeSampleAt(0, i);  // corner 0 -> corner 1
        } else if (sum == n32) {
          s = edgeSampleAt(1, j);  // corner 1 -> corner 2
        } else if (i == 0) {
          s = edgeSampleAt(2, n32 - j);  // corner 2 -> corner 0
        } else {
          const float u = static_cast<float>(i) / nf, v = static_cast<float>(j) / nf;
          s = addSample(p[0] + (p[1] - p[0]) * u + (p[2] - p[0]) * v,
                        nv[0] + (nv[1] - nv[0]) * u + (nv[2] - nv[0]) * v);
        }
        atlas.texelKinds[here] = kTexelSample;
        atlas.texelSample[here] = s;
      }
    }

    // Lattice edges of the triangle's samples: right, up and the anti-diagonal between them.
    for (uint32_t j = 0; j < n32; ++j) {
      for (uint32_t i = 0; i + j < n32; ++i) {
        const uint32_t here = atlas.texelSample[texel(i, j)];
        const uint32_t right = atlas.texelSample[texel(i + 1, j)];
        const uint32_t up = atlas.texelSample[texel(i, j + 1)];
        atlas.neighbours.push_back({here, right});
        atlas.neighbours.push_back({here, up});
        atlas.neighbours.push_back({right, up});
      }
    }

    // Render mesh: the triangle's own three vertices at the texel centres of its corners.
    const float ior = layout_detail::frontIor(scene, surface);
    const std::array<glm::uvec2, 3> corner = {glm::uvec2(0, 0), glm::uvec2(n32, 0), glm::uvec2(0, n32)};
    const uint32_t first = static_cast<uint32_t>(atlas.mesh.positions.size() / 3);
    for (uint32_t c = 0; c < 3; ++c) {
      const uint32_t v = tri.vertex[c];
      const glm::vec2 uv(static_cast<float>((bx + corner[c].x + 0.5) / width),
                         static_cast<float>((by + corner[c].y + 0.5) / height));
      layout_detail::appendVertex(atlas.mesh, surface.positions[v],
                                  layout_detail::normalizeOr(surface.normals[v], geometric), uv, ior);
      atlas.mesh.indices.push_back(first + c);
    }
  }
  layout_detail::canonicalizePairs(atlas.neighbours);

  // Shared edges: the first triangle of each welded edge against every other one.
  const auto cornerUv = [&](uint32_t t, uint32_t c) {
    const size_t v = size_t(t) * 3 + c;
    return std::array<float, 2>{atlas.mesh.uvs[2 * v], atlas.mesh.uvs[2 * v + 1]};
  };
  for (size_t k = 0; k < uses.size();) {
    size_t end = k + 1;
    while (end < uses.size() && uses[end].key == uses[k].key) ++end;
    const uint32_t lo = static_cast<uint32_t>(uses[k].key >> 32);
    const uint32_t hi = static_cast<uint32_t>(uses[k].key & 0xFFFFFFFFu);
    if (lo != hi) {
      // Corner of a use's triangle that sits at welded id `id`.
      const auto endpoint = [&](const EdgeUse& use, uint32_t id) {
        const FrontTriangle& tri = front.triangles[use.triangle];
        const uint32_t c = tri.weld[use.edge] == id ? use.edge : (use.edge + 1) % 3;
        return cornerUv(use.triangle, c);
      };
      for (size_t other = k + 1; other < end; ++other) {
        atlas.sharedEdges.push_back({endpoint(uses[k], lo), endpoint(uses[k], hi),
                                     endpoint(uses[other], lo), endpoint(uses[other], hi)});
      }
    }
    k = end;
  }
  return atlas;
}

}  // namespace shrefract::bake
