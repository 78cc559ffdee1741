// Split layout (the revised technique): every triangle gets its own (n+1) x (n+1) block of
// texels; texel (i, j) with i + j <= n is the point with barycentric weights (1 - i/n - j/n, i/n,
// j/n) on corners (0, 1, 2). Points on welded vertices and edges are one sample shared by every
// triangle that shows them, and the texels just past each hypotenuse (i + j = n + 1) are gutters
// rebuilt at run time so that bilinear filtering on the hypotenuse is linear between its samples.
// docs/technique.md derives the gutter rule.
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

using layout_detail::cornerAt;
using layout_detail::EdgeUse;
using layout_detail::FrontMesh;
using layout_detail::FrontTriangle;

// Unique samples at edge resolution n of a mesh with V welded vertices, E welded edges and F
// triangles: every vertex once, n - 1 points per edge, (n-1)(n-2)/2 interior points per triangle.
struct SampleCounts {
  uint64_t vertices = 0, edges = 0, triangles = 0;

  uint64_t at(uint64_t n) const {
    const uint64_t interior = n >= 2 ? (n - 1) * (n - 2) / 2 : 0;
    return vertices + edges * (n - 1) + triangles * interior;
  }
};

// Welded edges: uses of one edge are adjacent in `uses`; edge ids follow key order.
struct WeldedEdges {
  std::vector<uint32_t> ofTriangleEdge;  // edge e of triangle t at 3t + e
  uint32_t count = 0;
};

WeldedEdges numberWeldedEdges(const FrontMesh& front, const std::vector<EdgeUse>& uses) {
  WeldedEdges edges;
  edges.ofTriangleEdge.assign(front.triangles.size() * 3, 0);
  uint32_t edgeCount = 0;
  for (size_t k = 0; k < uses.size(); ++k) {
    if (k > 0 && uses[k].key != uses[k - 1].key) {
      ++edgeCount;
    }
    edges.ofTriangleEdge[uses[k].triangle * 3 + uses[k].edge] = edgeCount;
  }
  ++edgeCount;
  edges.count = edgeCount;
  return edges;
}

// Blocks in rows of `perRow`, as square as the triangle count allows.
struct BlockGrid {
  uint64_t perRow = 0, rows = 0;
  uint64_t maxN = 0;  // the largest edge resolution whose blocks fit maxAtlasSize
};

Result<BlockGrid> blockGrid(uint64_t triangles, const LayoutOptions& options) {
  BlockGrid grid;
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
  grid.perRow = perRow;
  grid.rows = rows;
  grid.maxN = maxBlock - 1;
  return grid;
}

// Density: the n whose count is nearest the target (the first on a tie).
uint64_t nearestEdgeResolution(const SampleCounts& counts, double target, uint64_t maxN) {
  uint64_t n = 1;
  while (n + 1 <= maxN && static_cast<double>(counts.at(n)) < target) {
    const double below = target - static_cast<double>(counts.at(n));
    const double above = static_cast<double>(counts.at(n + 1)) - target;
    if (above >= below) break;
    ++n;
  }
  return n;
}

// Budget: the largest n whose count stays within it.
Result<uint64_t> budgetEdgeResolution(const SampleCounts& counts, double target, uint64_t maxN) {
  uint64_t n = 0;
  for (uint64_t m = 1; m <= maxN && static_cast<double>(counts.at(m)) <= target; ++m) {
    n = m;
  }
  if (n == 0) {
    return makeError(ErrorCode::InvalidArgument,
                     "split layout: sample budget " + std::to_string(static_cast<uint64_t>(target)) +
                         " is below the " + std::to_string(counts.at(1)) +
                         " samples of one per welded vertex (edge resolution 1); raise --samples");
  }
  return n;
}

Result<uint64_t> chooseEdgeResolution(const LayoutOptions& options, const SampleCounts& counts, double target,
                                      uint64_t maxN) {
  if (options.samplesPerUnitArea > 0.0f) {
    return nearestEdgeResolution(counts, target, maxN);
  }
  return budgetEdgeResolution(counts, target, maxN);
}

// An atlas of `perRow` x `rows` empty blocks of side n + 1.
SampleAtlas emptyAtlas(uint32_t n32, const BlockGrid& grid, uint64_t sampleCount) {
  const uint32_t block = n32 + 1;
  SampleAtlas atlas;
  atlas.edgeResolution = n32;
  atlas.width = static_cast<uint32_t>(grid.perRow) * block;
  atlas.height = static_cast<uint32_t>(grid.rows) * block;
  const size_t texelCount = size_t(atlas.width) * atlas.height;
  atlas.texelKinds.assign(texelCount, kTexelEmpty);
  atlas.texelSample.assign(texelCount, kNoSample);
  atlas.samples.reserve(sampleCount);
  return atlas;
}

