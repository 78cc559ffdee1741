// The helpers of field_test_support.h.
#include "field/field_test_support.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>

namespace shrefract::fieldtest {

uint32_t referenceCrc32(const uint8_t* data, size_t size) {
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) {
    c ^= data[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return ~c;
}

uint32_t getU32(const std::vector<uint8_t>& b, size_t at) {
  return static_cast<uint32_t>(b[at]) | (static_cast<uint32_t>(b[at + 1]) << 8) |
         (static_cast<uint32_t>(b[at + 2]) << 16) | (static_cast<uint32_t>(b[at + 3]) << 24);
}

uint64_t getU64(const std::vector<uint8_t>& b, size_t at) {
  return static_cast<uint64_t>(getU32(b, at)) | (static_cast<uint64_t>(getU32(b, at + 4)) << 32);
}

void putU32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
  for (size_t k = 0; k < 4; ++k) b[at + k] = static_cast<uint8_t>(v >> (8 * k));
}

void putU64(std::vector<uint8_t>& b, size_t at, uint64_t v) {
  for (size_t k = 0; k < 8; ++k) b[at + k] = static_cast<uint8_t>(v >> (8 * k));
}

void resign(std::vector<uint8_t>& b) { putU32(b, b.size() - 4, referenceCrc32(b.data(), b.size() - 4)); }

size_t sectionPayload(const std::vector<uint8_t>& b, const char* tag) {
  size_t pos = 40;
  while (pos + 12 <= b.size() - 4) {
    const uint64_t length = getU64(b, pos + 4);
    if (std::memcmp(&b[pos], tag, 4) == 0) return pos + 12;
    pos += 12 + static_cast<size_t>(length);
  }
  ADD_FAILURE() << "section " << tag << " not found";
  return 0;
}

std::vector<float> syntheticCoefficients(uint32_t channels) {
  const size_t texels = kWidth * kHeight;
  std::vector<float> v(kLayers * texels * channels);
  uint32_t state = 12345u;
  for (float& x : v) {
    state = state * 1664525u + 1013904223u;
    x = static_cast<float>(state >> 8) / static_cast<float>(1u << 24) - 0.5f;  // [-0.5, 0.5)
  }
  for (size_t t = 0; t < texels; ++t) v[t * channels + 1] = kConstantLayer0Channel1;
  return v;
}

Field makeField(Variant variant) {
  Field f;
  f.width = kWidth;
  f.height = kHeight;
  f.order = kOrder;
  f.channels = variant.channels;
  f.quantization = variant.quantization;

  const uint32_t texels = kWidth * kHeight;
  f.texelKinds.assign(texels, kTexelSample);
  f.frames.assign(texels * 12, 0.0f);
  f.texelKinds[7] = kTexelEmpty;
  f.texelKinds[15] = kTexelEmpty;
  for (uint32_t g : {14u, 23u, 31u}) f.texelKinds[g] = kTexelGutter;
  f.gutters = {{14, 12, 13, 5}, {23, 20, 21, 22}, {31, 28, 29, 30}};
  for (uint32_t t = 0; t < texels; ++t) {
    if (f.texelKinds[t] != kTexelSample) continue;
    const float x = static_cast<float>(t % kWidth), y = static_cast<float>(t / kWidth);
    const std::array<float, 12> rows{1.0f, 0.0f, 0.0f, -x, 0.0f, 0.6f, 0.8f, -y, 0.0f, -0.8f, 0.6f, 0.1f * x};
    std::copy(rows.begin(), rows.end(), f.frames.begin() + t * 12);
  }

  f.mesh.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0.5f};
  f.mesh.normals = {0, 0, 1, 0, 0, 1, 0, 0.6f, 0.8f, 0, 0, -1};
  f.mesh.uvs = {0.0f, 0.0f, 1.0f, 0.0f, 1.0f, 1.0f, 0.0625f, 0.875f};
  f.mesh.frontIor = {1.5f, 1.5f, 1.0f / 1.5f, 1.33f};
  f.mesh.indices = {0, 1, 2, 0, 2, 3};

  f.media.push_back({"air", 1.0f, 0.0f, {1.0f, 1.0f, 1.0f}});
  f.media.push_back({"glass \xC3\xA9", 1.5f, variant.channels == 4 ? 0.3f : 0.0f, {0.9f, 0.95f, 1.0f}});

  BakeRecord& s = f.settings;
  s.source = "builtin:test";
  s.order = kOrder;
  s.directionsTheta = 8;
  s.directionsPhi = 16;
  s.layout = SampleLayout::Split;
  s.sampleBudget = 123456789012ull;
  s.samplesPerUnitArea = 12.5f;
  s.maxBounces = 16;
  s.window = SmoothingWindow::Hann;
  s.spatialNeighbours = 3;
  s.quantization = variant.quantization;
  s.regularization = 1e-3f;
  s.threads = 7;

