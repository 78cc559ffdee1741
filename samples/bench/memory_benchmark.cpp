// Memory benchmark: device memory per sample and per object for each SH order and quantization,
// from real uploads (Object::gpuMemoryBytes(): the memory requirements of every buffer and image
// the engine creates for the object), against the paper's figure: (L+1)^2 basis functions x 4
// channels x 1 byte per sample (order 8, 8 bits: 324 bytes).
//
//   shrefract_memory_benchmark [FIELD.shrf ...] [--size WxH] [--fill F] [--validation]
//
// The table uses synthetic fields of one atlas (default 338x311 with 51% of the texels holding a
// sample: the occupancy of the bunny baked with the charts layout and 35k samples) for orders 1,
// 2, 4, 8, 12, 16, both quantizations, with and without the optical-depth channel. Each FIELD.shrf
// given adds a row for that real field. Exit code 0 with "SKIPPED:" when there is no Vulkan device.
#include <shrefract/renderer.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "bench/bench_support.h"
#include "cli/args.h"

namespace shrefract::bench {
namespace {

struct Options {
  std::vector<std::string> fields;
  SyntheticOptions synthetic{338, 311, 8, 4, Quantization::U8, 0.515f, 1};
  bool validation = false;
};

int usage(const char* message) {
  return usageError(message,
                    "usage: shrefract_memory_benchmark [FIELD.shrf ...] [--size WxH] [--fill F] [--validation]\n");
}

struct Row {
  std::string name, encoding;  // encoding: "8" for SH order 8, else bench_support's label
  uint32_t channels = 0;
  uint64_t layers = 0;            // SH functions, table nodes or Pca components per channel
  uint64_t coefficientBytes = 0;  // per sample, as uploaded (Field::bytesPerSample)
  uint64_t paper = 0;             // the paper's bytes for the same SH order; its budget, 324, otherwise
  Quantization quantization = Quantization::U8;
  uint64_t samples = 0, texels = 0, triangles = 0;
  uint64_t objectBytes = 0;
};

void printRow(const Row& r) {
  const double perSample = r.samples ? double(r.objectBytes) / double(r.samples) : 0.0;
  std::printf("| %-10s | %5s | %5llu | %-3s | %u | %9.1f | %6llu | %6llu | %5.2f | %8.2f |\n", r.name.c_str(),
              r.encoding.c_str(), static_cast<unsigned long long>(r.layers), toString(r.quantization), r.channels,
              perSample, static_cast<unsigned long long>(r.coefficientBytes), static_cast<unsigned long long>(r.paper),
              perSample / double(r.paper), double(r.objectBytes) / 1048576.0);
}

// Uploads `field` as the engine would and fills `row` with its layout and the object's device
// memory; the object is released before returning, so rows never add up on the device.
bool measure(Context& context, const Field& field, const std::string& name, Row& row) {
  auto uploaded = harness::uploadField(context, field, /*volumeInDecompression=*/true);
  if (!uploaded) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), uploaded.error().message.c_str());
    return false;
  }
  std::unique_ptr<Object> object = std::move(uploaded).value();
  row.name = name;
  const bool sh = field.encoding == Encoding::Sh;
  row.encoding = sh ? std::to_string(field.order) : encodingLabel(field);
  row.layers = field.layerCount();
  row.coefficientBytes = field.bytesPerSample();
  row.paper = sh ? uint64_t(field.layerCount()) * 4 : 324;  // (L+1)^2 x 4 channels x 8 bits
  row.channels = field.channels;
  row.quantization = field.quantization;
  row.texels = field.texelCount();
  row.triangles = field.mesh.indices.size() / 3;
  row.samples = 0;
  for (uint8_t k : field.texelKinds) row.samples += k == kTexelSample;
  row.objectBytes = object->gpuMemoryBytes();
  object.reset();
  context.releaseDeferred();
  return true;
}

