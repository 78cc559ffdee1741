// Writing glTF files from tests: a document with one binary buffer (as a data URI or a GLB),
// cubes with analytic normals, and glass materials. Shared by the import and tool tests, so that
// no test needs files from outside the repository.
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace shrefract::gltf_test {

using nlohmann::json;

inline constexpr int kFloat = 5126;
inline constexpr int kUnsignedByte = 5121;
inline constexpr int kUnsignedShort = 5123;
inline constexpr int kUnsignedInt = 5125;


inline std::string base64(const std::vector<uint8_t>& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t b0 = bytes[i];
    const uint32_t b1 = i + 1 < bytes.size() ? bytes[i + 1] : 0u;
    const uint32_t b2 = i + 2 < bytes.size() ? bytes[i + 2] : 0u;
    const uint32_t triple = (b0 << 16) | (b1 << 8) | b2;
    out += kAlphabet[(triple >> 18) & 63u];
    out += kAlphabet[(triple >> 12) & 63u];
    out += i + 1 < bytes.size() ? kAlphabet[(triple >> 6) & 63u] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[triple & 63u] : '=';
  }
  return out;
}

// Builds a glTF document with one binary buffer.
class GltfWriter {
 public:
  GltfWriter() {
    doc_["asset"] = {{"version", "2.0"}, {"generator", "shrefract gltf_import_test"}};
  }

  json& doc() { return doc_; }

  // Appends raw bytes (4-byte aligned) as a buffer view; returns its index.
  int addView(const void* data, size_t bytes, size_t stride = 0) {
    while (bin_.size() % 4 != 0) {
      bin_.push_back(0);
    }
    json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", bytes}};
    if (stride != 0) {
      view["byteStride"] = stride;
    }
    const auto* p = static_cast<const uint8_t*>(data);
    bin_.insert(bin_.end(), p, p + bytes);
    doc_["bufferViews"].push_back(view);
    return static_cast<int>(doc_["bufferViews"].size()) - 1;
  }

  int addAccessor(int view, int componentType, size_t count, const char* type,
                  size_t byteOffset = 0, bool normalized = false) {
    json accessor = {{"bufferView", view},
                     {"componentType", componentType},
                     {"count", count},
                     {"type", type}};
    if (byteOffset != 0) {
      accessor["byteOffset"] = byteOffset;
    }
    if (normalized) {
      accessor["normalized"] = true;
    }
    doc_["accessors"].push_back(accessor);
    return static_cast<int>(doc_["accessors"].size()) - 1;
  }

