// The pieces of the charts layout (charts_layout.cpp): chart sources (chart_generation.cpp),
// packing (chart_packing.cpp), rasterization and gutters (chart_raster.cpp), overlap tests
// (chart_overlap.cpp). Private to the bake.
#pragma once

#include "layout/layout_common.h"

#include <glm/ext/vector_uint2_sized.hpp>
#include <glm/vec2.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace shrefract::bake::layout_detail {

// Texels around every chart that hold copies of its border samples: bilinear filtering at a point
// of a chart reads texels less than 1 texel away, so 1 would do; 2 leaves room for the rounding of
// interpolated UVs and for a future coarser mip level.
inline constexpr uint32_t kGutter = 2;

using Tri2 = std::array<glm::dvec2, 3>;

inline double cross2(glm::dvec2 a, glm::dvec2 b) { return a.x * b.y - a.y * b.x; }

inline double signedArea2(const Tri2& t) { return cross2(t[1] - t[0], t[2] - t[0]); }

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

struct Chart {
  std::vector<uint32_t> triangles;
  glm::dvec2 lo{0.0}, hi{0.0};  // bounds of the projection, world units
};

struct GeneratedCharts {
  std::vector<Chart> charts;
  std::vector<uint32_t> chartOf;
  std::vector<Tri2> projected;  // per front triangle, world units on its chart's plane
  double projectedArea = 0.0;
};

// Shelf packing of the chart rectangles (tallest first) at `scale` texels per world unit. Sizes
// are 64-bit: the caller shrinks the scale until they fit its limit.
struct Packing {
  uint64_t width = 0, height = 0;
  std::vector<glm::u64vec2> origin;  // per chart: corner of its rectangle
};

// Flags the triangles whose interior overlaps another one's. Triangles that only touch (a shared
// edge or vertex, up to `tolerance` times the extent of all triangles) do not count; triangles of
// zero area are skipped. Grid buckets keep the pair tests local.
std::vector<uint8_t> overlapFlags(const std::vector<Tri2>& tris, double tolerance);

// Per front triangle, its TEXCOORD_0 corners when every front surface has a valid atlas.
bool sceneAtlas(const Scene& scene, const FrontMesh& front, std::vector<Tri2>& uvs);

// Charts of the scene's atlas: triangles joined by welded edges with the same UVs on both sides.
uint32_t uvCharts(const FrontMesh& front, const std::vector<EdgeUse>& uses, const std::vector<Tri2>& uvs,
                  std::vector<uint32_t>& chartOf);

GeneratedCharts generateCharts(const Scene& scene, const FrontMesh& front, const std::vector<EdgeUse>& uses);

Packing pack(const GeneratedCharts& generated, double scale);

Placement place(const GeneratedCharts& generated, const Packing& packing, double scale);

// Samples at every texel centre inside a triangle (the first triangle wins a centre on a shared
// edge). A chart that covers no texel centre gets one sample, at the centroid of its largest
// triangle, in the texel under that centroid when the texel is free.
Raster rasterize(const Scene& scene, const FrontMesh& front, const Placement& placement);

// Fills the texels within kGutter texels of each chart (and not inside one) with the sample of the
// nearest texel of that chart; where two charts reach a texel, the nearer sample wins. Returns,
// per texel, the squared distance in texels to the sample it copies (infinity where none).
std::vector<double> fillGutters(const FrontMesh& front, const Placement& placement, Raster& raster);

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
                             const std::vector<EdgeUse>& uses, const std::vector<double>& assigned, Raster& raster);

}  // namespace shrefract::bake::layout_detail
