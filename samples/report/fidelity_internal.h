// What the parts of the report's fidelity section share (fidelity.h): the variants it bakes, the
// profile of a report size, the context of one scene's measurements and the default field kept
// for the decomposition. Private to samples/report.
#pragma once

#include "report/fidelity.h"

#include <shrefract/bake/bake.h>
#include <shrefract/trace/image_metrics.h>
#include <shrefract/bake/layout.h>
#include <shrefract/trace/reference_render.h>
#include <shrefract/bake/shard.h>
#include <shrefract/cpu_reference.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <tuple>

#include "cli/scene_source.h"
#include "report/plot.h"
#include "report/report_text.h"

namespace shrefract::report::fidelity {

// The bunny of the shared assets, looked for from the working directory as the benchmarks do; the
// section skips it (with a line in the report) when it is not there.
inline constexpr const char* kBunny = "../shared/assets/bunny.glb";

// One field setting. It is traced once and finished twice, in f16 and in u8 (bakePair): the u8
// row is the field `bake --quant u8` writes, refinement layers included (Pca), for one trace.
struct Variant {
  std::string series;  // plot series without the quantization: "sh", "table", "pca", ...
  std::string label;   // point label: "L4", "N16", "K32"
  BakeSettings settings;
  bool isDefault = false;
  // The default field's path rule decision: this variant bakes the default under the other rule
  // than the one the bake chose, and where the default kept a volume, that volume (its grid and
  // samples) rather than choosing again (followDefault), so that the rule is all its row changes.
  bool followsDefault = false;
};

struct Profile {
  uint32_t width = 320, height = 240;
  uint32_t samplesPerAxis = 4;
  uint32_t treeDepth = 8;
  uint32_t frames = 5;
  uint32_t environmentWidth = 1024;  // as `shrefract render --env builtin`
  bool antialiasing = true;          // the 1-spp section (CPU references filtered at 1 spp)
  std::vector<std::string> scenes;
  std::vector<Variant> variants;
};

// A GPU render: the image at S x S samples per pixel (untimed), then `frames` timed frames at 1 spp
// (what a host pays per frame; medians), the last of which is kept; with `msaaToo`, also one
// untimed 1-spp frame with the host's 4x MSAA (a count every Vulkan device offers).
struct GpuRender {
  bake::Image image;
  bake::Image image1spp;
  std::optional<bake::Image> image1sppMsaa;  // with msaaToo: 1 spp with the host's 4x MSAA
  double decompressionMs = 0.0, rasterMs = 0.0, frameMs = 0.0;
};

// What the measurements of one scene share.
struct SceneContext {
  const Profile& profile;
  const FidelityOptions& options;
  offscreen::Session& session;
  const Environment& gpuEnvironment;
  const bake::Image& environment;
  std::vector<std::string>& files;
  const std::string& spec;
  const bake::Scene& scene;
  const bake::Tracer& tracer;
  std::string name;  // file name stem
  uint32_t width = 0, height = 0, frames = 0;
  Camera camera;
  bake::ReferenceImage physical;
  bake::ReferenceImage dense;  // the full tree at 2S x 2S (measurePhysical)
  std::map<std::pair<PathRule, bool>, bake::ReferenceImage> exact;  // by path rule and throughput
};

// The default field and its renders, kept for the decomposition.
struct DefaultField {
  std::optional<Field> f16;
  std::optional<GpuRender> gpuF16, gpuU8;
  std::string error;
};

// The variants, image size, references and scenes of a report size (fidelity_profile.cpp).
Profile profileFor(ReportSize size, uint64_t samples);

// Measuring (fidelity_measure.cpp).
Result<FidelityScene> measureScene(SceneContext& c);
std::string sceneTitle(const std::string& spec);
inline const char* ruleName(PathRule rule) { return rule == PathRule::HighestEnergy ? "highest-energy" : "first-refraction"; }
Result<void> writeOut(SceneContext& c, const std::string& name, const bake::Image& image);
// The default field's path rule (the bake's choice: BakeSettings::choosePathRule): the
// decomposition and the side by side compare it with the exact render of that rule.
PathRule defaultRule(const Profile& p, const DefaultField& def);
// The denser reference's samples per axis: 2S - 1. For an even S its cell centres (odd multiples of
// 1 / (2 (2S - 1))) meet neither the S x S renders' (odd multiples of 1 / 2S) nor those of a volume
// field's 2x2 paths at S x S (odd multiples of 1 / 4S); 2S, the report's before, met the latter
// (docs/encodings.md, "The lines against a reference that shares no sub-samples").
inline uint32_t denseSamplesPerAxis(uint32_t s) { return std::min(2 * s - 1, bake::kMaxSamplesPerAxis); }

// Plots and the side by side (fidelity_plots.cpp).
// Side by side: physical | exact (the default's rule) | exact at the texels | u8 field | heat map.
Result<void> writeCompare(SceneContext& c, const DefaultField& def, const std::optional<bake::Image>& texels);
// Plots: PSNR against bytes per sample and against frame time, one series per encoding.
Result<void> writeFidelityPlots(SceneContext& c, const FidelityScene& out);

// The section's text (fidelity_markdown.cpp).
std::string markdownOf(const Profile& p, const std::vector<FidelityScene>& scenes, uint32_t width, uint32_t height,
                       double seconds);

}  // namespace shrefract::report::fidelity
