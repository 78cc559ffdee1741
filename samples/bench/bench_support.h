// Shared by the GPU benchmarks (decompression, frame, memory): synthetic fields of a given size,
// order and quantization, an engine context on the headless harness, GPU timestamps, medians.
// Benchmarks print what they measured and the ratio that matters; they are not tests.
#pragma once

#include <shrefract/context.h>
#include <shrefract/field.h>
#include <shrefract/harness/harness.h>
#include <shrefract/renderer.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "cli/args.h"

namespace shrefract::bench {

// A valid field whose every texel (or the first `sampleFraction` of them, row-major; the others
// are empty) is a sample of a flat patch facing +z, with uniform random coefficients in [-1, 1]
// quantized as asked, in any encoding (field.h): Sh (band 0 of z offset to -4), Table (every
// node's z offset to -4) or Pca (the first component's weight offset to 4, its basis function's z
// to -1; the basis otherwise random in [-0.25, 0.25]), so that the decoded sums stay away from
// zero. A throughput channel, when asked for, holds values in [0, 1]. Values do not matter for
// throughput; sizes, encoding, layers, channels and quantization are those of a real field.
struct SyntheticOptions {
  uint32_t width = 256;
  uint32_t height = 256;
  uint32_t order = 8;        // Sh
  uint32_t channels = 4;     // 3 or 4; with throughput 4 or 5 (the throughput last); + 1 with jumpDistance
  Quantization quantization = Quantization::U8;
  float sampleFraction = 1.0f;
  uint32_t seed = 1;
  Encoding encoding = Encoding::Sh;
  uint32_t tableSize = 0;    // Table, Pca: nodes per side N
  uint32_t components = 0;   // Pca: K
  bool throughput = false;
  // Nodes: decoded jump-aware, as the tool's default Pca bake is (field.h EncodingShape::jumpAware).
  DirectionSampling directionSampling = DirectionSampling::Grid;
  // Nodes and N >= 12: the last channel is a jump distance (EncodingShape::jumpDistance), as in the
  // tool's default bake.
  bool jumpDistance = false;
  // Pca: clustered (EncodingShape::clustered): each sample a random index of one of the K tables.
  bool clustered = false;
};
Field syntheticField(const SyntheticOptions& options);

// A field's encoding as the benchmarks' tables name it: "sh L=8", "table 9x9", "pca K=324 N=16",
// with " nodes" where the cells are decoded jump-aware, " +throughput" and " +jump distance" with
// those channels.
std::string encodingLabel(const Field& field);

// Parses "u8" / "f16".
bool parseQuantization(const std::string& text, Quantization& out);

// A benchmark's command line against `flags` and --validation, which every benchmark has (and
// --help, which cli::Args::parseProgram adds): the arguments, or the exit code to stop with once
// `usage` has printed: usage(nullptr) and 0 for --help, usage(the error line) and 2 for a bad
// command line.
std::variant<cli::Args, int> parseCommandLine(const char* program, int argc, char** argv,
                                              const std::vector<cli::FlagSpec>& flags,
                                              const std::function<void(const char* error)>& usage);

// FIELD.shrf for a benchmark, or the exit code to stop with: 0 after "SKIPPED: PATH does not
// exist" (and `why`) when there is no such file, 1 after the error when it does not read.
std::variant<Field, int> benchmarkField(const std::string& path, const char* why = "");

// A benchmark's usage error: `message` (when given) and then `usage` on stderr; returns 2.
int usageError(const char* message, const char* usage);

// A benchmark's main: its options from the command line (`parse` returns the exit code to stop
// with, or nothing to go on), then `run`.
template <class Options>
int benchmarkMain(int argc, char** argv, std::optional<int> (*parse)(int, char**, Options&),
                  int (*run)(const Options&)) {
  Options options;
  if (const std::optional<int> exitCode = parse(argc, argv, options)) return *exitCode;
  return run(options);
}

// A whole decimal number in [lo, hi]; false for anything else ("12x", "", "-1", a null pointer).
bool parseCount(const char* text, uint32_t lo, uint32_t hi, uint32_t& out);
// The frame benchmarks' flags (frame, reference) after `own`: --size of the frame, --shading,
// --format (readShadingAndFormat reads them) and --cube-env.
std::vector<cli::FlagSpec> withFrameFlags(std::vector<cli::FlagSpec> own);
// The frame benchmarks' --shading (field, exit-direction, single-interface) and --format (rgba16f,
// rgba8, rgba32f) when given; otherwise untouched. The usage line for a value not among them.
std::optional<std::string> readShadingAndFormat(const cli::Args& args, ShadingMode& shading, VkFormat& format);

// The harness (validation off: benchmarks measure the driver, not the layer) and a context on it.
// Returns null after printing "SKIPPED: no Vulkan device" when there is none, or the error.
struct Gpu {
  std::unique_ptr<harness::Harness> harness;
  std::unique_ptr<Context> context;
  ~Gpu();
};
std::unique_ptr<Gpu> createGpu(bool validation, bool* noDevice);

// Timestamp queries for one command buffer at a time: begin(cmd) resets the pool; mark(cmd, i)
// writes timestamp i after all earlier commands; read() returns the milliseconds between marks.
class GpuTimer {
 public:
  GpuTimer(harness::Harness& h, uint32_t marks);
  ~GpuTimer();
  bool available() const { return pool_ != VK_NULL_HANDLE; }
  void begin(VkCommandBuffer cmd);
  void mark(VkCommandBuffer cmd, uint32_t index);
  // Milliseconds from mark `from` to mark `to` of the last submitted command buffer.
  double elapsedMs(uint32_t from, uint32_t to);

 private:
  harness::Harness& h_;
  uint32_t marks_;
  VkQueryPool pool_ = VK_NULL_HANDLE;
  std::vector<uint64_t> ticks_;
  bool fetched_ = false;
};


double median(std::vector<double> values);

// CPU time of the whole process (every thread) in milliseconds. On a software Vulkan device the
// device's worker threads belong to the process, so the difference around a submission is the
// CPU cost of its work, however busy the machine is.
double processCpuMs();


}  // namespace shrefract::bench
