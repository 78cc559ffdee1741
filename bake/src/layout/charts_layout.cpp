// Charts layout (the straightforward technique): samples are the texels of a chart atlas. The
// scene's TEXCOORD_0 is used when it is a valid atlas; otherwise triangles are grouped by dominant
// normal axis and connectivity, each chart is projected on its axis plane, and the charts are
// shelf-packed with a gutter. Filtering is continuous inside a chart and breaks at chart borders
// (docs/technique.md).
#include <shrefract/bake/layout.h>

#include "layout/charts_common.h"

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

using namespace layout_detail;  // layout_common.h, charts_common.h

// Accept the sample count when it is within this factor of the target.
constexpr double kCountTolerance = 0.1;

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
  const auto vertexAt = [&](const EdgeUse& use, uint32_t id) {
    return cornerVertex[use.triangle][cornerAt(front, use, id)];
  };
  appendSharedEdges(uses, vertexAt, /*seamsOnly=*/true, atlas);
}

}  // namespace

Result<SampleAtlas> buildChartsLayout(const Scene& scene, const LayoutOptions& options) {
  Result<layout_detail::FrontAndTarget> start = layout_detail::frontAndTarget(scene, options);
  if (!start) return start.error();
  const FrontMesh& front = start->front;
  const double target = start->target;
  const uint32_t maxSize = std::min(options.maxAtlasSize, layout_detail::kLargestAtlas);
  const std::vector<EdgeUse> uses = layout_detail::sortedEdgeUses(front);

  std::vector<Tri2> uvs;
  const bool useSceneUvs = sceneAtlas(scene, front, uvs);
  Result<Fitted> fitted = useSceneUvs
                              ? Result<Fitted>(fitSceneAtlas(scene, front, uses, uvs, target, maxSize))
                              : fitGeneratedCharts(scene, front, uses, target, maxSize);
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
