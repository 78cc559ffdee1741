// The glTF importer's pieces: the Importer (gltf_import.cpp runs it) and what its stages share.
// Accessors and primitives (gltf_accessors.cpp), the node hierarchy (gltf_nodes.cpp), mesh repair
// and closed volumes (gltf_repair.cpp), media from materials (gltf_materials.cpp), containment
// (gltf_containment.cpp). Private to shrefract::assets.
#pragma once

#include <shrefract/assets/gltf_import.h>

// tinygltf's header is not warning-clean under our flags; its implementation lives in the system
// library (TINYGLTF_IMPLEMENTATION must not be defined here).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wold-style-cast"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wuseless-cast"
#include <tiny_gltf.h>
#pragma GCC diagnostic pop

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <optional>
#include <cstdio>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace shrefract::bake::gltf_detail {

static_assert(std::endian::native == std::endian::little, "glTF buffers are little-endian");

inline constexpr float kDefaultIor = 1.5f;  // KHR_materials_ior default (and the core glTF dielectric)

// attenuationColor channels are clamped to at least this before taking -ln(c): a channel of 0
// (black) means "absorbs everything", which has no finite absorption. -ln(1e-6) = 13.8, i.e. the
// channel keeps 1e-6 of its light after one attenuationDistance.
inline constexpr double kMinAttenuationColor = 1e-6;

// Interior points of volumes with no opposite wall (open meshes) are pushed inside by this
// fraction of the volume's bounding-box diagonal.
inline constexpr double kInteriorOffset = 1e-4;

// Positions of one volume closer than this fraction of its bounding-box diagonal are welded: the
// cracks exporters leave (float round-off in transforms, split vertices written twice) are far
// smaller, real features of a mesh far larger (the bunny's vertex spacing is ~1e-3 of its size).
inline constexpr double kWeldTolerance = 1e-5;

// Overlap test between closed volumes: this many vertices of each (evenly strided) are tested
// against the other, each pulled this fraction of the diagonal toward its volume's centre so that
// volumes that only touch (a shared face) do not count.
inline constexpr size_t kOverlapProbes = 64;

inline constexpr double kOverlapInset = 1e-3;

// Node hierarchies are walked recursively; this bounds the stack a malicious file can take.
// Real scenes are a few levels deep.
inline constexpr size_t kMaxNodeDepth = 1024;

// Directions of the parity rays of the containment test: far from the axes and from each other,
// so that axis-aligned models do not send them exactly along edges or faces.
inline constexpr std::array<glm::dvec3, 3> kParityDirections{
    glm::dvec3(0.2672612419, 0.5345224838, 0.8017837257),
    glm::dvec3(-0.7071067812, 0.1178511302, 0.6972166888),
    glm::dvec3(0.3539202769, -0.8846832213, 0.3034034657)};

inline std::string lowercase(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// tinygltf's messages are multi-line; errors must be one line.
inline std::string oneLine(const std::string& text) {
  std::string out;
  std::string line;
  auto flush = [&out, &line] {
    const size_t begin = line.find_first_not_of(" \t");
    if (begin != std::string::npos) {
      const size_t end = line.find_last_not_of(" \t");
      if (!out.empty()) {
        out += "; ";
      }
      out += line.substr(begin, end - begin + 1);
    }
    line.clear();
  };
  for (char c : text) {
    if (c == '\n' || c == '\r') {
      flush();
    } else {
      line += c;
    }
  }
  flush();
  return out;
}

inline std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::string line;
  for (char c : text) {
    if (c == '\n' || c == '\r') {
      if (!oneLine(line).empty()) {
        out.push_back(oneLine(line));
      }
      line.clear();
    } else {
      line += c;
    }
  }
  if (!oneLine(line).empty()) {
    out.push_back(oneLine(line));
  }
  return out;
}

inline std::string quoted(const std::string& name) { return name.empty() ? "" : " ('" + name + "')"; }

