// The report's temporal stability section (docs/technique.md, "Temporal stability"): an orbit
// of frames around each built-in scene, rendered with the default field at one sample per pixel
// on the GPU and with the physical reference (full Fresnel tree, 4x4 supersampled, CPU); the
// flicker of each (mean absolute frame-to-frame change of the object's pixels) and the field's
// relative to the reference's. The frames stay in the report as PNG sequences to flip through.
#pragma once

#include <shrefract/assets/image.h>
#include <shrefract/environment.h>
#include <shrefract/renderer.h>
#include <shrefract/result.h>

#include <string>
#include <vector>

#include "offscreen/offscreen.h"
#include "report/report.h"

namespace shrefract::report {

struct FlickerOptions {
  ReportSize size = ReportSize::Default;
  std::string outputDirectory;
  uint32_t threads = 0;
};

struct FlickerScene {
  std::string scene;
  uint32_t frames = 0, width = 0, height = 0;
  uint64_t samples = 0;              // the field's sample texels
  double fieldFlicker = 0.0, referenceFlicker = 0.0;
  double seconds = 0.0;
};

// Mean over consecutive frames of the mean absolute change of the colour (clamped to [0, 1], over
// RGB) on the pixels that are the object's in either frame (the masks of bake::ReferenceImage).
double flickerOf(const std::vector<bake::Image>& frames, const std::vector<std::vector<uint8_t>>& masks);

Result<std::vector<FlickerScene>> runFlicker(const FlickerOptions& options, offscreen::Session& session,
                                             const Environment& gpuEnvironment, const bake::Image& environment,
                                             std::vector<std::string>& files);

std::string flickerMarkdown(const std::vector<FlickerScene>& scenes);

}  // namespace shrefract::report