  int addVec3(const std::vector<glm::vec3>& values) {
    const int view = addView(values.data(), values.size() * sizeof(glm::vec3));
    const int accessor = addAccessor(view, kFloat, values.size(), "VEC3");
    glm::vec3 lo = values.front();
    glm::vec3 hi = values.front();
    for (const glm::vec3& v : values) {
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
    doc_["accessors"][static_cast<size_t>(accessor)]["min"] = {lo.x, lo.y, lo.z};
    doc_["accessors"][static_cast<size_t>(accessor)]["max"] = {hi.x, hi.y, hi.z};
    return accessor;
  }

  // Indices as u8, u16 or u32.
  int addIndices(const std::vector<uint32_t>& indices, int componentType = kUnsignedInt) {
    std::vector<uint8_t> bytes;
    for (uint32_t index : indices) {
      if (componentType == kUnsignedByte) {
        bytes.push_back(static_cast<uint8_t>(index));
      } else if (componentType == kUnsignedShort) {
        const auto v = static_cast<uint16_t>(index);
        bytes.insert(bytes.end(), {static_cast<uint8_t>(v & 0xFFu), static_cast<uint8_t>(v >> 8)});
      } else {
        bytes.resize(bytes.size() + 4);
        std::memcpy(bytes.data() + bytes.size() - 4, &index, 4);
      }
    }
    const int view = addView(bytes.data(), bytes.size());
    return addAccessor(view, componentType, indices.size(), "SCALAR");
  }

  int addMaterial(json material) {
    doc_["materials"].push_back(std::move(material));
    return static_cast<int>(doc_["materials"].size()) - 1;
  }

  int addMesh(json primitives, const std::string& name = "") {
    json mesh = {{"primitives", std::move(primitives)}};
    if (!name.empty()) {
      mesh["name"] = name;
    }
    doc_["meshes"].push_back(mesh);
    return static_cast<int>(doc_["meshes"].size()) - 1;
  }

  int addNode(json node) {
    doc_["nodes"].push_back(std::move(node));
    return static_cast<int>(doc_["nodes"].size()) - 1;
  }

  void setScene(const std::vector<int>& nodes) {
    doc_["scenes"] = json::array({json{{"nodes", nodes}}});
    doc_["scene"] = 0;
  }

  json finished(bool glb) const {
    json out = doc_;
    json buffer = {{"byteLength", bin_.size()}};
    if (!glb) {
      buffer["uri"] = "data:application/octet-stream;base64," + base64(bin_);
    }
    out["buffers"] = json::array({buffer});
    return out;
  }

  std::string writeGltf(const std::filesystem::path& path) const {
    std::ofstream(path, std::ios::binary) << finished(false).dump(1);
    return path.string();
  }

  std::string writeGlb(const std::filesystem::path& path) const {
    std::string text = finished(true).dump();
    while (text.size() % 4 != 0) {
      text += ' ';
    }
    std::vector<uint8_t> bin = bin_;
    while (bin.size() % 4 != 0) {
      bin.push_back(0);
    }
    std::vector<uint8_t> file;
    auto u32 = [&file](uint32_t v) {
      for (int i = 0; i < 4; ++i) {
        file.push_back(static_cast<uint8_t>(v >> (8 * i)));
      }
    };
    u32(0x46546C67u);  // "glTF"
    u32(2);
    u32(static_cast<uint32_t>(12 + 8 + text.size() + 8 + bin.size()));
    u32(static_cast<uint32_t>(text.size()));
    u32(0x4E4F534Au);  // "JSON"
    file.insert(file.end(), text.begin(), text.end());
    u32(static_cast<uint32_t>(bin.size()));
    u32(0x004E4942u);  // "BIN\0"
    file.insert(file.end(), bin.begin(), bin.end());
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(file.data()),
               static_cast<std::streamsize>(file.size()));
    return path.string();
  }

 private:
  json doc_;
  std::vector<uint8_t> bin_;
};

// Cube of edge 2 * half centred at `center`: 8 corners (corner i has coordinate k at +half when
// bit k of i is set), 12 triangles counter-clockwise seen from outside.
struct Cube {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;  // corner normals: normalized corner directions
  std::vector<uint32_t> indices;
};

inline Cube makeCube(float half = 1.0f, glm::vec3 center = glm::vec3(0.0f)) {
  Cube cube;
  for (uint32_t i = 0; i < 8; ++i) {
    const glm::vec3 d((i & 1u) ? 1.0f : -1.0f, (i & 2u) ? 1.0f : -1.0f, (i & 4u) ? 1.0f : -1.0f);
    cube.positions.push_back(center + half * d);
    cube.normals.push_back(glm::normalize(d));
  }
  for (uint32_t axis = 0; axis < 3; ++axis) {
    const uint32_t u = (axis + 1) % 3;
    const uint32_t w = (axis + 2) % 3;
    for (uint32_t side = 0; side < 2; ++side) {
      const uint32_t base = side << axis;
      const uint32_t c00 = base;
      const uint32_t c10 = base | (1u << u);
      const uint32_t c11 = base | (1u << u) | (1u << w);
      const uint32_t c01 = base | (1u << w);
      if (side == 1) {  // u x w = +axis: (c00, c10, c11) is counter-clockwise seen from +axis
        cube.indices.insert(cube.indices.end(), {c00, c10, c11, c00, c11, c01});
      } else {
        cube.indices.insert(cube.indices.end(), {c00, c11, c10, c00, c01, c11});
      }
    }
  }
  return cube;
}