// Fills the atlas one triangle block at a time. The samples of welded vertices and edges are
// remembered across blocks so that every triangle showing one of them reuses the same sample.
class BlockWriter {
 public:
  BlockWriter(const Scene& scene, const FrontMesh& front, const WeldedEdges& edges, uint32_t n32, uint32_t perRow,
              SampleAtlas& atlas)
      : scene_(scene),
        front_(front),
        triangleEdge_(edges.ofTriangleEdge),
        n32_(n32),
        block_(n32 + 1),
        perRow_(perRow),
        atlas_(atlas),
        vertexSample_(front.weldPositions.size(), kNoSample),
        edgeSample_(size_t(edges.count) * (n32 - 1), kNoSample),
        nf_(static_cast<float>(n32)),
        width_(atlas.width),
        height_(atlas.height) {}

  void write(uint32_t t) {
    const FrontTriangle& tri = front_.triangles[t];
    const std::array<glm::vec3, 3> p = {front_.weldPositions[tri.weld[0]], front_.weldPositions[tri.weld[1]],
                                        front_.weldPositions[tri.weld[2]]};
    const std::array<glm::vec3, 3> nv = {front_.weldNormals[tri.weld[0]], front_.weldNormals[tri.weld[1]],
                                         front_.weldNormals[tri.weld[2]]};
    const glm::vec3 geometric = layout_detail::triangleNormal(
        p[0], p[1], p[2], layout_detail::normalizeOr(nv[0] + nv[1] + nv[2], nv[0]));
    const Block b{t, tri, (t % perRow_) * block_, (t / perRow_) * block_, p, nv, geometric};
    writeTexels(b);
    addLatticeNeighbours(b);
    appendRenderTriangle(b);
  }

 private:
  struct Block {
    uint32_t t;
    const FrontTriangle& tri;
    uint32_t bx, by;  // texel of lattice point (0, 0)
    std::array<glm::vec3, 3> p, nv;
    glm::vec3 geometric;
  };

  uint32_t texel(const Block& b, uint32_t i, uint32_t j) const { return (b.by + j) * atlas_.width + b.bx + i; }

  uint32_t addSample(const Block& b, glm::vec3 position, glm::vec3 normal) {
    SurfacePoint point;
    point.position = position;
    point.shadingNormal = layout_detail::normalizeOr(normal, b.geometric);
    point.geometricNormal = b.geometric;  // of the first triangle that shows the point
    point.surface = b.tri.surface;
    point.triangle = b.tri.triangle;
    atlas_.samples.push_back(point);
    return static_cast<uint32_t>(atlas_.samples.size() - 1);
  }

  uint32_t cornerSample(const Block& b, uint32_t c) {
    uint32_t& s = vertexSample_[b.tri.weld[c]];
    if (s == kNoSample) s = addSample(b, b.p[c], b.nv[c]);
    return s;
  }

  // k-th of n points along edge e (corner e toward corner (e+1)%3). The point is keyed from the
  // lower welded id, and computed from the key, so both triangles of the edge get the same one.
  uint32_t edgeSampleAt(const Block& b, uint32_t e, uint32_t k) {
    const uint32_t from = b.tri.weld[e], to = b.tri.weld[(e + 1) % 3];
    const bool forward = from <= to;
    const uint32_t lo = forward ? from : to, hi = forward ? to : from;
    const uint32_t kk = forward ? k : n32_ - k;
    uint32_t& s = edgeSample_[size_t(triangleEdge_[b.t * 3 + e]) * (n32_ - 1) + (kk - 1)];
    if (s == kNoSample) {
      const float w = static_cast<float>(kk) / nf_;
      const glm::vec3 plo = front_.weldPositions[lo], phi = front_.weldPositions[hi];
      const glm::vec3 nlo = front_.weldNormals[lo], nhi = front_.weldNormals[hi];
      s = addSample(b, plo + (phi - plo) * w, nlo + (nhi - nlo) * w);
    }
    return s;
  }

  // Sample of lattice point (i, j), i + j <= n.
  uint32_t latticeSample(const Block& b, uint32_t i, uint32_t j) {
    if (i == 0 && j == 0) return cornerSample(b, 0);
    if (i == n32_ && j == 0) return cornerSample(b, 1);
    if (i == 0 && j == n32_) return cornerSample(b, 2);
    if (j == 0) return edgeSampleAt(b, 0, i);         // corner 0 -> corner 1
    if (i + j == n32_) return edgeSampleAt(b, 1, j);  // corner 1 -> corner 2
    if (i == 0) return edgeSampleAt(b, 2, n32_ - j);  // corner 2 -> corner 0
    const float u = static_cast<float>(i) / nf_, v = static_cast<float>(j) / nf_;
    const std::array<glm::vec3, 3>& p = b.p;
    const std::array<glm::vec3, 3>& nv = b.nv;
    return addSample(b, p[0] + (p[1] - p[0]) * u + (p[2] - p[0]) * v,
                     nv[0] + (nv[1] - nv[0]) * u + (nv[2] - nv[0]) * v);
  }

