// CPU renderers the field is measured against, on the same cameras and environments as
// `shrefract render`:
//  - Exact: per pixel, the true path from the eye (with parallax) under a path rule (the
//    highest-energy branch by default), plus the front Fresnel reflection: what the field
//    approximates.
//  - FullTree: every Fresnel branch at every interface to a depth, weighted by energy: the
//    physical reference (depth 8 at 4x4 samples per pixel in the report).
//  - SingleInterface: one Snell bend at the front surface, then the environment: what engines
//    usually ship as a glass shader.
// Shading matches the engine: F * env(reflected) + (1 - F) * env(exit) * exp(-tau * k) * c, with c
// the colour of the medium behind the front surface (in every mode, as the engine's tint).
//
// For the error decomposition of a field (report, docs/technique.md), two more pieces:
//  - exactDistortion: the field's distortion image with the exact path at every sample texel,
//    in place of the decoded encoding (no angular fit, no quantization; the spatial sampling of
//    the atlas stays);
//  - renderDistortion: the raster pass's CPU twin (reference::render's pixel, supersampled)
//    drawing a distortion image through the field's render mesh.
//
// Supersampling (every renderer here): samplesPerAxis = S traces S x S rays per pixel, through
// the centres of an S x S grid of equal sub-pixel cells (stratified, deterministic), and averages
// their linear colours (a box filter). Sub-sample (i, j) of pixel (x, y) is exactly the centre of
// pixel (S x + i, S y + j) of the same camera at S times the size, so a render at S x S equals a
// 1-sample render at S times the size reduced by boxFilter: the GPU path (offscreen) does that.
// The mask marks pixels where more than half of the sub-samples hit the object (coverage > 0.5;
// with S = 1: the pixel-centre ray hits).
#pragma once

#include <shrefract/assets/image.h>
#include <shrefract/assets/scene.h>
#include <shrefract/trace/tracer.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/field.h>
#include <shrefract/renderer.h>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace shrefract::bake {

enum class ReferenceMode { Exact, FullTree, SingleInterface };

// The range of ReferenceOptions::environmentLevelBias: -kMax..kMax levels.
inline constexpr float kMaxEnvironmentLevelBias = 4.0f;

struct ReferenceProgress {
  uint32_t rowsDone = 0;
  uint32_t rowsTotal = 0;
  uint64_t rays = 0;  // rays (or tree leaves) counted so far
  double seconds = 0.0;
};

