// Writes the seed corpus of the fuzz targets: small valid field files in the current format (the
// synthetic band of the engine tests: U8 and F16, 3 and 4 channels, empty and gutter texels) and
// small glTF files (two nested tetrahedra, glass around an air bubble, with KHR material
// extensions, u16 and u8 indices and a child node with a transform; as .gltf with a data URI and
// as .glb). The fuzz test runs it before each run, so the seeds follow the format;
// tests/fuzz/corpus holds its output at the time of the last commit (field files as .bin: *.shrf is
// git-ignored) and inputs that once found a bug (regression-*).
//
// usage: fuzz_seeds FIELD_DIR GLTF_DIR
#include <shrefract/field.h>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "engine/synthetic_field.h"

namespace {

bool write(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
  return bool(out);
}

std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t b0 = uint8_t(bytes[i]);
    const uint32_t b1 = i + 1 < bytes.size() ? uint8_t(bytes[i + 1]) : 0u;
    const uint32_t b2 = i + 2 < bytes.size() ? uint8_t(bytes[i + 2]) : 0u;
    const uint32_t t = (b0 << 16) | (b1 << 8) | b2;
    out += k[(t >> 18) & 63u];
    out += k[(t >> 12) & 63u];
    out += i + 1 < bytes.size() ? k[(t >> 6) & 63u] : '=';
    out += i + 2 < bytes.size() ? k[t & 63u] : '=';
  }
  return out;
}

template <typename T>
std::string raw(const std::vector<T>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

// Tetrahedron positions (outward counter-clockwise) scaled and moved.
std::vector<float> tetra(float s, float dx) {
  const float p[12] = {1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1};
  std::vector<float> out(12);
  for (int i = 0; i < 12; ++i) out[size_t(i)] = s * p[i] + (i % 3 == 0 ? dx : 0.0f);
  return out;
}
const std::vector<uint16_t> kTetraIndices = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};

// One buffer: positions of two tetrahedra, then u16 indices, then u8 indices.
std::string gltfJson(bool dataUri, size_t* binSize, std::string* binOut) {
  std::string bin = raw(tetra(1.0f, 0.0f)) + raw(tetra(0.3f, 0.1f));
  const size_t idx16 = bin.size();
  bin += raw(kTetraIndices);
  const size_t idx8 = bin.size();
  for (uint16_t i : kTetraIndices) bin.push_back(char(i));
  while (bin.size() % 4) bin.push_back('\0');
  *binSize = bin.size();
  *binOut = bin;
  const std::string buffer = dataUri ? "{\"byteLength\": " + std::to_string(bin.size()) +
                                           ", \"uri\": \"data:application/octet-stream;base64," + base64(bin) + "\"}"
                                     : "{\"byteLength\": " + std::to_string(bin.size()) + "}";
  return std::string("{\"asset\": {\"version\": \"2.0\"},\n") +
         "\"extensionsUsed\": [\"KHR_materials_ior\", \"KHR_materials_volume\", \"KHR_materials_transmission\"],\n"
         "\"buffers\": [" + buffer + "],\n"
         "\"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 96},\n"
         "  {\"buffer\": 0, \"byteOffset\": " + std::to_string(idx16) + ", \"byteLength\": 24},\n"
         "  {\"buffer\": 0, \"byteOffset\": " + std::to_string(idx8) + ", \"byteLength\": 12}],\n"
         "\"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\"},\n"
         "  {\"bufferView\": 0, \"byteOffset\": 48, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\"},\n"
         "  {\"bufferView\": 1, \"componentType\": 5123, \"count\": 12, \"type\": \"SCALAR\"},\n"
         "  {\"bufferView\": 2, \"componentType\": 5121, \"count\": 12, \"type\": \"SCALAR\"}],\n"
         "\"materials\": [{\"name\": \"glass\", \"extensions\": {\"KHR_materials_ior\": {\"ior\": 1.5},\n"
         "    \"KHR_materials_transmission\": {\"transmissionFactor\": 1},\n"
         "    \"KHR_materials_volume\": {\"thicknessFactor\": 1, \"attenuationDistance\": 2,\n"
         "      \"attenuationColor\": [0.9, 0.8, 0.7]}}},\n"
         "  {\"name\": \"bubble\", \"extensions\": {\"KHR_materials_ior\": {\"ior\": 1.0}}}],\n"
         "\"meshes\": [{\"name\": \"outer\", \"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 2, "
         "\"material\": 0}]},\n"
         "  {\"name\": \"inner\", \"primitives\": [{\"attributes\": {\"POSITION\": 1}, \"indices\": 3, "
         "\"material\": 1, \"mode\": 4}]}],\n"
         "\"nodes\": [{\"name\": \"a\", \"mesh\": 0, \"children\": [1]},\n"
         "  {\"name\": \"b\", \"mesh\": 1, \"translation\": [0.05, 0, 0], \"scale\": [1, 1, 1]}],\n"
         "\"scenes\": [{\"nodes\": [0]}], \"scene\": 0}\n";
}