  void writeTexels(const Block& b) {
    for (uint32_t j = 0; j <= n32_; ++j) {
      for (uint32_t i = 0; i <= n32_; ++i) {
        const uint32_t sum = i + j;
        const uint32_t here = texel(b, i, j);
        if (sum > n32_ + 1) {
          continue;  // never read: filtering inside the triangle stays within i + j <= n + 1
        }
        if (sum == n32_ + 1) {
          atlas_.texelKinds[here] = kTexelGutter;
          atlas_.gutters.push_back({here, texel(b, i - 1, j), texel(b, i, j - 1), texel(b, i - 1, j - 1)});
          continue;
        }
        const uint32_t s = latticeSample(b, i, j);
        atlas_.texelKinds[here] = kTexelSample;
        atlas_.texelSample[here] = s;
      }
    }
  }

  // Lattice edges of the triangle's samples: right, up and the anti-diagonal between them.
  void addLatticeNeighbours(const Block& b) {
    for (uint32_t j = 0; j < n32_; ++j) {
      for (uint32_t i = 0; i + j < n32_; ++i) {
        const uint32_t here = atlas_.texelSample[texel(b, i, j)];
        const uint32_t right = atlas_.texelSample[texel(b, i + 1, j)];
        const uint32_t up = atlas_.texelSample[texel(b, i, j + 1)];
        atlas_.neighbours.push_back({here, right});
        atlas_.neighbours.push_back({here, up});
        atlas_.neighbours.push_back({right, up});
      }
    }
  }

  // Render mesh: the triangle's own three vertices at the texel centres of its corners.
  void appendRenderTriangle(const Block& b) {
    const Surface& surface = scene_.surfaces[b.tri.surface];
    const float ior = layout_detail::frontIor(scene_, surface);
    const std::array<glm::uvec2, 3> corner = {glm::uvec2(0, 0), glm::uvec2(n32_, 0), glm::uvec2(0, n32_)};
    const uint32_t first = static_cast<uint32_t>(atlas_.mesh.positions.size() / 3);
    for (uint32_t c = 0; c < 3; ++c) {
      const uint32_t v = b.tri.vertex[c];
      const glm::vec2 uv(static_cast<float>((b.bx + corner[c].x + 0.5) / width_),
                         static_cast<float>((b.by + corner[c].y + 0.5) / height_));
      layout_detail::appendVertex(atlas_.mesh, surface.positions[v],
                                  layout_detail::normalizeOr(surface.normals[v], b.geometric), uv, ior);
      atlas_.mesh.indices.push_back(first + c);
    }
  }

  const Scene& scene_;
  const FrontMesh& front_;
  const std::vector<uint32_t>& triangleEdge_;
  const uint32_t n32_, block_, perRow_;
  SampleAtlas& atlas_;
  std::vector<uint32_t> vertexSample_;  // per welded vertex
  std::vector<uint32_t> edgeSample_;    // per welded edge, its n - 1 inner points
  const float nf_;
  const double width_, height_;
};

// Shared edges: the first triangle of each welded edge against every other one.
void addSharedEdges(const FrontMesh& front, const std::vector<EdgeUse>& uses, SampleAtlas& atlas) {
  // Every triangle has three render vertices of its own.
  const auto vertexAt = [&](const EdgeUse& use, uint32_t id) {
    return size_t(use.triangle) * 3 + cornerAt(front, use, id);
  };
  layout_detail::appendSharedEdges(uses, vertexAt, /*seamsOnly=*/false, atlas);
}

}  // namespace

Result<SampleAtlas> buildSplitLayout(const Scene& scene, const LayoutOptions& options) {
  Result<layout_detail::FrontAndTarget> start = layout_detail::frontAndTarget(scene, options);
  if (!start) return start.error();
  const FrontMesh& front = start->front;
  const double target = start->target;

  const std::vector<EdgeUse> uses = layout_detail::sortedEdgeUses(front);
  const WeldedEdges edges = numberWeldedEdges(front, uses);
  const uint64_t triangles = front.triangles.size();
  Result<BlockGrid> grid = blockGrid(triangles, options);
  if (!grid) {
    return grid.error();
  }
  const SampleCounts counts{front.weldPositions.size(), edges.count, triangles};
  Result<uint64_t> n = chooseEdgeResolution(options, counts, target, grid->maxN);
  if (!n) {
    return n.error();
  }

  const uint32_t n32 = static_cast<uint32_t>(n.value());
  SampleAtlas atlas = emptyAtlas(n32, grid.value(), counts.at(n.value()));
  BlockWriter writer(scene, front, edges, n32, static_cast<uint32_t>(grid->perRow), atlas);
  for (uint32_t t = 0; t < front.triangles.size(); ++t) {
    writer.write(t);
  }
  layout_detail::canonicalizePairs(atlas.neighbours);
  addSharedEdges(front, uses, atlas);
  return atlas;
}

}  // namespace shrefract::bake