struct ReferenceOptions {
  ReferenceMode mode = ReferenceMode::Exact;
  uint32_t width = 640;
  uint32_t height = 480;
  Camera camera;                 // same convention as the engine (renderer.h)
  float absorptionScale = 1.0f;  // k
  bool reflection = true;        // add the front Fresnel reflection
  float exposure = 1.0f;
  uint32_t maxBounces = 16;      // Exact; FullTree uses treeDepth
  // Exact: the branch the path follows at every interface after the front one (field.h PathRule).
  PathRule pathRule = PathRule::HighestEnergy;
  // Exact: multiply the transmitted term by the path's Fresnel throughput (PathResult::energy, the
  // product of the factors of the branches taken after the front interface). Without it the path
  // carries all of the transmitted light, as the field's shading assumes.
  bool throughput = false;
  uint32_t treeDepth = 8;          // FullTree: interfaces after the front one
  uint32_t samplesPerAxis = 1;     // S: S x S stratified samples per pixel (see the top), 1..kMaxSamplesPerAxis
  uint32_t threads = 0;            // 0: all hardware threads
  // Look the environment up as the engine does (docs/technique.md): its level chain
  // (reference::environmentLevels), averaged over the pixel (reference::sampleLatLongOverPixel)
  // with each lookup direction's derivatives taken from four probes half a sub-sample cell away
  // (+-x, +-y), traced as well (5x the rays). A probe that hits another surface, misses, or went
  // another way (another number of interfaces or leaves) gives no derivative on its side: a path
  // discontinuity lies between them, found by bisection (3 more traces per such probe), and the
  // probe's colour is blended in with the share of the cell beyond it (shareBeyondCrossings);
  // FullTree: the sample's own side enters with its mean over a linear ramp toward the opposite
  // probe, not the sample's colour. The background stays at level 0 away from the object. False: level 0 everywhere
  // (bake::sampleLatLong), as the physical reference is rendered.
  bool filtered = false;
  // filtered: taps per axis of each lookup, as RendererCreateInfo::environmentTapsPerAxis (1..4).
  // 4, not the engine's default 2: offline the 16 lookups per direction cost little and read the
  // footprint of a fast-turning path closer to the pixel's box (docs/technique.md, "The CPU
  // references"). 2, with environmentLevelBias 0, mirrors the engine.
  uint32_t environmentTapsPerAxis = 4;
  // filtered: levels added to each tap's (reference::LatLongImage::levelBias), in [-4, 4]. -1, not
  // the engine's 0: a trilinear tap blurs over about twice its cell's footprint, so at bias 0 the
  // 4x4 taps spread a pixel over about 1.5 pixels' worth of directions, which a small bright source
  // (the sun) turns into a halo of saturated pixels; one level finer keeps each tap to its cell and
  // the pixel to its box (docs/technique.md, "The CPU references").
  float environmentLevelBias = -1.0f;
  // filtered, FullTree: where a sub-sample's probes see its colour change within the cell (a probe
  // across a discontinuity whose colour differs by more than 0.03 in any channel of the written
  // image, or, with none, the probes' mean on an axis more than 0.01 from the sample's colour), the
  // sub-sample is the mean of four filtered samples of its cell's quarters, each with its own probes:
  // the rim of smooth glass, where Fresnel rises toward grazing in the last tenth of a pixel, and
  // the flanks where the tree changes shape (docs/technique.md, "The CPU references"). False: one
  // filtered sample per cell. The exact mode is not refined: it meets its 2 dB line without (the
  // same section).
  bool refine = true;
  // Called from the calling thread, between the rows it renders, at most every 100 ms, and once
  // at the end. May be empty.
  std::function<void(const ReferenceProgress&)> progress;
};

struct ReferenceImage {
  Image color;  // linear RGBA, alpha 1: the mean of the pixel's sub-samples
  // Per pixel: the normalized mean of the transmitted exit directions of the sub-samples that hit
  // the object (FullTree: each sub-sample's energy-weighted mean); zero where none hits.
  std::vector<glm::vec3> directions;
  std::vector<uint8_t> mask;     // per pixel: 1 where coverage > 0.5 (see the top)
  std::vector<float> coverage;   // per pixel: fraction of the sub-samples that hit the object
  uint64_t rays = 0;
  uint64_t refined = 0;  // sub-samples refined (ReferenceOptions::refine)
  double seconds = 0.0;
};

// The world-space direction of the ray through the centre of pixel (x, y), matching the engine's
// projection (Vulkan clip space, y down).
glm::vec3 pixelDirection(const Camera& camera, uint32_t width, uint32_t height, uint32_t x, uint32_t y);

// Errors (InvalidArgument): a size outside 1..16384 per axis, samplesPerAxis outside
// 1..kMaxSamplesPerAxis (image.h) or a supersampled size beyond 65536 per axis, an empty environment.
Result<ReferenceImage> renderReference(const Tracer& tracer, const Scene& scene, const Image& environment,
                                       const ReferenceOptions& options);

// Filtered renders (ReferenceOptions::filtered) across a path discontinuity: the share of a
// sub-sample's cell, the box [-1/2, 1/2]^2 around it, beyond the discontinuities found toward its
// four probes (+x, -x, +y, -y). crossing[k]: the discontinuity's distance from the sample toward
// probe k, in cells, within (0, 1/2]; 0 where probe k went the sample's way. One crossing: 1/2 - t
// (an edge at right angles to its axis); one on an x and one on a y half-axis: the box's area
// beyond the straight edge through both, split evenly between the two; probes across on both
// sides of an axis (a feature thinner than the cell, or two discontinuities): the expected share
// 1/4 per probe, the axes combined as independent, split evenly. The sample keeps 1 - the sum.
std::array<float, 4> shareBeyondCrossings(const std::array<float, 4>& crossing);

