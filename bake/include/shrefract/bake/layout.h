// Sample layouts: where the baker puts its surface samples in the field atlas, and the render mesh
// that reads them back with bilinear filtering. Two layouts (docs/technique.md):
//
//   split   the revised technique: every triangle gets its own (n+1) x (n+1) texel block; samples on
//           shared vertices and edges are one surface point, and gutter texels rebuilt at run time
//           (GutterTexel) make bilinear filtering continuous across every triangle edge.
//   charts  the straightforward technique: triangles grouped into charts of a texture atlas
//           (the scene's TEXCOORD_0 when it is a valid atlas, generated otherwise); filtering is
//           discontinuous at chart borders (seams).
//
// Only surfaces seen from outside the object (outerMedium == 0) are laid out.
#pragma once

#include <shrefract/bake/sample_frame.h>
#include <shrefract/assets/scene.h>
#include <shrefract/field.h>
#include <shrefract/result.h>

#include <array>
#include <cstdint>
#include <vector>

namespace shrefract::bake {

// Sample budget used when LayoutOptions names neither a budget nor a density. Sized for clustered
// Pca fields: a cluster's table is the mean of alike samples, so more samples sharpen the spatial
// term, where shared components had to span them all; fields that keep components lose a little,
// and the bake and file grow (docs/technique.md, "Sample layouts").
inline constexpr uint64_t kDefaultSampleBudget = 40000;

// SampleAtlas::texelSample of a texel that holds no sample (empty or split-layout gutter).
inline constexpr uint32_t kNoSample = 0xFFFFFFFFu;

struct LayoutOptions {
  // At most one of the two is > 0; both 0 means sampleBudget = kDefaultSampleBudget.
  // split: the most unique samples allowed (the layout takes the finest resolution that fits).
  // charts: the number of samples aimed at (the result lands near it, not exactly on it).
  uint64_t sampleBudget = 0;
  // Unique samples per unit of world-space area of the laid-out surfaces.
  float samplesPerUnitArea = 0.0f;
  // Largest atlas width and height, in texels.
  uint32_t maxAtlasSize = 8192;
  // charts: the gutter texels beside a smooth seam hold the surface beyond it (docs/technique.md,
  // "Charts layout (the tool's default)"); false: they copy the nearest sample of their chart, as
  // other gutter texels do (kept to measure the difference).
  bool extendSmoothSeams = true;
};

struct SampleAtlas {
  uint32_t width = 0;   // atlas size in texels
  uint32_t height = 0;
  std::vector<uint8_t> texelKinds;    // width * height: kTexelEmpty, kTexelSample, kTexelGutter
  std::vector<uint32_t> texelSample;  // width * height: index into samples, kNoSample otherwise
  // Distinct surface points to trace. A point that several texels show (a vertex or edge point of
  // the split layout, a chart-layout gutter texel) is here once, so its data is bit-identical in
  // every texel that shows it.
  std::vector<SurfacePoint> samples;
  std::vector<GutterTexel> gutters;   // split layout: continuity rules, applied after decompression
  FieldMesh mesh;                     // render mesh for this atlas (uvs normalized to [0,1])
  // Pairs {a, b} of sample indices (a < b) adjacent on the surface, sorted, no duplicates: the
  // neighbourhood of spatial smoothing. split: edges of each triangle's sample lattice (which
  // connect across triangles through the shared edge samples); charts: 4-neighbour texels of a
  // chart.
  std::vector<std::array<uint32_t, 2>> neighbours;

  // One surface edge seen from two triangles: the segment a0-a1 in triangle A's texels and b0-b1
  // in triangle B's, normalized atlas coordinates; a0 and b0 are the same surface point, as are a1
  // and b1. Filtering the field along a and along b at the same parameter gives the same value
  // when the layout is continuous there (split: every shared edge; charts: none of these).
  struct SharedEdge {
    std::array<float, 2> a0{}, a1{}, b0{}, b1{};
  };
  // split: every welded edge between two triangles; charts: every edge where a chart border
  // separates the two triangles' texels (a seam).
  std::vector<SharedEdge> sharedEdges;

  uint32_t edgeResolution = 0;  // split: n, the samples per triangle edge minus one; charts: 0
  uint32_t chartCount = 0;      // charts: number of charts; split: 0
  bool usesSceneUvs = false;    // charts: true when the scene's TEXCOORD_0 was used as the atlas
};

// Split layout. One edge resolution n >= 1 for all triangles: with a budget, the largest n whose
// unique sample count fits it; with a density, the n whose count is nearest density * area.
// Vertices are welded within a surface by exact position and normal; only welded vertices and
// edges share samples.
// Errors (InvalidArgument): the scene fails validateScene, no surface has outerMedium == 0, both
// budget and density given or a density that is not finite and >= 0, maxAtlasSize == 0, a budget
// smaller than n = 1 needs, or more triangles than 2 x 2 blocks fit in maxAtlasSize^2.
Result<SampleAtlas> buildSplitLayout(const Scene& scene, const LayoutOptions& options);

// Charts layout. Uses the scene's TEXCOORD_0 as the atlas when every laid-out surface has one,
// every UV lies in [0,1], no UV triangle is degenerate and no two overlap; otherwise generates
// charts (dominant normal axis and connectivity, planar projection, shelf packing with a 2-texel
// gutter). Texels whose centre lies inside a triangle are samples; texels within 2 texels of a
// chart reuse the sample of the nearest texel of that chart, so filtering never reads an empty
// texel from inside a triangle.
// Errors (InvalidArgument): as buildSplitLayout, except the last two: when the charts do not fit
// in maxAtlasSize at the asked density they are scaled down to fit.
Result<SampleAtlas> buildChartsLayout(const Scene& scene, const LayoutOptions& options);

}  // namespace shrefract::bake
