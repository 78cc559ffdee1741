// `shrefract report`: error against run time for every setting. For each scene it bakes a sweep of
// settings (SH order, direction density, quantization, layout, smoothing), renders each field on the
// GPU with timings, and compares it per pixel with the exact reference (Embree, CPU); the two
// baselines an engine would otherwise pick (single-interface refraction, exact tracing) and the
// full Fresnel tree are measured the same way. Writes DIR/report.md, plots and side-by-side images.
#pragma once

#include <shrefract/result.h>

#include <cstdint>
#include <string>
#include <vector>

namespace shrefract::report {

enum class ReportSize {
  Smoke,    // seconds: for the test suite
  Default,  // a couple of minutes on 2 cores
  Full,     // the paper's workload (35k samples, 32x64 directions, orders to 16)
};

struct ReportOptions {
  std::vector<std::string> scenes;  // scene specs (builtin:NAME[?options] or glTF); empty: defaults
  std::string outputDirectory;
  ReportSize size = ReportSize::Default;
  uint32_t width = 0, height = 0;   // 0: by size
  uint32_t frames = 0;              // GPU frames timed per setting; 0: by size
  uint32_t threads = 0;             // bake and CPU reference threads; 0: all
  int deviceIndex = -1;
  bool validation = true;
};

// One measured setting (or baseline) of one scene.
struct ReportRow {
  std::string scene;
  std::string group;  // order, directions, quantization, layout, smoothing, baseline
  std::string label;
  uint32_t order = 0;
  std::string directions, quantization, layout, smoothing;
  double psnr = 0, ssim = 0, meanAngle = 0, p95Angle = 0, maxAngle = 0;
  uint64_t pixels = 0;
  uint64_t memoryBytes = 0;   // field file bytes (0 for baselines without a field)
  double bakeSeconds = 0;
  double decompressionMs = 0;  // GPU timestamps, last frame
  double rasterMs = 0;
  double frameMs = 0;          // wall time per frame (median), or CPU seconds per frame for CPU baselines
  bool gpu = true;
};

struct ReportResult {
  std::vector<ReportRow> rows;
  std::vector<std::string> files;  // written, relative to the output directory
  double seconds = 0;
};

// Runs the report. Progress lines go to stderr. Errors: unreadable scenes, an unwritable output
// directory, no Vulkan device, a Vulkan validation message.
Result<ReportResult> runReport(const ReportOptions& options);

}  // namespace shrefract::report