struct ExactDistortionOptions {
  PathRule pathRule = PathRule::HighestEnergy;
  uint32_t maxBounces = 16;
  // As a field with a throughput channel: the direction is scaled by clamp(PathResult::energy, 0, 1)
  // and the image is marked (reference::DistortionImage::throughput).
  bool throughput = false;
  uint32_t threads = 0;  // 0: all hardware threads
};

struct ExactDistortion {
  reference::DistortionImage image;
  uint64_t samples = 0;    // sample texels traced
  uint64_t unmatched = 0;  // sample texels whose surface point the tracer did not find (see below)
  uint64_t rays = 0;
  double seconds = 0.0;
};

// The distortion image the engine would hold for `eye` if every sample texel stored its exact
// path: for each texel of kind kTexelSample, the sample's position p and normal n are recovered
// from its frame (rows of M_s = [R | -R p]: p = -R^T t, n = row 2 of R), its surface and triangle
// from tracer.firstHit along -n from just outside p (or, on an edge or corner where that ray runs
// in the plane of the next face, along -n tilted toward one of 8 tangent directions); the view direction is the one the engine
// decodes for (w = M_s (eye, 1), w.z clamped to >= 0, normalized; zero -> +z), and the path is
// tracer.traceFromSurface(p, -R^T w) under `options` (what the bake traces at a grid direction).
// The texel holds (exit direction normalized, or zero below the engine's length threshold, times
// the clamped throughput with options.throughput; optical depth when the field stores it, else 0,
// clamped to +-65504), rounded to binary16, then
// the field's gutter rules run as in reference::decompress. Empty and gutter texels start at zero.
// A texel whose surface is not found within 1e-3 of the scene's extent of p is traced from p with
// the frame's normal as its geometric normal (on the surface hit along -n, else surface 0), and
// counted in `unmatched`.
// Errors (InvalidArgument): frames, texel kinds or gutters that disagree with the atlas size.
// The field's encoding and coefficients are not read.
Result<ExactDistortion> exactDistortion(const Tracer& tracer, const Field& field, glm::vec3 eye,
                                        const ExactDistortionOptions& options);

struct DistortionRenderOptions {
  uint32_t width = 640;
  uint32_t height = 480;
  Camera camera;
  ObjectShading shading;      // as Object::createFromField sets it by default
  float exposure = 1.0f;
  uint32_t samplesPerAxis = 1;  // as ReferenceOptions
  uint32_t threads = 0;
  // Set: a Volume field traced per fragment (Object::tracesVolumePerFragment), shaded by
  // reference::shadeVolume; the distortion image is not read (an empty one will do).
  const Field* volume = nullptr;
};

// The engine's raster pass on the CPU for one field object: per sub-sample, reference::render's
// pixel (reference::PixelRenderer: the nearest front-facing triangle of `mesh` in double
// precision, its perspective-correct attributes, reference::shadeField with `distortion` and the
// filtered lookups of reference::pixelDerivatives for the sub-sample grid; the environment's level
// 0 where no triangle is hit), but only the triangles whose screen bounds cover the sample are
// tested, so it runs on big meshes. `rays` counts sub-samples. Per-pixel results equal
// reference::render's at S = 1 (reference_test checks it). Errors as renderReference's, and a
// distortion image whose size disagrees with its pixels.
Result<ReferenceImage> renderDistortion(const FieldMesh& mesh, const reference::DistortionImage& distortion,
                                        const Image& environment, const DistortionRenderOptions& options);

}  // namespace shrefract::bake