inline bool isFinite(glm::vec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// A validated accessor: `count` elements of `elementSize` bytes, `stride` apart, all inside the
// buffer.
struct AccessorView {
  const unsigned char* data = nullptr;
  size_t count = 0;
  size_t stride = 0;
  int type = 0;  // TINYGLTF_TYPE_*
  int componentType = 0;
  bool normalized = false;

  const unsigned char* element(size_t i) const { return data + i * stride; }
};

// One mesh instance's primitives that share a material: one volume, one Surface.
struct Volume {
  std::string label;  // "mesh 0 ('name') in node 2 ('name')" for messages
  std::string name;   // Surface name
  int material = -1;  // glTF material index, -1 = default material
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;
  std::vector<glm::vec2> uvs;              // one per vertex (zeros where a primitive had none)
  std::vector<uint8_t> normalFromFile;     // per vertex: 1 when NORMAL gave a usable normal
  std::vector<uint32_t> indices;
  bool anyUvs = false;
  bool missingUvs = false;
  size_t degenerate = 0;        // triangles dropped (two corners at one position once welded)
  size_t computedNormals = 0;   // vertices whose normal was computed
  // Filled by finalize().
  bool closed = false;
  double volume = 0.0;  // signed, after orientation
  glm::dvec3 boundsMin{0.0};
  glm::dvec3 boundsMax{0.0};
  uint32_t medium = 0;
};

// What repairVolume changed, for the warnings.
struct Repairs {
  size_t welded = 0;        // vertices moved onto another within the tolerance
  size_t duplicated = 0;    // triangles dropped: the same corners, the same winding, as a kept one
  size_t internal = 0;      // triangles dropped in pairs: the same corners, opposite windings
  double tolerance = 0.0;
};

// A primitive's attributes as read and checked, in its mesh's own space.
struct PrimitiveData {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;  // empty when it has no NORMAL
  std::vector<glm::vec2> uvs;      // empty when it has no TEXCOORD_0
  std::vector<uint32_t> indices;   // triangle corners
};

// What a material's KHR_materials_ior, _transmission and _volume say; glTF's defaults where absent.
struct MaterialVolume {
  double ior = kDefaultIor;
  double transmission = 0.0;
  double thickness = 0.0;
  double distance = std::numeric_limits<double>::infinity();
  glm::dvec3 color{1.0};
  std::string bad;  // the last malformed property read, empty when none
};

class Importer {
 public:
  Importer(const std::string& path, const ImportOptions& options, ImportReport& report)
      : path_(path), options_(options), report_(report) {}

  Result<Scene> run();

 private:
  Error fail(ErrorCode code, const std::string& problem) const {
    return makeError(code, path_ + ": " + problem);
  }
  void warn(const std::string& warning) { report_.warnings.push_back(path_ + ": " + warning); }

  Result<void> load();
  Result<void> visitNode(int nodeIndex, const glm::dmat4& parent, std::vector<uint8_t>& onPath,
                         size_t depth);
  Result<glm::dmat4> localTransform(int nodeIndex) const;
  Result<void> addInstance(int nodeIndex, const glm::dmat4& world);
  void nameAfterMaterials(const std::map<int, size_t>& byMaterial);
  Result<void> addPrimitive(const std::string& where, const tinygltf::Primitive& primitive,
                            const glm::dmat4& world, const glm::dmat3& normalMatrix, bool mirrored,
                            Volume& volume);
  Result<PrimitiveData> readPrimitive(const std::string& where,
                                      const tinygltf::Primitive& primitive) const;
  Result<void> checkPerVertex(const std::string& what, size_t count, size_t vertexCount) const;
  template <class T>
  Result<std::vector<T>> readPerVertex(const std::string& where, const tinygltf::Primitive& primitive,
                                       const char* semantic, size_t vertexCount,
                                       Result<std::vector<T>> (Importer::*read)(int, const std::string&) const) const;
  Result<std::vector<uint32_t>> readTriangles(const std::string& where,
                                              const tinygltf::Primitive& primitive,
                                              size_t vertexCount) const;
  Result<void> appendVertices(const std::string& where, const PrimitiveData& data,
                              const glm::dmat4& world, const glm::dmat3& normalMatrix,
                              Volume& volume);
  Result<AccessorView> viewAccessor(int accessorIndex, const std::string& what) const;
  Result<void> checkAccessorRange(const std::string& what, const tinygltf::Accessor& accessor,
                                  size_t elementSize, size_t stride) const;
  Result<std::vector<glm::vec3>> readVec3(int accessorIndex, const std::string& what) const;
  Result<std::vector<glm::vec2>> readTexcoords(int accessorIndex, const std::string& what) const;
  Result<std::vector<uint32_t>> readIndices(int accessorIndex, const std::string& what,
                                            size_t vertexCount) const;
  void reportRepairs(const Volume& volume, const Repairs& repairs);
  Result<void> finalize(Volume& volume);
  Result<void> checkClosed(Volume& volume);
  void orientOutward(Volume& volume);
  void settleNormals(Volume& volume);
  Result<Medium> mediumOf(int materialIndex);
  Result<void> checkMaterialVolume(const std::string& what, const MaterialVolume& m) const;
  Result<void> checkOverrides() const;
  Result<void> collectVolumes();
  Result<void> assignMedia(Scene& scene);
  size_t innermostContainer(size_t v, const std::set<std::pair<size_t, size_t>>& overlaps) const;
  Result<void> addSurfaces(Scene& scene, const std::set<std::pair<size_t, size_t>>& overlaps);
  glm::dvec3 interiorPoint(const Volume& volume) const;
  bool contains(const Volume& container, const glm::dvec3& point) const;
  // {probes inside, probes tested}
  std::pair<size_t, size_t> probesInside(const Volume& probed, const Volume& container) const;
  std::set<std::pair<size_t, size_t>> findOverlaps();

  const std::string& path_;
  const ImportOptions& options_;
  ImportReport& report_;
  tinygltf::Model model_;
  std::vector<Volume> volumes_;
};

}  // namespace shrefract::bake::gltf_detail
