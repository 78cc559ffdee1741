// Decompression benchmark: bytes of SH coefficients read per second by the engine's decompression
// pass, against plain copies of the same number of bytes on the same device in the same run (GPU
// timestamps, several repetitions, medians). Target: at least half of the copy's rate.
//
//   shrefract_decompression_benchmark [FIELD.shrf] [--size WxH] [--order L] [--quant u8|f16]
//                                     [--channels 3|4] [--reps N] [--validation] [--profile]
//   shrefract_decompression_benchmark --encodings [--size WxH] [--reps N] [--validation]
//
// Without FIELD.shrf a synthetic field of the given size, order, channels and quantization is
// built in memory (random coefficients: the values do not change the work). The references are
// compute shaders with no arithmetic that copy as many bytes as the decompression reads, through
// each path the engine could read them by: storage buffer to storage buffer (a word per
// invocation), texel buffer to storage texel buffer (a word, or four words, per invocation). The
// ratio is taken against the fastest of them. For reference only, a copy of the layout the engine
// used before (an RGBA 2D-array image of every texel and layer, a texelFetch each) is timed too.
// Bytes are coefficient bytes; the frames and texel indices the decompression also reads are not
// counted. The process CPU time is printed as well: on a software device (llvmpipe) it is the
// work itself, whatever else competes for the cores, while timestamps include the waiting.
// --profile repeats the decompression alone (for perf) and prints its times.
//
// --encodings compares the encodings (field.h) at the paper's budget of 324 coefficient bytes per
// sample instead: synthetic fields of the same atlas (--size, default 233x233 = 54289 samples,
// about the bunny's 54123; every texel a sample) in each encoding the bake's
// --max-bytes-per-sample picks from at 324 bytes (bake/src/driver/budget.cpp budgetCandidates), plus Pca K = 64 and
// the same order or table over the budget with the throughput channel, each uploaded as its own
// object and decompressed by the engine (Decompressor::record) in turns within every repetition.
// It prints the median GPU milliseconds of a decompression, the median over repetitions of its
// ratio to SH order 8 (u8, 4 channels: the paper's field) in the same repetition (and two Volume
// fields, which store nothing per sample: a glass box's grid at 128^3 and 256^3), the process
// CPU time, and the device memory of each field's buffers (coefficients, scale/bias table, Pca
// basis, or a Volume field's grid, in the basis column: their sizes as gpu_layout.h lays them out)
// and of the whole object
// (Object::gpuMemoryBytes(), with the frames, texel indices, distortion image and mesh).
// Exit code 0 with "SKIPPED:" when there is no Vulkan device or FIELD.shrf is missing.
#include <shrefract/decompressor.h>
#include <shrefract/renderer.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bench/bench_support.h"
#include "bench/copy_references.h"
#include "cli/args.h"

