// The offline bake: lay out surface samples, trace every sample in every grid direction with
// Embree, fit SH per sample, smooth, quantize, and assemble a Field ready to be written.
#pragma once

#include <shrefract/assets/scene.h>
#include <shrefract/bake/bake_settings.h>
#include <shrefract/field.h>
#include <shrefract/result.h>

#include <cstdint>
#include <functional>
#include <string>

namespace shrefract::bake {

struct BakeProgress {
  uint64_t samplesDone = 0;
  uint64_t samplesTotal = 0;
  uint64_t rays = 0;
  double seconds = 0.0;
};

struct BakeOptions {
  // order, directions, layout, sample budget or density, max bounces, window, spatial neighbours,
  // quantization, regularization (0: kDefaultRegularization) and the source name. `threads` 0
  // means all hardware threads; it never changes the field's data.
  BakeSettings settings;
  // Random held-out directions traced per sample to measure the fit away from the grid (the
  // statistics only; 0 disables).
  uint32_t heldOutDirections = 4;
  // Called from the calling thread about every 100 ms and once at the end.
  std::function<void(const BakeProgress&)> progress;
  // One-line notes on choices the bake made (the --max-error selection), for the tool to print.
  std::function<void(const std::string&)> note;
  // Called from the calling thread as each stage after the tracing begins (choosing the exit
  // frame, learning a Pca basis, checking the fit, quantizing), with what it does: on large tables
  // these take long, and `progress` alone would leave them silent (docs/performance.md, "By
  // encoding").
  std::function<void(const std::string&)> stage;
};

// settings.maxErrorDegrees > 0 ("--max-error"): before the bake, the smallest SH order (0 up to
// settings.order) and the coarsest direction grid (8x16 up to settings.directionsTheta x Phi) that
// meet the target are chosen on a deterministic subset of the samples (up to 192). The error is
// the mean angle between traced and reconstructed exit directions over 64 held-out view directions
// per sample, cosine-weighted (as often as a view direction covers the screen). The cheapest
// candidate wins: fewest basis functions, then fewest directions. If no candidate meets the target,
// the largest order and grid are used and a note says so.

// Largest table size the bake fits: the format's kMaxTableSize. A grid-fitted Table inverts an
// N^2 x N^2 matrix (4096^2 at 64); a Pca over 64x64 tables traces 4096 paths a sample and learns
// its basis from the tables themselves, without their Gram matrix, whose size grows as the square
// of a table's (docs/performance.md, "By encoding").
inline constexpr uint32_t kMaxBakeTableSize = kMaxTableSize;

// Nodes per side of the Pca basis tables when the caller does not ask (the tool's default field and
// the report's). With the exits in the sample's frame, finer tables under the same 324 weights
// read closer on every built-in scene, for 4x the traced paths and basis per doubling and a
// longer, larger bake (docs/encodings.md, "Pca").
inline constexpr uint32_t kDefaultPcaTableSize = 64;
// The same for a Pca fitted to a direction grid (--direction-sampling grid): the default 32x64 grid
// traces 2048 directions, half the nodes of a 64x64 table.
inline constexpr uint32_t kDefaultGridPcaTableSize = 32;

// The hemisphere grid a bake accepts (settings.directionsTheta x directionsPhi), and the cap on
// interactions: one declaration, read by the bake's checks and by the tool's flags.
inline constexpr uint32_t kMinDirectionRows = 1, kMaxDirectionRows = 512;
inline constexpr uint32_t kMinDirectionColumns = 1, kMaxDirectionColumns = 1024;
inline constexpr uint32_t kMaxBakeBounces = 1024;

// BakeSettings::volumeDensify: a Volume field whose paths between neighbouring texels, as its texels
// predict them, see colours below kVolumeDensifyBelowDb of PSNR is laid out again at
// kVolumeDensifyFactor times the sample budget, once: where texels predict the paths poorly
// (chaotic paths, edges between faces) more of them bring the image closer; elsewhere the cheaper
// layout stays (docs/encodings.md, "Samples").
inline constexpr double kVolumeDensifyBelowDb = 32.0;
inline constexpr uint64_t kVolumeDensifyFactor = 4;
// BakeSettings::tryVolume with no volumeSize: the volume tried is kDefaultVolumeSize per side, or
// twice that where the image choice (4 views, 320x240 at 2x2 against exact renders) reads it at
// least kFinerVolumeGainDb closer: the finer grid costs 8x the dense grid's memory, and only some
// scenes read closer at it (docs/encodings.md, "The default encoding").
inline constexpr double kFinerVolumeGainDb = 0.25;
// BakeSettings::choosePathRule: the bake keeps highest-energy where its exact renders at the image
// choice's views (4 views, 320x240 at 2x2, against the full tree at depth 8 at the same positions)
// come at least this much closer than first-refraction's, the tool's rule otherwise (first-
// refraction fields have fewer jumps). A volume follows its rule's exact render, and which rule
// reads closer depends on the scene (docs/encodings.md, "The path rule").
inline constexpr double kHighestEnergyGainDb = 0.25;
// The budget the default bake's grids are held to: the paper's 324 encoded bytes per sample (81 SH
// coefficients x 4 channels x 1 byte), a grid's stored bytes (volumeGridBytes: its brick entries
// and the words of the bricks the band reaches) counted over the field's samples (its frames and
// mesh not counted, as for every encoding). Stored in bricks, the built-in scenes' 256^3 grids fit
// it at the default samples, where a dense one would not (docs/encodings.md, "Bricks").
inline constexpr double kDefaultBytesPerSampleBudget = 324.0;
// Whether a grid of `gridBytes` fits kDefaultBytesPerSampleBudget over `samples` samples.
constexpr bool volumeFitsDefaultBudget(uint64_t gridBytes, uint64_t samples) {
  return double(gridBytes) <= kDefaultBytesPerSampleBudget * double(samples);
}
// The pairs of texels the check traces (kFrameChoiceViews views each).
inline constexpr size_t kVolumeDensityPairs = 4000;

// BakeSettings::tryVolume without chooseByImages: the encoding follows from what the scene is,
// with no image rendered. One closed medium in air (volumeSceneProblem empty): the Volume encoding,
// kDefaultVolumeSize per side unless volumeSize is given, traced in texture space by the engine;
// quick to bake, small to store. Otherwise (several media, open or overlapping volumes,
// which the grid's one interface rule cannot hold): Pca over kDefaultPerSampleTableSize node
// tables, 324 components or as many clusters, exits in the sample's frame. A sample budget of 0
// (and no density) becomes kDefaultSampleBudget for a convex volume (densified: volumeDensify),
// kDefaultConcaveVolumeBudget for a concave one, whose samples trace nothing at the bake, and
// kDefaultPerSampleBudget for Pca, which keeps its bake short (docs/performance.md, "Default
// fields"). Its tables are means over a cluster's samples, so finer tables over fewer samples read
// closer than coarser ones over more (docs/encodings.md, "The default encoding").
// The path rule and quantization are kept; `why` (optional) receives the reason, for the note.
// A concave volume (the trace follows several segments a path) lays out kDefaultConcaveVolumeBudget
// samples, a convex one kDefaultSampleBudget, laid out again as volumeDensify says.
inline constexpr uint64_t kDefaultConcaveVolumeBudget = 20000;
inline constexpr uint32_t kDefaultPerSampleTableSize = 24, kDefaultPcaComponents = 324;
inline constexpr uint64_t kDefaultPerSampleBudget = 12000;
BakeSettings settingsForScene(const Scene& scene, BakeSettings settings, std::string* why = nullptr);

// Bakes `scene`. Errors: invalid settings (order 0..kMaxFitOrder, the direction grid and bounces
// above, spatial 0/3/5),
// an invalid scene, layout failures. The result passes validateField().
Result<Field> bakeField(const Scene& scene, const BakeOptions& options);

}  // namespace shrefract::bake
