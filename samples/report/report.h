// `shrefract report`: error against run time for every setting. For each scene it bakes a sweep of
// settings (SH order, direction density, quantization, layout, smoothing), renders each field on the
// GPU with timings, and compares it per pixel with the exact reference (Embree, CPU); the two
// baselines an engine would otherwise pick (single-interface refraction, exact tracing) and the
// full Fresnel tree are measured the same way; then the fidelity section (report/fidelity.h) measures
// everything against the physical reference and decomposes the field's error. Writes DIR/report.md,
// plots and side-by-side images.
#pragma once

#include <shrefract/field.h>
#include <shrefract/result.h>

#include <cstdint>
#include <string>
#include <vector>

namespace shrefract::report {

enum class ReportSize {
  Smoke,    // seconds: for the test suite
  Default,  // minutes on 2 cores: the fidelity section of the default fields
  Full,     // hours: the settings sweeps, stability cases, flicker orbits and every fidelity row
};

// What the report and each of its sections are run with.
struct SectionOptions {
  std::vector<std::string> scenes;  // scene specs (builtin:NAME[?options] or glTF); empty: defaults
  std::string outputDirectory;
  ReportSize size = ReportSize::Default;
  uint32_t width = 0, height = 0;   // 0: by size
  uint32_t frames = 0;              // GPU frames timed per setting; 0: by size
  uint32_t threads = 0;             // bake and CPU reference threads; 0: all
  uint64_t samples = 0;             // sample budget of the bakes (stiff cases: at most 1500); 0: by size
};

struct ReportOptions : SectionOptions {
  int deviceIndex = -1;
  bool validation = true;
  bool fidelityOnly = false;        // only the fidelity section (report/fidelity.h)
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

// One row of the fidelity section (report/fidelity.h).
struct FidelityRow {
  std::string scene;
  std::string kind;    // "physical", "exact", "single interface", "field"
  std::string label;   // e.g. "sh L8 32x64 (default)"
  std::string series;  // plot series: "sh u8", "table f16", ...
  std::string encoding, parameters, directions, quantization;  // "-" where they do not apply
  PathRule pathRule = PathRule::HighestEnergy;
  bool throughput = false;
  uint32_t bytesPerSample = 0;   // fields only
  uint64_t samples = 0;          // fields: distinct surface points traced (BakeStatistics::uniqueSamples)
  double psnrPhysical = 0.0;     // dB against the physical reference
  double psnrSameRule = 0.0;     // dB against the exact render of the same path rule (see fidelity_measure.cpp)
  // dB against the full tree at 2S x 2S, which shares no sample positions with the S x S renders
  // (the physical row: the S x S reference's own figure against it).
  double psnrDense = 0.0;
  double bakeSeconds = 0.0;      // fields: the bake (a u8 row shares its f16 twin's trace: that bake's)
  double decompressionMs = 0.0;  // GPU timestamps, 1 spp, last timed frame
  double rasterMs = 0.0;
  double cpuMs = 0.0;            // CPU renderers: milliseconds per 1-spp frame (the 4x4 render / 16)
  bool gpu = false;
  std::string error;             // non-empty: the row could not be measured (bake or upload failed)
};

struct FidelityStep {
  std::string step;      // "path rule", "spatial sampling", ...
  std::string compares;  // "exact highest-energy vs physical"
  double psnr = 0.0;     // between the two stages
  double cumulative = 0.0;  // the coarser stage against the physical reference
  std::string error;
};

// One mode at one sample per pixel with filtered lookups, and the same mode supersampled, each
// against the physical reference (the anti-aliasing target: within 2 dB of each other), and
// against a denser one (the full tree at 2S x 2S), which shares no sample positions with the
// S x S renders and gives the full tree's own row a finite figure.
struct FidelityAntialiasing {
  std::string mode;              // "default field u8 (GPU)", "exact highest-energy (CPU)", ...
  double psnrOneSample = 0.0;    // 1 spp, filtered
  double psnrSupersampled = 0.0; // S x S; infinity for the full tree, which is the reference
  double denseOneSample = 0.0, denseSupersampled = 0.0;  // the same against the 2S x 2S full tree
};

struct FidelityScene {
  std::string scene;
  std::string skipped;  // non-empty: why the scene was left out (e.g. a missing asset)
  uint64_t pixels = 0;  // object pixels compared
  uint32_t samplesPerAxis = 0;
  std::vector<FidelityRow> rows;
  std::vector<FidelityStep> decomposition;
  std::vector<FidelityAntialiasing> antialiasing;
  uint32_t denseSamplesPerAxis = 0;  // of the antialiasing table's denser reference
  uint64_t unmatchedTexels = 0, sampleTexels = 0;  // exact-at-texels: surface points not found
  double seconds = 0.0;
};

struct ReportResult {
  std::vector<ReportRow> rows;
  std::vector<FidelityScene> fidelity;
  std::vector<std::string> files;  // written, relative to the output directory
  double seconds = 0;
};

// Runs the report. Progress lines go to stderr. Errors: unreadable scenes, an unwritable output
// directory, no Vulkan device, a Vulkan validation message.
Result<ReportResult> runReport(const ReportOptions& options);

}  // namespace shrefract::report