void printHeader(const std::string& deviceName, const SyntheticOptions& synthetic) {
  std::printf("device: %s\n", deviceName.c_str());
  std::printf("synthetic atlas %ux%u, %.1f%% of the texels are samples; bytes per sample = all of the object's "
              "device memory / samples\n",
              synthetic.width, synthetic.height, 100.0 * double(synthetic.sampleFraction));
  std::printf("paper: (L+1)^2 x 4 channels x 1 byte per sample (order 8, 8 bits: 324 bytes); a table or pca field is "
              "set against 324\n\n");
  std::printf("| field      | order or encoding | layers | q   | c | bytes/sample | coeff/sample | paper | ratio | MiB/object |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
}

// One row per synthetic order, quantization and channel count; `paperCase` receives the row the
// paper's figure is set against (order 8, u8, 4 channels).
bool measureSynthetic(Context& context, const SyntheticOptions& synthetic, Row& paperCase) {
  for (uint32_t order : {1u, 2u, 4u, 8u, 12u, 16u})
    for (Quantization q : {Quantization::U8, Quantization::F16})
      for (uint32_t channels : {4u, 3u}) {
        SyntheticOptions o = synthetic;
        o.order = order;
        o.quantization = q;
        o.channels = channels;
        Row row;
        if (!measure(context, syntheticField(o), "synthetic", row)) return false;
        printRow(row);
        if (order == 8 && q == Quantization::U8 && channels == 4) paperCase = row;
      }
  return true;
}

// One row per FIELD.shrf given; a missing file is skipped, an unreadable one fails.
bool measureFields(Context& context, const std::vector<std::string>& fields) {
  for (const std::string& path : fields) {
    const std::variant<Field, int> field = benchmarkField(path);
    if (const int* exitCode = std::get_if<int>(&field)) {
      if (*exitCode != 0) return false;
      continue;  // skipped
    }
    Row row;
    if (!measure(context, std::get<Field>(field), std::filesystem::path(path).filename().string(), row)) return false;
    printRow(row);
    std::printf("  (%s: %llu samples in a %llu-texel atlas, %llu triangles)\n", path.c_str(),
                static_cast<unsigned long long>(row.samples), static_cast<unsigned long long>(row.texels),
                static_cast<unsigned long long>(row.triangles));
  }
  return true;
}

void printPaperComparison(const Row& paperCase) {
  const double perSample = double(paperCase.objectBytes) / double(paperCase.samples);
  std::printf("\norder 8, u8, 4 channels: %.1f bytes per sample in all, against the paper's 324 (ratio %.2f); of "
              "which coefficients 324, frame 48, texel index 4, and the distortion image and mesh the rest\n",
              perSample, perSample / 324.0);
}

int run(const Options& options) {
  bool noDevice = false;
  auto gpu = createGpu(options.validation, &noDevice);
  if (!gpu) return noDevice ? 0 : 1;
  Context& context = *gpu->context;
  printHeader(gpu->harness->deviceName(), options.synthetic);
  Row paperCase;
  if (!measureSynthetic(context, options.synthetic, paperCase)) return 1;
  if (!measureFields(context, options.fields)) return 1;
  printPaperComparison(paperCase);
  if (const uint32_t messages = gpu->harness->messageCount(); messages) {
    std::fprintf(stderr, "%u Vulkan validation message(s)\n", messages);
    return 1;
  }
  return 0;
}

// The options from the command line, or the exit code to stop with.
std::optional<int> parseArguments(int argc, char** argv, Options& options) {
  const std::vector<cli::FlagSpec> flags = {
      {"size", true, "synthetic atlas", cli::ValueKind::Size, {1, 4096}, {1, 4096}},
      {"fill", true, "fraction of texels that are samples", cli::ValueKind::Real, {0, 1, true, false}},
  };
  auto parsed = parseCommandLine("shrefract_memory_benchmark", argc, argv, flags,
                                 [](const char* error) { usage(error); });
  if (const int* exitCode = std::get_if<int>(&parsed)) return *exitCode;
  const cli::Args& args = std::get<cli::Args>(parsed);
  args.read("size", options.synthetic.width, options.synthetic.height);
  if (double fill = 0.0; args.read("fill", fill)) options.synthetic.sampleFraction = static_cast<float>(fill);
  options.validation = args.has("validation");
  options.fields = args.positional();
  return std::nullopt;
}

}  // namespace
}  // namespace shrefract::bench

int main(int argc, char** argv) {
  return shrefract::bench::benchmarkMain(argc, argv, shrefract::bench::parseArguments, shrefract::bench::run);
}