namespace shrefract::bench {
namespace {

struct Options {
  std::string field;
  SyntheticOptions synthetic;
  uint32_t reps = 15;
  bool validation = false;
  bool profile = false;
  bool encodings = false;  // compare the encodings at 324 bytes per sample (see the top)
  bool sizeGiven = false;
};

int usage(const char* message) {
  return usageError(message,
                    "usage: shrefract_decompression_benchmark [FIELD.shrf] [--size WxH] [--order L] [--quant u8|f16]\n"
                    "                                         [--channels 3|4] [--reps N] [--validation] [--profile]\n"
                    "       shrefract_decompression_benchmark --encodings [--size WxH] [--reps N] [--validation]\n");
}

// Median GPU milliseconds (and process CPU milliseconds) of each recorder over `reps` rounds,
// after two warm-up rounds. The recorders take turns within a round, each in its own submission,
// so that a change in the load of a shared machine affects all of them alike.
struct Timing {
  double ms = 0.0, fastestMs = 0.0, cpuMs = 0.0;
  std::vector<double> rounds;  // GPU milliseconds of each timed round, in order
};
std::vector<Timing> timeTurns(harness::Harness& h, GpuTimer& timer, uint32_t reps,
                              const std::vector<std::function<void(VkCommandBuffer)>>& recorders, bool& failed) {
  std::vector<std::vector<double>> ms(recorders.size()), cpu(recorders.size());
  for (uint32_t round = 0; round < reps + 2 && !failed; ++round)
    for (size_t k = 0; k < recorders.size() && !failed; ++k) {
      const double cpuStart = processCpuMs();
      auto submitted = h.submitAndWait([&](VkCommandBuffer cmd) {
        timer.begin(cmd);
        timer.mark(cmd, 0);
        recorders[k](cmd);
        timer.mark(cmd, 1);
      });
      const double cpuEnd = processCpuMs();
      if (!submitted) {
        std::fprintf(stderr, "%s\n", submitted.error().message.c_str());
        failed = true;
      } else if (round >= 2) {
        ms[k].push_back(timer.elapsedMs(0, 1));
        cpu[k].push_back(cpuEnd - cpuStart);
      }
    }
  std::vector<Timing> out(recorders.size());
  for (size_t k = 0; k < recorders.size() && !failed; ++k)
    out[k] = {median(ms[k]), *std::min_element(ms[k].begin(), ms[k].end()), median(cpu[k]), ms[k]};
  return out;
}

// --encodings: one field of the comparison (see the top of this file).
struct EncodingCase {
  const char* name;
  Encoding encoding;
  uint32_t order, tableSize, components, channels;
  bool throughput;
  Quantization quantization;
  DirectionSampling sampling = DirectionSampling::Grid;
  bool jumpDistance = false;  // channels count it
  bool clustered = false;     // Pca: one index per sample (2 bytes), K tables
};
// At 324 bytes per sample the bake's budget candidates (bake/src/driver/budget.cpp budgetCandidates) are, with 4
// channels: SH order 8, Table 9x9 and Pca K = 324 in u8, SH order 5 and Table 6x6 in f16 (288
// bytes); with the throughput as a fifth channel: SH order 7 and Table 8x8 in u8 (320 bytes).
// Pca K = 64 shows how the Pca cost scales with K; SH order 8 and Table 9x9 with 5 channels show
// what the throughput channel alone costs at the same order or table. "nodes" is Pca traced at its
// table nodes, whose cells are decoded jump-aware (docs/encodings.md), "+jump distance" with that
// channel: 5 channels for glass that absorbs (the built-in scenes), 4 for glass that does not (the
// bunny). The tool's default bake is the N=64 case: 64x64 node tables, a basis 16 times the N=16
// cases' (324 x 4096 nodes x 5 channels, 26.5 MB of floats). "clustered" is the same shape stored
// as the bake stores a clustered field: each sample the index of one of the K tables (2 bytes).
constexpr std::array<EncodingCase, 18> kEncodingCases{{
    {"sh L=8 (paper)", Encoding::Sh, 8, 0, 0, 4, false, Quantization::U8},
    {"sh L=5", Encoding::Sh, 5, 0, 0, 4, false, Quantization::F16},
    {"table 9x9", Encoding::Table, 0, 9, 0, 4, false, Quantization::U8},
    {"table 6x6", Encoding::Table, 0, 6, 0, 4, false, Quantization::F16},
    {"pca K=324 N=16", Encoding::Pca, 0, 16, 324, 4, false, Quantization::U8},
    {"pca K=324 N=16 nodes", Encoding::Pca, 0, 16, 324, 4, false, Quantization::U8, DirectionSampling::Nodes},
    {"pca K=324 N=16 nodes +jump distance", Encoding::Pca, 0, 16, 324, 5, false, Quantization::U8,
     DirectionSampling::Nodes, true},
    {"pca K=324 N=16 nodes 3ch +jump distance", Encoding::Pca, 0, 16, 324, 4, false, Quantization::U8,
     DirectionSampling::Nodes, true},
    {"pca K=324 N=64 nodes +jump distance (default)", Encoding::Pca, 0, 64, 324, 5, false, Quantization::U8,
     DirectionSampling::Nodes, true},
    {"pca clustered K=324 N=64 nodes +jump distance", Encoding::Pca, 0, 64, 324, 5, false, Quantization::U8,
     DirectionSampling::Nodes, true, true},
    {"pca K=64 N=16", Encoding::Pca, 0, 16, 64, 4, false, Quantization::U8},
    {"sh L=8 +throughput", Encoding::Sh, 8, 0, 0, 5, true, Quantization::U8},
    {"sh L=7 +throughput", Encoding::Sh, 7, 0, 0, 5, true, Quantization::U8},
    {"table 9x9 +throughput", Encoding::Table, 0, 9, 0, 5, true, Quantization::U8},
    {"table 8x8 +throughput", Encoding::Table, 0, 8, 0, 5, true, Quantization::U8},
    {"pca K=324 N=16 +throughput", Encoding::Pca, 0, 16, 324, 5, true, Quantization::U8},
    // No bytes per sample: each sample's path traced through a glass box's grid (table size = N).
    {"volume 128^3", Encoding::Volume, 0, 128, 0, 4, false, Quantization::U8},
    {"volume 256^3", Encoding::Volume, 0, 256, 0, 4, false, Quantization::U8},
}};

// Bytes of the field's buffers as createFromField sizes them (gpu_layout.h): the coefficients of
// the sample texels (Sh: planes of the sample count rounded up to 4), the scale/bias table (Sh:
// SHR_SH_SCALE_BIAS_VEC4S(channels) = 2 or 3 vec4s per basis function, allocated for f16 too;
// Table and Pca: a vec2 per layer and value, at least one vec4) and the Pca basis (floats; a
// placeholder vec4 otherwise). Memory requirements may round each up to the device's alignment;
// Object::gpuMemoryBytes() counts those.
struct FieldBufferBytes {
  uint64_t coefficients = 0, scaleBias = 0, basis = 0;
};
FieldBufferBytes fieldBufferBytes(const Field& field, uint64_t samples) {
  const uint64_t layers = field.layerCount(), values = field.valuesPerLayer();
  const uint64_t stored = field.encoding == Encoding::Sh ? (samples + 3) / 4 * 4 : samples;
  FieldBufferBytes b;
  b.coefficients = std::max<uint64_t>((stored * layers * values * field.coefficientValueBytes() + 3) / 4 * 4, 4);
  b.scaleBias = field.encoding == Encoding::Sh ? layers * (field.channels > 4 ? 3 : 2) * 16
                                               : std::max<uint64_t>(layers * values * 8, 16);
  b.basis = std::max<uint64_t>((field.basis.size() * field.basisValueBytes() + 3) / 4 * 4, 16);
  if (field.encoding == Encoding::Volume) b.basis = 48 + volumeGridBytes(field.volume);  // VolumeHeader + grid
  return b;
}

uint64_t sampleCount(const Field& field) {
  uint64_t samples = 0;
  for (uint8_t k : field.texelKinds) samples += k == kTexelSample;
  return samples;
}

// GB/s of reading `bytesRead` in `ms` milliseconds; 0 without a time.
double rate(uint64_t bytesRead, double ms) { return ms > 0.0 ? double(bytesRead) / (ms * 1e-3) / 1e9 : 0.0; }

// --encodings: one uploaded field of the comparison and what it occupies.
struct EncodingEntry {
  EncodingCase c;
  std::unique_ptr<Object> object;
  uint32_t bytesPerSample = 0;
  uint64_t samples = 0;
  FieldBufferBytes buffers;
  uint64_t objectBytes = 0;
};

SyntheticOptions encodingCaseOptions(const SyntheticOptions& base, const EncodingCase& c) {
  SyntheticOptions o = base;
  o.encoding = c.encoding;
  o.order = c.order;
  o.tableSize = c.tableSize;
  o.components = c.components;
  o.channels = c.channels;
  o.throughput = c.throughput;
  o.quantization = c.quantization;
  o.directionSampling = c.sampling;
  o.jumpDistance = c.jumpDistance;
  o.clustered = c.clustered;
  return o;
}

// The case's synthetic field uploaded and prepared for decompression; errors name the case.
Result<EncodingEntry> uploadEncodingCase(Context& context, Decompressor& decompressor, const SyntheticOptions& base,
                                         const EncodingCase& c) {
  EncodingEntry e{c, nullptr};
  {
    const Field field = syntheticField(encodingCaseOptions(base, c));
    e.samples = sampleCount(field);
    e.bytesPerSample = field.bytesPerSample();
    e.buffers = fieldBufferBytes(field, e.samples);
    auto uploaded = harness::uploadField(context, field, /*volumeInDecompression=*/true);
    if (!uploaded) return makeError(uploaded.error().code, std::string(c.name) + ": " + uploaded.error().message);
    e.object = std::move(uploaded).value();
  }
  context.releaseDeferred();  // the upload's staging buffers
  if (auto prepared = decompressor.prepare(*e.object); !prepared)
    return makeError(prepared.error().code, std::string(c.name) + ": " + prepared.error().message);
  e.objectBytes = e.object->gpuMemoryBytes();
  return e;
}

// The comparison as a Markdown table, a row per field, after the lines that say what it shows.
void printEncodingTable(harness::Harness& h, const SyntheticOptions& base, const std::array<float, 3>& eye,
                        uint32_t reps, const std::vector<EncodingEntry>& entries, const std::vector<Timing>& t) {
  std::printf("device: %s\n", h.deviceName().c_str());
  std::printf("synthetic fields: %ux%u atlas, %llu samples each; eye (%.1f, %.1f, %.1f)\n", base.width, base.height,
              static_cast<unsigned long long>(entries[0].samples), double(eye[0]), double(eye[1]), double(eye[2]));
  std::printf("median of %u repetitions taking turns; GPU timestamps around Decompressor::record; ratio: median over "
              "repetitions of ms / ms of %s in the same repetition\n",
              reps, entries[0].c.name);
  std::printf("memory: buffers as laid out (KiB); object: Object::gpuMemoryBytes() (MiB, with frames, texel indices, "
              "distortion image, mesh)\n\n");
  std::printf("| field | q | c | coefficient bytes/sample | GPU ms | ratio | CPU ms | coefficients KiB | scale/bias KiB | basis KiB "
              "| object MiB |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (size_t k = 0; k < entries.size(); ++k) {
    const EncodingEntry& e = entries[k];
    std::vector<double> ratios;
    for (size_t r = 0; r < t[k].rounds.size() && r < t[0].rounds.size(); ++r)
      if (t[0].rounds[r] > 0.0) ratios.push_back(t[k].rounds[r] / t[0].rounds[r]);
    char basis[32] = "-";  // the placeholder vec4 of a field without a basis is not shown
    if (e.c.encoding == Encoding::Pca || e.c.encoding == Encoding::Volume) std::snprintf(basis, sizeof(basis), "%.1f", double(e.buffers.basis) / 1024.0);
    std::printf("| %-26s | %-3s | %u | %3u | %9.3f | %6.2f | %9.3f | %9.1f | %7.2f | %8s | %7.2f |\n", e.c.name,
                toString(e.c.quantization), e.c.channels, e.bytesPerSample, t[k].ms, median(ratios), t[k].cpuMs,
                double(e.buffers.coefficients) / 1024.0, double(e.buffers.scaleBias) / 1024.0, basis,
                double(e.objectBytes) / 1048576.0);
  }
}

int runEncodings(const Options& options, harness::Harness& h, Context& context, GpuTimer& timer) {
  auto decompressor = Decompressor::create(context);
  if (!decompressor) {
    std::fprintf(stderr, "%s\n", decompressor.error().message.c_str());
    return 1;
  }
  decompressor.value()->setSkipUnchanged(false);  // every repetition does the whole work

  SyntheticOptions base = options.synthetic;
  if (!options.sizeGiven) base.width = base.height = 233;
  base.sampleFraction = 1.0f;
  std::vector<EncodingEntry> entries;
  // One field at a time: the CPU copy (and its float coefficients) is dropped after the upload.
  for (const EncodingCase& c : kEncodingCases) {
    auto entry = uploadEncodingCase(context, *decompressor.value(), base, c);
    if (!entry) {
      std::fprintf(stderr, "%s\n", entry.error().message.c_str());
      return 1;
    }
    entries.push_back(std::move(entry).value());
  }

  bool failed = false;
  const std::array<float, 3> eye{0.3f, 0.2f, 2.0f};
  std::vector<std::function<void(VkCommandBuffer)>> recorders;
  for (EncodingEntry& e : entries)
    recorders.push_back([&, object = e.object.get()](VkCommandBuffer cmd) {
      auto r = decompressor.value()->record(cmd, eye, {object});
      if (!r || decompressor.value()->lastStats().decompressed != 1) failed = true;
    });
  const std::vector<Timing> t = timeTurns(h, timer, options.reps, recorders, failed);
  if (failed) {
    std::fprintf(stderr, "a decompression could not be recorded\n");
    return 1;
  }
  printEncodingTable(h, base, eye, options.reps, entries, t);
  entries.clear();
  decompressor.value().reset();
  if (const uint32_t messages = h.messageCount(); messages) {
    std::fprintf(stderr, "%u Vulkan validation message(s)\n", messages);
    return 1;
  }
  return 0;
}

// The report: the decompression's rate and the copies', and its ratio to the fastest reference.
void printCopyComparison(harness::Harness& h, const Options& options, const Field& field, uint64_t samples,
                         uint64_t decompressBytes, const Timing& decompression, const std::array<Copy, 4>& copies) {
  const double decompressRate = rate(decompressBytes, decompression.ms);
  const double decompressCpuRate = rate(decompressBytes, decompression.cpuMs);
  double bestRate = 0.0, bestCpuRate = 0.0;
  const Copy* best = nullptr;
  for (const Copy& c : copies) {
    if (!c.reference) continue;
    if (rate(c.bytes, c.ms) > bestRate) {
      bestRate = rate(c.bytes, c.ms);
      best = &c;
    }
    bestCpuRate = std::max(bestCpuRate, rate(c.bytes, c.cpuMs));
  }
  const double ratio = bestRate > 0.0 ? decompressRate / bestRate : 0.0;
  const uint32_t componentBytes = field.coefficientValueBytes();
  std::printf("device: %s\n", h.deviceName().c_str());
  // encodingLabel: a Table or Pca field has no SH order ("order 0" said nothing of its 324 layers).
  std::printf("field: %s, %ux%u atlas, %llu samples, %s (%u layers), %u channels, %s\n",
              options.field.empty() ? "synthetic" : options.field.c_str(), field.width, field.height,
              static_cast<unsigned long long>(samples), encodingLabel(field).c_str(), field.layerCount(),
              field.channels, toString(field.quantization));
  std::printf("coefficient bytes read per decompression: %.2f MiB (%u per sample and basis function)\n",
              double(decompressBytes) / 1048576.0, field.valuesPerLayer() * componentBytes);
  if (field.encoding != Encoding::Sh)
    std::printf("note: a %s field; the bytes above are all it stores, of which a decompression reads less (a Table "
                "sample 4 nodes); --encodings compares the encodings\n",
                toString(field.encoding));
  std::printf("median of %u repetitions taking turns; GPU timestamps (and process CPU time):\n", options.reps);
  std::printf("  %-64s %8.3f ms %7.3f GB/s  (CPU %8.3f ms)\n", "decompression pass", decompression.ms, decompressRate,
              decompression.cpuMs);
  for (const Copy& c : copies)
    std::printf("  %-64s %8.3f ms %7.3f GB/s  (CPU %8.3f ms)%s\n", c.name, c.ms, rate(c.bytes, c.ms), c.cpuMs,
                c.reference ? "" : "  [not a reference: other bytes]");
  std::printf("ratio decompression / fastest copy of the same bytes (%s): %.2f (target >= 0.50: %s)\n",
              best ? best->name : "-", ratio, ratio >= 0.5 ? "met" : "NOT met");
  std::printf("ratio by process CPU time: %.2f\n", bestCpuRate > 0.0 ? decompressCpuRate / bestCpuRate : 0.0);
}

// The decompression against copies of as many bytes, taking turns (see the top). The object and
// the decompressor are released once timed; validation messages fail the run. Exit code.
int compareWithCopies(harness::Harness& h, GpuTimer& timer, const Options& options, const Field& field,
                      std::unique_ptr<Object>& object, std::unique_ptr<Decompressor>& decompressor,
                      const std::function<void(VkCommandBuffer)>& recordDecompression, bool& failed) {
  const uint64_t samples = sampleCount(field);
  // What the decompression reads: the sample texels' coefficients, the field's channels only.
  const uint64_t decompressBytes = samples * field.bytesPerSample();
  Resources r(h);
  const uint64_t copyWords = (decompressBytes + 15) / 16 * 4;
  const std::vector<uint8_t> rgba = rgbaCoefficients(field);
  CopyTargets targets;
  bool ok = createCopyTargets(r, field, copyWords, rgba.size(), targets);
  std::array<Copy, 4> copies{{{"copy, storage buffer -> storage buffer, 1 word/invocation"},
                              {"copy, texel buffer -> storage texel buffer, 1 word/invocation"},
                              {"copy, texel buffer -> storage texel buffer, 4 words/invocation"},
                              {"copy, RGBA 2D-array image (previous layout), texelFetch"}}};
  ok = ok && createCopies(r, copies);
  auto staging = h.createHostBuffer(std::max<VkDeviceSize>(rgba.size(), copyWords * 4), VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
  if (!ok || !staging) {
    std::fprintf(stderr, "cannot set up the copy shaders\n");
    if (staging) h.destroyBuffer(staging.value());
    return 1;
  }
  if (auto uploaded = uploadCopySources(h, staging.value(), rgba, targets, field, copyWords); !uploaded) {
    std::fprintf(stderr, "%s\n", uploaded.error().message.c_str());
    return 1;
  }
  bindCopies(h, field, targets, copyWords, rgba.size(), copies);

  std::vector<std::function<void(VkCommandBuffer)>> recorders{recordDecompression};
  for (const Copy& c : copies) recorders.push_back(copyRecorder(field, c));
  const std::vector<Timing> t = timeTurns(h, timer, options.reps, recorders, failed);
  object.reset();
  decompressor.reset();
  if (failed) return 1;
  for (size_t k = 0; k < copies.size(); ++k) {
    copies[k].ms = t[k + 1].ms;
    copies[k].cpuMs = t[k + 1].cpuMs;
  }
  printCopyComparison(h, options, field, samples, decompressBytes, t[0], copies);
  if (const uint32_t messages = h.messageCount(); messages) {
    std::fprintf(stderr, "%u Vulkan validation message(s)\n", messages);
    return 1;
  }
  return 0;
}

// The field of FIELD.shrf, or the synthetic one without it. An exit code when the run ends here.
std::optional<int> loadField(const Options& options, Field& field) {
  if (options.field.empty()) {
    field = syntheticField(options.synthetic);
    return std::nullopt;
  }
  auto read = benchmarkField(options.field);
  if (const int* exitCode = std::get_if<int>(&read)) return *exitCode;
  field = std::get<Field>(std::move(read));
  return std::nullopt;
}

int runField(const Options& options, const Field& field, harness::Harness& h, Context& context, GpuTimer& timer) {

  auto uploaded = harness::uploadField(context, field, /*volumeInDecompression=*/true);
  if (!uploaded) {
    std::fprintf(stderr, "%s\n", uploaded.error().message.c_str());
    return 1;
  }
  std::unique_ptr<Object> object = std::move(uploaded).value();
  auto decompressor = Decompressor::create(context);
  if (!decompressor || !decompressor.value()->prepare(*object)) {
    std::fprintf(stderr, "cannot create the decompression pipeline\n");
    return 1;
  }
  decompressor.value()->setSkipUnchanged(false);  // every repetition does the whole work

  bool failed = false;
  const std::array<float, 3> eye{0.3f, 0.2f, 2.0f};
  auto recordDecompression = [&](VkCommandBuffer cmd) {
    if (auto r = decompressor.value()->record(cmd, eye, {object.get()}); !r) failed = true;
  };
  // A Volume field reads no coefficients (it traces its grid), so there are no bytes to copy
  // beside it: its decompression is timed alone.
  const bool volume = field.encoding == Encoding::Volume;
  if (options.profile || volume) {
    const std::vector<Timing> t = timeTurns(h, timer, options.reps, {recordDecompression}, failed);
    if (!failed)
      std::printf("%sdecompression alone: %.3f ms GPU (fastest %.3f), %.3f ms process CPU (median of %u)\n",
                  volume ? "volume field (no coefficients to copy beside it): " : "", t[0].ms, t[0].fastestMs,
                  t[0].cpuMs, options.reps);
    return failed ? 1 : 0;
  }
  return compareWithCopies(h, timer, options, field, object, decompressor.value(), recordDecompression, failed);
}

// The device and a timer of two marks, then --encodings or the field (FIELD.shrf, loaded first:
// a missing file skips before any device is touched, or the synthetic one).
int run(const Options& options) {
  Field field;
  if (!options.encodings)
    if (const std::optional<int> exitCode = loadField(options, field)) return *exitCode;
  bool noDevice = false;
  std::unique_ptr<Gpu> gpu = createGpu(options.validation, &noDevice);
  if (!gpu) return noDevice ? 0 : 1;
  GpuTimer timer(*gpu->harness, 2);
  if (!timer.available()) {
    std::printf("SKIPPED: the queue has no timestamps\n");
    return 0;
  }
  return options.encodings ? runEncodings(options, *gpu->harness, *gpu->context, timer)
                           : runField(options, field, *gpu->harness, *gpu->context, timer);
}

// The options from the command line, or the exit code to stop with.
std::optional<int> parseArguments(int argc, char** argv, Options& options) {
  const std::vector<cli::FlagSpec> flags = {
      {"size", true, "synthetic atlas", cli::ValueKind::Size, {1, 8192}, {1, 8192}},
      {"order", true, "synthetic SH order", cli::ValueKind::Integer, {0, 16}},
      {"quant", true, "u8 or f16"},
      {"channels", true, "3 or 4", cli::ValueKind::Integer, {3, 4}},
      {"reps", true, "repetitions", cli::ValueKind::Integer, {1, 1000}},
      {"profile", false, "the decompression alone"},
      {"encodings", false, "compare the encodings"},
  };
  auto parsed = parseCommandLine("shrefract_decompression_benchmark", argc, argv, flags,
                                 [](const char* error) { usage(error); });
  if (const int* exitCode = std::get_if<int>(&parsed)) return *exitCode;
  const cli::Args& args = std::get<cli::Args>(parsed);
  options.sizeGiven = args.read("size", options.synthetic.width, options.synthetic.height);
  args.read("order", options.synthetic.order);
  args.read("channels", options.synthetic.channels);
  args.read("reps", options.reps);
  if (std::string q; args.read("quant", q) && !parseQuantization(q, options.synthetic.quantization))
    return usage("--quant expects u8 or f16");
  options.validation = args.has("validation");
  options.profile = args.has("profile");
  options.encodings = args.has("encodings");
  if (args.positional().size() > 1) return usage(("unknown argument " + args.positional()[1]).c_str());
  if (!args.positional().empty()) options.field = args.positional()[0];
  if (options.encodings && (!options.field.empty() || options.profile))
    return usage("--encodings takes no FIELD.shrf and no --profile");
  return std::nullopt;
}

}  // namespace
}  // namespace shrefract::bench

int main(int argc, char** argv) {
  return shrefract::bench::benchmarkMain(argc, argv, shrefract::bench::parseArguments, shrefract::bench::run);
}
