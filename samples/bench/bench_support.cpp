#include "bench/bench_support.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <random>

namespace shrefract::bench {

namespace {

// The field's header from the options: sizes, encoding, channels, settings and its two media.
Field syntheticHeader(const SyntheticOptions& o) {
  const bool sh = o.encoding == Encoding::Sh;
  Field f;
  f.width = o.width;
  f.height = o.height;
  f.encoding = o.encoding;
  f.order = sh ? o.order : 0;
  const bool volume = o.encoding == Encoding::Volume;
  f.tableSize = sh || volume ? 0 : o.tableSize;
  f.components = o.encoding == Encoding::Pca ? o.components : 0;
  f.channels = o.channels;
  f.throughput = o.throughput;
  f.jumpDistance = o.jumpDistance;
  f.quantization = o.quantization;
  f.clustered = o.encoding == Encoding::Pca && o.clustered;
  f.settings.order = f.order;
  f.settings.encoding = f.encoding;
  f.settings.tableSize = f.tableSize;
  f.settings.components = f.components;
  f.settings.throughput = f.throughput;
  f.settings.jumpDistance = f.jumpDistance;
  f.settings.directionSampling = sh ? DirectionSampling::Grid : o.directionSampling;
  f.settings.quantization = o.quantization;
  f.settings.source = "synthetic";
  f.media.push_back(FieldMedium{"air", 1.0f, 0.0f, {1.0f, 1.0f, 1.0f}});
  f.media.push_back(FieldMedium{"glass", 1.5f, f.hasOpticalDepth() ? 0.5f : 0.0f, {1.0f, 1.0f, 1.0f}});
  return f;
}

// The first `samples` texels are samples of a unit square in z = 0, each with the identity
// rotation and the translation that takes (x, y, 0) to its origin: w = eye - p.
void placeSamples(Field& f, uint64_t samples, uint32_t width, uint32_t height) {
  const uint64_t texels = f.texelCount();
  f.texelKinds.assign(texels, kTexelEmpty);
  f.frames.assign(texels * 12, 0.0f);
  for (uint64_t t = 0; t < samples; ++t) {
    f.texelKinds[t] = kTexelSample;
    const float x = (float(t % width) + 0.5f) / float(width) - 0.5f;
    const float y = (float(t / width) + 0.5f) / float(height) - 0.5f;
    float* m = &f.frames[t * 12];
    m[0] = 1.0f, m[3] = -x;
    m[5] = 1.0f, m[7] = -y;
    m[10] = 1.0f;
  }
}

// Volume: the grid of a glass box under the samples' square (|x|, |y| <= 1/2, -1/2 <= z <= 0),
// N = o.tableSize voxels per side: every path enters through its top, may reflect off its sides,
// and leaves through its bottom; each voxel the exact distance and its nearest face's normal.
FieldVolume boxUnderTheSquare(uint32_t n) {
  FieldVolume v;
  v.size = n;
  v.spacing = 1.0f / float(n - 5);
  v.origin = {-0.5f * float(n - 1) * v.spacing, -0.5f * float(n - 1) * v.spacing, -0.25f - 0.5f * float(n - 1) * v.spacing};
  std::vector<uint32_t> dense(size_t(n) * n * n);
  for (uint32_t z = 0; z < n; ++z)
    for (uint32_t y = 0; y < n; ++y)
      for (uint32_t x = 0; x < n; ++x) {
        const float p[3] = {v.origin[0] + v.spacing * float(x), v.origin[1] + v.spacing * float(y),
                            v.origin[2] + v.spacing * float(z) + 0.25f};  // relative to the box's centre
        const float q[3] = {std::fabs(p[0]) - 0.5f, std::fabs(p[1]) - 0.5f, std::fabs(p[2]) - 0.25f};
        float outside = 0.0f;
        for (float c : q) outside += std::max(c, 0.0f) * std::max(c, 0.0f);
        const float inside = std::min(std::max({q[0], q[1], q[2]}), 0.0f);
        const int axis = q[0] >= q[1] && q[0] >= q[2] ? 0 : q[1] >= q[2] ? 1 : 2;
        std::array<float, 3> normal{0.0f, 0.0f, 0.0f};
        normal[size_t(axis)] = p[axis] >= 0.0f ? 1.0f : -1.0f;
        dense[(size_t(z) * n + y) * n + x] = packVolumeVoxel((std::sqrt(outside) + inside) / v.spacing, normal);
      }
  setVolumeVoxels(v, dense);
  return v;
}

// Whether channel c of the field's decoded values is the throughput (the last, when it has one).
bool isThroughputChannel(const Field& f, uint32_t c) { return f.throughput && c == f.decodedChannels() - 1; }

// Pca: a random basis whose mean component points mostly along -z (never a zero sum), with
// plausible jump distances and throughputs in their channels.
void randomBasis(Field& f, const SyntheticOptions& o, std::mt19937& rng) {
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  const uint32_t decoded = f.decodedChannels();
  const size_t nodes = size_t(o.tableSize) * o.tableSize;
  f.basis.resize(size_t(o.components) * nodes * o.channels);
  for (size_t i = 0; i < f.basis.size(); ++i) {
    const size_t k = i / (nodes * o.channels), c = i % o.channels;
    f.basis[i] = 0.25f * uniform(rng);
    if (c == decoded) f.basis[i] = k == 0 ? 0.1f + 0.5f * f.basis[i] : 0.01f * f.basis[i];  // jump distance
    else if (isThroughputChannel(f, uint32_t(c))) f.basis[i] = k == 0 ? 0.5f + f.basis[i] : 0.1f * f.basis[i];
    else if (k == 0 && c == 2) f.basis[i] -= 1.0f;
  }
}

// Random coefficients for the sample texels, layer-major as encodeCoefficients takes them.
std::vector<float> randomCoefficients(const Field& f, const SyntheticOptions& o, uint64_t samples, std::mt19937& rng) {
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  const uint64_t texels = f.texelCount();
  const uint32_t layers = f.layerCount(), values = f.valuesPerLayer();
  std::vector<float> coefficients(size_t(layers) * texels * values, 0.0f);
  if (f.clustered) {
    std::uniform_int_distribution<uint32_t> index(0, f.components - 1);
    for (uint64_t t = 0; t < samples; ++t) coefficients[t] = float(index(rng));
    return coefficients;
  }
  for (uint32_t layer = 0; layer < layers; ++layer)
    for (uint64_t t = 0; t < samples; ++t)
      for (uint32_t v = 0; v < values; ++v) {
        float x = uniform(rng);
        if (o.encoding == Encoding::Pca) x += layer == 0 ? 4.0f : 0.0f;  // the mean component
        else if (isThroughputChannel(f, v)) x = 0.5f + 0.5f * x;
        else if (v == 2 && (layer == 0 || o.encoding == Encoding::Table)) x -= 4.0f;  // mostly -z: never a zero sum
        coefficients[(size_t(layer) * texels + t) * values + v] = x;
      }
  return coefficients;
}

// The unit square in z = 0, facing +z, atlas coordinates over the whole atlas.
FieldMesh unitSquareMesh() {
  FieldMesh mesh;
  mesh.positions = {-0.5f, -0.5f, 0.0f, 0.5f, -0.5f, 0.0f, 0.5f, 0.5f, 0.0f, -0.5f, 0.5f, 0.0f};
  mesh.normals = {0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 1.0f};
  mesh.uvs = {0.0f, 0.0f, 1.0f, 0.0f, 1.0f, 1.0f, 0.0f, 1.0f};
  mesh.frontIor = {1.5f, 1.5f, 1.5f, 1.5f};
  mesh.indices = {0, 1, 2, 0, 2, 3};
  return mesh;
}

}  // namespace

Field syntheticField(const SyntheticOptions& o) {
  Field f = syntheticHeader(o);
  const uint64_t texels = f.texelCount();
  const uint64_t samples =
      std::min<uint64_t>(texels, static_cast<uint64_t>(double(texels) * double(std::clamp(o.sampleFraction, 0.0f, 1.0f))));
  placeSamples(f, samples, o.width, o.height);
  std::mt19937 rng(o.seed);  // one generator: the basis's draws, then the coefficients'
  if (o.encoding == Encoding::Volume) {
    f.volume = boxUnderTheSquare(o.tableSize);
    f.settings.volumeSize = o.tableSize;
  } else {
    if (o.encoding == Encoding::Pca) randomBasis(f, o, rng);  // before the coefficients: encodeCoefficients checks its size
    (void)encodeCoefficients(f, randomCoefficients(f, o, samples, rng));
  }
  f.mesh = unitSquareMesh();
  return f;
}

bool parseQuantization(const std::string& text, Quantization& out) {
  if (text == "u8") out = Quantization::U8;
  else if (text == "f16") out = Quantization::F16;
  else return false;
  return true;
}

std::string encodingLabel(const Field& f) {
  const std::string n = std::to_string(f.tableSize);
  if (f.encoding == Encoding::Volume) {
    const std::string v = std::to_string(f.volume.size);
    return "volume " + v + "^3" + (f.throughput ? " +throughput" : "");
  }
  std::string label = f.encoding == Encoding::Sh      ? "sh L=" + std::to_string(f.order)
                      : f.encoding == Encoding::Table ? "table " + n + "x" + n
                      : f.clustered                   ? "pca clustered K=" + std::to_string(f.components) + " N=" + n
                                                      : "pca K=" + std::to_string(f.components) + " N=" + n;
  if (f.shape().jumpAware) label += " nodes";
  if (f.throughput) label += " +throughput";
  if (f.jumpDistance) label += " +jump distance";
  return label;
}

bool parseCount(const char* text, uint32_t lo, uint32_t hi, uint32_t& out) {
  if (!text || !*text) return false;
  char* end = nullptr;
  const unsigned long v = std::strtoul(text, &end, 10);
  if (*end || text[0] == '-' || v < lo || v > hi) return false;
  out = uint32_t(v);
  return true;
}

std::variant<cli::Args, int> parseCommandLine(const char* program, int argc, char** argv,
                                              const std::vector<cli::FlagSpec>& flags,
                                              const std::function<void(const char* error)>& usage) {
  std::vector<cli::FlagSpec> all = flags;
  all.push_back({"validation", false, "with the validation layer"});
  auto parsed = cli::Args::parseProgram(program, argc, argv, all);
  if (!parsed) {
    usage(parsed.error().message.c_str());
    return 2;
  }
  if (parsed.value().has("help")) {
    usage(nullptr);
    return 0;
  }
  return std::move(parsed).value();
}

std::variant<Field, int> benchmarkField(const std::string& path, const char* why) {
  if (!std::filesystem::exists(path)) {
    std::printf("SKIPPED: %s does not exist%s\n", path.c_str(), why);
    return 0;
  }
  auto read = readField(path);
  if (!read) {
    std::fprintf(stderr, "%s\n", read.error().message.c_str());
    return 1;
  }
  return std::move(read).value();
}

int usageError(const char* message, const char* usage) {
  if (message) std::fprintf(stderr, "%s\n", message);
  std::fprintf(stderr, "%s", usage);
  return 2;
}

namespace {

bool parseShading(const std::string& text, ShadingMode& out) {
  if (text == "field") out = ShadingMode::Field;
  else if (text == "exit-direction") out = ShadingMode::FieldExitDirection;
  else if (text == "single-interface") out = ShadingMode::SingleInterface;
  else return false;
  return true;
}

bool parseColorFormat(const std::string& text, VkFormat& out) {
  if (text == "rgba16f") out = VK_FORMAT_R16G16B16A16_SFLOAT;
  else if (text == "rgba8") out = VK_FORMAT_R8G8B8A8_UNORM;
  else if (text == "rgba32f") out = VK_FORMAT_R32G32B32A32_SFLOAT;
  else return false;
  return true;
}

}  // namespace

std::vector<cli::FlagSpec> withFrameFlags(std::vector<cli::FlagSpec> own) {
  own.insert(own.end(), {{"size", true, "frame size", cli::ValueKind::Size, {1, 8192}, {1, 8192}},
                         {"shading", true, "field, exit-direction or single-interface"},
                         {"format", true, "rgba16f, rgba8 or rgba32f"},
                         {"cube-env", false, "a cube map environment"}});
  return own;
}

std::optional<std::string> readShadingAndFormat(const cli::Args& args, ShadingMode& shading, VkFormat& format) {
  if (std::string v; args.read("shading", v) && !parseShading(v, shading))
    return "--shading expects field, exit-direction or single-interface";
  if (std::string v; args.read("format", v) && !parseColorFormat(v, format))
    return "--format expects rgba16f, rgba8 or rgba32f";
  return std::nullopt;
}

Gpu::~Gpu() {
  if (context) context->releaseDeferred();
  context.reset();
  harness.reset();
}

std::unique_ptr<Gpu> createGpu(bool validation, bool* noDevice) {
  harness::HarnessOptions options;
  options.enableValidation = validation;
  harness::HarnessFailure failure = harness::HarnessFailure::None;
  auto h = harness::Harness::create(options, &failure);
  if (noDevice) *noDevice = !h && failure == harness::HarnessFailure::NoDevice;
  if (!h) {
    std::fprintf(stderr, "%s%s\n", failure == harness::HarnessFailure::NoDevice ? "SKIPPED: no Vulkan device: " : "",
                 h.error().message.c_str());
    return nullptr;
  }
  auto gpu = std::make_unique<Gpu>();
  gpu->harness = std::move(h).value();
  auto context = harness::createContext(*gpu->harness);
  if (!context) {
    std::fprintf(stderr, "%s\n", context.error().message.c_str());
    return nullptr;
  }
  gpu->context = std::move(context).value();
  return gpu;
}

GpuTimer::GpuTimer(harness::Harness& h, uint32_t marks) : h_(h), marks_(marks), ticks_(marks, 0) {
  if (!h.hasTimestamps()) return;
  VkQueryPoolCreateInfo info{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  info.queryType = VK_QUERY_TYPE_TIMESTAMP;
  info.queryCount = marks;
  if (vkCreateQueryPool(h.device(), &info, nullptr, &pool_) != VK_SUCCESS) pool_ = VK_NULL_HANDLE;
}

GpuTimer::~GpuTimer() {
  if (pool_) vkDestroyQueryPool(h_.device(), pool_, nullptr);
}

void GpuTimer::begin(VkCommandBuffer cmd) {
  fetched_ = false;
  if (pool_) vkCmdResetQueryPool(cmd, pool_, 0, marks_);
}

void GpuTimer::mark(VkCommandBuffer cmd, uint32_t index) {
  if (pool_) vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, pool_, index);
}

double GpuTimer::elapsedMs(uint32_t from, uint32_t to) {
  if (!pool_) return 0.0;
  if (!fetched_) {
    if (vkGetQueryPoolResults(h_.device(), pool_, 0, marks_, ticks_.size() * sizeof(uint64_t), ticks_.data(),
                              sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT) != VK_SUCCESS)
      return 0.0;
    fetched_ = true;
  }
  return double(ticks_[to] - ticks_[from]) * double(h_.properties().limits.timestampPeriod) * 1e-6;
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double processCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

}  // namespace shrefract::bench