  BakeStatistics& t = f.statistics;
  t.samples = 27;
  t.uniqueSamples = 20;
  t.directions = 128;
  t.paths = 3456;
  t.rays = 99999;
  t.trappedPaths = 3;
  t.bakeSeconds = 0.1;
  t.traceSeconds = 5e-324;  // subnormal: must survive bit for bit
  t.fitSeconds = 1e300;
  t.raysPerSecond = 12345.678901234567;
  t.peakMemoryBytes = 1ull << 40;
  t.fitRmsDegrees = 0.1f;
  t.fitMaxDegrees = 1e-40f;  // subnormal float
  t.heldOutRmsDegrees = 2.5f;
  t.heldOutMaxDegrees = 7.25f;
  t.quantizationRmsDegrees = -0.0f;
  t.quantizationMaxDegrees = 3.0e38f;

  const Result<void> encoded = encodeCoefficients(f, syntheticCoefficients(variant.channels));
  EXPECT_TRUE(encoded.ok()) << encoded.error().message;
  return f;
}

std::vector<uint32_t> bits(const std::vector<float>& v) {
  std::vector<uint32_t> out(v.size());
  for (size_t i = 0; i < v.size(); ++i) out[i] = std::bit_cast<uint32_t>(v[i]);
  return out;
}

uint32_t bits(float v) { return std::bit_cast<uint32_t>(v); }

uint64_t bits(double v) { return std::bit_cast<uint64_t>(v); }

void expectSameField(const Field& a, const Field& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.order, b.order);
  EXPECT_EQ(a.channels, b.channels);
  EXPECT_EQ(a.quantization, b.quantization);
  EXPECT_EQ(a.coefficientsU8, b.coefficientsU8);
  EXPECT_EQ(a.coefficientsF16, b.coefficientsF16);
  EXPECT_EQ(bits(a.scale), bits(b.scale));
  EXPECT_EQ(bits(a.bias), bits(b.bias));
  EXPECT_EQ(bits(a.frames), bits(b.frames));
  EXPECT_EQ(a.texelKinds, b.texelKinds);
  ASSERT_EQ(a.gutters.size(), b.gutters.size());
  for (size_t i = 0; i < a.gutters.size(); ++i) {
    EXPECT_EQ(a.gutters[i].target, b.gutters[i].target);
    EXPECT_EQ(a.gutters[i].a, b.gutters[i].a);
    EXPECT_EQ(a.gutters[i].b, b.gutters[i].b);
    EXPECT_EQ(a.gutters[i].c, b.gutters[i].c);
  }
  EXPECT_EQ(bits(a.mesh.positions), bits(b.mesh.positions));
  EXPECT_EQ(bits(a.mesh.normals), bits(b.mesh.normals));
  EXPECT_EQ(bits(a.mesh.uvs), bits(b.mesh.uvs));
  EXPECT_EQ(bits(a.mesh.frontIor), bits(b.mesh.frontIor));
  EXPECT_EQ(a.mesh.indices, b.mesh.indices);
  ASSERT_EQ(a.media.size(), b.media.size());
  for (size_t i = 0; i < a.media.size(); ++i) {
    EXPECT_EQ(a.media[i].name, b.media[i].name);
    EXPECT_EQ(bits(a.media[i].ior), bits(b.media[i].ior));
    EXPECT_EQ(bits(a.media[i].absorption), bits(b.media[i].absorption));
    for (size_t k = 0; k < 3; ++k) EXPECT_EQ(bits(a.media[i].color[k]), bits(b.media[i].color[k]));
  }
  const BakeRecord &s = a.settings, &u = b.settings;
  EXPECT_EQ(s.source, u.source);
  EXPECT_EQ(s.order, u.order);
  EXPECT_EQ(s.directionsTheta, u.directionsTheta);
  EXPECT_EQ(s.directionsPhi, u.directionsPhi);
  EXPECT_EQ(s.layout, u.layout);
  EXPECT_EQ(s.sampleBudget, u.sampleBudget);
  EXPECT_EQ(bits(s.samplesPerUnitArea), bits(u.samplesPerUnitArea));
  EXPECT_EQ(s.maxBounces, u.maxBounces);
  EXPECT_EQ(s.window, u.window);
  EXPECT_EQ(s.spatialNeighbours, u.spatialNeighbours);
  EXPECT_EQ(s.quantization, u.quantization);
  EXPECT_EQ(bits(s.regularization), bits(u.regularization));
  EXPECT_EQ(s.shFit, u.shFit);
  EXPECT_EQ(s.threads, u.threads);
  const BakeStatistics &t = a.statistics, &v = b.statistics;
  EXPECT_EQ(t.samples, v.samples);
  EXPECT_EQ(t.uniqueSamples, v.uniqueSamples);
  EXPECT_EQ(t.directions, v.directions);
  EXPECT_EQ(t.paths, v.paths);
  EXPECT_EQ(t.rays, v.rays);
  EXPECT_EQ(t.trappedPaths, v.trappedPaths);
  EXPECT_EQ(bits(t.bakeSeconds), bits(v.bakeSeconds));
  EXPECT_EQ(bits(t.traceSeconds), bits(v.traceSeconds));
  EXPECT_EQ(bits(t.fitSeconds), bits(v.fitSeconds));
  EXPECT_EQ(bits(t.raysPerSecond), bits(v.raysPerSecond));
  EXPECT_EQ(t.peakMemoryBytes, v.peakMemoryBytes);
  EXPECT_EQ(bits(t.fitRmsDegrees), bits(v.fitRmsDegrees));
  EXPECT_EQ(bits(t.fitMaxDegrees), bits(v.fitMaxDegrees));
  EXPECT_EQ(bits(t.heldOutRmsDegrees), bits(v.heldOutRmsDegrees));
  EXPECT_EQ(bits(t.heldOutMaxDegrees), bits(v.heldOutMaxDegrees));
  EXPECT_EQ(bits(t.quantizationRmsDegrees), bits(v.quantizationRmsDegrees));
  EXPECT_EQ(bits(t.quantizationMaxDegrees), bits(v.quantizationMaxDegrees));
}