std::string glb(const std::string& jsonText, const std::string& bin) {
  std::string text = jsonText;
  while (text.size() % 4) text.push_back(' ');
  auto u32 = [](uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  std::string out = "glTF" + u32(2) + u32(uint32_t(12 + 8 + text.size() + 8 + bin.size()));
  out += u32(uint32_t(text.size())) + "JSON" + text;
  out += u32(uint32_t(bin.size())) + std::string("BIN\0", 4) + bin;
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: fuzz_seeds FIELD_DIR GLTF_DIR\n");
    return 2;
  }
  const std::string fieldDir = argv[1], gltfDir = argv[2];
  bool ok = true;
  int n = 0;
  for (auto q : {shrefract::Quantization::U8, shrefract::Quantization::F16})
    for (uint32_t channels : {3u, 4u})
      for (bool gutters : {false, true}) {
        shrefract::testing::SyntheticFieldOptions o;
        o.width = gutters ? 4 : 2;
        o.height = gutters ? 3 : 1;
        o.order = gutters ? 1 : 0;
        o.channels = channels;
        o.quantization = q;
        o.emptyAndGutters = gutters;
        o.meshSegments = 2;
        const std::vector<uint8_t> bytes = shrefract::serializeField(shrefract::testing::makeSyntheticField(o));
        ok = write(fieldDir + "/field" + std::to_string(n++) + ".bin", std::string(bytes.begin(), bytes.end())) && ok;
      }
  // The Table and Pca encodings: a small field each, the Pca one with the throughput channel.
  for (auto encoding : {shrefract::Encoding::Table, shrefract::Encoding::Pca}) {
    shrefract::testing::SyntheticFieldOptions o;
    o.width = 4;
    o.height = 3;
    o.order = 0;
    o.encoding = encoding;
    o.tableSize = 3;
    o.components = 2;
    o.throughput = encoding == shrefract::Encoding::Pca;
    o.channels = o.throughput ? 5 : 4;
    o.emptyAndGutters = true;
    o.meshSegments = 2;
    const std::vector<uint8_t> bytes = shrefract::serializeField(shrefract::testing::makeSyntheticField(o));
    ok = write(fieldDir + "/field" + std::to_string(n++) + ".bin", std::string(bytes.begin(), bytes.end())) && ok;
    if (encoding != shrefract::Encoding::Pca) continue;
    // The same Pca field clustered, one index a sample.
    o.clustered = true;
    const std::vector<uint8_t> clustered = shrefract::serializeField(shrefract::testing::makeSyntheticField(o));
    ok = write(fieldDir + "/field" + std::to_string(n++) + ".bin", std::string(clustered.begin(), clustered.end())) && ok;
  }
  // A Volume field (a grid of the band's sphere, no coefficients).
  {
    shrefract::testing::SyntheticFieldOptions o;
    o.width = 4;
    o.height = 3;
    o.encoding = shrefract::Encoding::Volume;
    o.volumeSize = 8;
    o.emptyAndGutters = true;
    o.meshSegments = 2;
    shrefract::Field volume = shrefract::testing::makeSyntheticField(o);
    volume.settings.maxBounces = 4;
    const std::vector<uint8_t> bytes = shrefract::serializeField(volume);
    ok = write(fieldDir + "/field" + std::to_string(n++) + ".bin", std::string(bytes.begin(), bytes.end())) && ok;
  }
  size_t binSize = 0;
  std::string bin;
  ok = write(gltfDir + "/nested.gltf", gltfJson(true, &binSize, &bin)) && ok;
  ok = write(gltfDir + "/nested.glb", glb(gltfJson(false, &binSize, &bin), bin)) && ok;
  if (!ok) std::fprintf(stderr, "fuzz_seeds: cannot write the seeds\n");
  return ok ? 0 : 1;
}