inline json glassMaterial(double ior, const std::string& name = "glass") {
  return json{{"name", name},
              {"extensions",
               {{"KHR_materials_ior", {{"ior", ior}}},
                {"KHR_materials_transmission", {{"transmissionFactor", 1.0}}},
                {"KHR_materials_volume", {{"thicknessFactor", 1.0}}}}}};
}


// A box of edge 2 * half at `center` as exporters write flat-shaded boxes: every face with its
// own 4 vertices and normal (24 vertices, 12 triangles, counter-clockwise seen from outside).
// Faces in the order +x, -x, +y, -y, +z, -z; face f uses vertices 4f .. 4f + 3.
struct FaceBox {
  std::vector<glm::vec3> positions, normals;
  std::vector<uint32_t> indices;
};

inline FaceBox makeFaceBox(float half, glm::vec3 center) {
  FaceBox box;
  for (int axis = 0; axis < 3; ++axis) {
    for (float sign : {1.0f, -1.0f}) {
      glm::vec3 n(0.0f);
      n[axis] = sign;
      glm::vec3 u(0.0f), v(0.0f);
      u[(axis + 1) % 3] = 1.0f;
      v[(axis + 2) % 3] = 1.0f;
      if (sign < 0.0f) std::swap(u, v);  // keeps u x v = n, so the winding faces outward
      const auto base = static_cast<uint32_t>(box.positions.size());
      for (glm::vec2 c : {glm::vec2(-1, -1), glm::vec2(1, -1), glm::vec2(1, 1), glm::vec2(-1, 1)}) {
        box.positions.push_back(center + half * (n + c.x * u + c.y * v));
        box.normals.push_back(n);
      }
      box.indices.insert(box.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
  }
  return box;
}

// Two overlapping boxes of different materials as a Blender export brings them: box A ("glass",
// ior 1.5, edge 2 at the origin, mesh 'boxA' in node 'A') with its y faces off by float round-off
// (2e-6, so 8 vertices are welded), its +z face written twice (2 duplicated triangles) and 2
// degenerate triangles; box B ("crystal", ior 1.7, edge 2 at (1, 0.5, 0.25), mesh 'boxB' in node
// 'B') with 1 degenerate triangle. Neither box contains the other.
struct BlenderBoxesCounts {
  size_t welded = 8, duplicated = 2, degenerateA = 2, degenerateB = 1;
};

inline GltfWriter blenderStyleBoxes() {
  FaceBox a = makeFaceBox(1.0f, glm::vec3(0.0f));
  for (uint32_t i = 8; i < 16; ++i) a.positions[i].x += 2e-6f;  // faces +y and -y
  a.indices.insert(a.indices.end(), a.indices.begin() + 24, a.indices.begin() + 30);  // +z again
  a.indices.insert(a.indices.end(), {0, 0, 1, 5, 6, 6});
  FaceBox b = makeFaceBox(1.0f, glm::vec3(1.0f, 0.5f, 0.25f));
  b.indices.insert(b.indices.end(), {2, 3, 3});
  GltfWriter w;
  auto addBox = [&w](const FaceBox& box, const std::string& name, json material) {
    const int m = w.addMaterial(std::move(material));
    json attributes = {{"POSITION", w.addVec3(box.positions)}, {"NORMAL", w.addVec3(box.normals)}};
    const int indices = w.addIndices(box.indices);
    const int mesh = w.addMesh(
        json::array({json{{"attributes", attributes}, {"indices", indices}, {"material", m}}}), "box" + name);
    return w.addNode(json{{"name", name}, {"mesh", mesh}});
  };
  const int nodeA = addBox(a, "A", glassMaterial(1.5, "glass"));
  const int nodeB = addBox(b, "B", glassMaterial(1.7, "crystal"));
  w.setScene({nodeA, nodeB});
  return w;
}

}  // namespace shrefract::gltf_test
