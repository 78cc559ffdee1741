// The report's fidelity section: how far the field and the usual shortcuts are from the
// physical answer, and where the error comes from.
//
// Physical reference: the full Fresnel tree (every branch at every interface) to depth 8,
// supersampled (trace/reference_render.h); errors are PSNR over the object's pixels, colours
// clamped to [0, 1], also against a denser tree that shares no sample positions with the renders.
// Per scene: exact single paths (highest-energy, first-refraction, each with and without the
// path's Fresnel throughput), single-interface refraction, the default field and, by the size,
// fields at other encodings and budgets; then the error decomposition of the default field:
//   physical -> exact path (path rule) -> exact path at the sample texels (spatial sampling)
//   -> f16 field (angular encoding) -> GPU -> u8 field (quantization) -> 1 spp (pixel sampling).
#pragma once

#include <shrefract/bake/bake_settings.h>
#include <shrefract/result.h>

#include <cstdint>
#include <string>
#include <vector>

#include "offscreen/offscreen.h"
#include "report/report.h"

namespace shrefract::report {

// The tool's default bake (`shrefract bake SCENE` with no flags): the scene decides the encoding
// and its budget (bake::settingsForScene).
BakeSettings defaultFieldSettings();

struct FidelityResult {
  std::vector<FidelityScene> scenes;
  std::string markdown;  // the section of report.md
};

using FidelityOptions = SectionOptions;  // outputDirectory: where its images go

// Runs the section on `session` (validation messages are the caller's to check). Images and plots
// go to the output directory and are appended to `files`. Errors: unreadable scenes (a default
// scene whose asset is missing is skipped instead), CPU renderer failures, unwritable files. A bake
// or upload that fails for one field row makes that row an error row, not a failure.
Result<FidelityResult> runFidelity(const FidelityOptions& options, offscreen::Session& session,
                                   std::vector<std::string>& files);

}  // namespace shrefract::report