Result<Field> parse(const std::vector<uint8_t>& bytes, const std::string& name) {
  return parseField(bytes.data(), bytes.size(), name);
}

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

Field makeEncodedField(Encoding encoding, Quantization q, bool throughput, bool jumpDistance, bool sampleFrameExits,
                       bool clustered) {
  Field f = makeField({4, q});
  f.encoding = f.settings.encoding = encoding;
  f.order = f.settings.order = 0;
  f.tableSize = f.settings.tableSize = jumpDistance ? 12 : 3;
  f.components = f.settings.components = encoding == Encoding::Pca ? 5 : 0;
  f.throughput = f.settings.throughput = throughput;
  f.jumpDistance = f.settings.jumpDistance = jumpDistance;
  f.sampleFrameExits = sampleFrameExits;
  f.settings.exitFrame = sampleFrameExits ? ExitFrame::Sample : ExitFrame::Object;
  f.channels = (throughput ? 5 : 4) + (jumpDistance ? 1 : 0);
  f.settings.pathRule = PathRule::FirstRefraction;
  f.settings.maxBytesPerSample = 324.0f;
  f.settings.directionSampling = DirectionSampling::Nodes;
  if (encoding == Encoding::Pca) {
    f.basis.resize(size_t(f.components) * f.tableSize * f.tableSize * f.channels);
    for (size_t i = 0; i < f.basis.size(); ++i) f.basis[i] = std::sin(0.37f * float(i));
  }
  f.clustered = clustered;
  f.settings.clusters = encoding == Encoding::Pca ? 7 : 0;
  std::vector<float> c(size_t(f.layerCount()) * f.texelCount() * f.valuesPerLayer());
  for (size_t i = 0; i < c.size(); ++i)
    c[i] = !clustered ? std::cos(0.11f * float(i)) * 0.5f + 0.5f
                      : f.texelKinds[i] == kTexelSample ? float(i * 7 % f.components) : 0.0f;  // one index a texel
  const Result<void> encoded = encodeCoefficients(f, c);
  EXPECT_TRUE(encoded.ok()) << encoded.error().message;
  return f;
}

std::vector<uint32_t> volumeFieldVoxels() {
  const uint32_t n = kVolumeFieldSize;
  std::vector<uint32_t> dense;
  for (uint32_t i = 0; i < n * n * n; ++i) {
    const uint32_t x = i % n, y = (i / n) % n;
    dense.push_back(x >= 8   ? volumeFarWord(false)
                    : y >= 8 ? volumeFarWord(true)
                             : packVolumeVoxel(4.0f * std::sin(0.7f * float(i)),
                                               {std::cos(0.3f * float(i)), std::sin(0.3f * float(i)), 0.5f}));
  }
  return dense;
}

Field makeVolumeField(Quantization q, bool throughput) {
  Field f = makeField({4, q});
  f.encoding = f.settings.encoding = Encoding::Volume;
  f.order = f.settings.order = 0;
  f.throughput = f.settings.throughput = throughput;
  f.channels = throughput ? 5 : 4;
  f.coefficientsU8.clear();
  f.coefficientsF16.clear();
  f.scale.clear();
  f.bias.clear();
  f.settings.pathRule = PathRule::FirstRefraction;
  f.settings.tryVolume = q == Quantization::F16;  // chosen by a default bake, or asked for
  FieldVolume& v = f.volume;
  v.size = f.settings.volumeSize = kVolumeFieldSize;
  v.origin = {-1.25f, -0.5f, 0.75f};
  v.spacing = 0.375f;
  setVolumeVoxels(v, volumeFieldVoxels());
  return f;
}

std::vector<uint8_t> withShorterEncoding(const Field& f, uint64_t bytes, uint32_t version) {
  std::vector<uint8_t> b = serializeField(f);
  const size_t encd = sectionPayload(b, "ENCD");
  const uint64_t encdLength = getU64(b, encd - 8);
  b.erase(b.begin() + static_cast<std::ptrdiff_t>(encd + encdLength - bytes),
          b.begin() + static_cast<std::ptrdiff_t>(encd + encdLength));
  putU64(b, encd - 8, encdLength - bytes);
  putU32(b, 4, version);
  putU64(b, 8, b.size());
  resign(b);
  return b;
}

}  // namespace shrefract::fieldtest
