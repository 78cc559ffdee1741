// glTF import: reads the default scene with tinygltf, validates every accessor it touches, bakes
// the node transforms into world-space surfaces and assigns media by containment (the medium
// stack rule of docs/scenes.md, "glTF media and the medium stack").
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

namespace shrefract::bake {
namespace {

static_assert(std::endian::native == std::endian::little, "glTF buffers are little-endian");

constexpr float kDefaultIor = 1.5f;  // KHR_materials_ior default (and the core glTF dielectric)

// attenuationColor channels are clamped to at least this before taking -ln(c): a channel of 0
// (black) means "absorbs everything", which has no finite absorption. -ln(1e-6) = 13.8, i.e. the
// channel keeps 1e-6 of its light after one attenuationDistance.
constexpr double kMinAttenuationColor = 1e-6;

// Interior points of volumes with no opposite wall (open meshes) are pushed inside by this
// fraction of the volume's bounding-box diagonal.
constexpr double kInteriorOffset = 1e-4;

// Positions of one volume closer than this fraction of its bounding-box diagonal are welded: the
// cracks exporters leave (float round-off in transforms, split vertices written twice) are far
// smaller, real features of a mesh far larger (the bunny's vertex spacing is ~1e-3 of its size).
constexpr double kWeldTolerance = 1e-5;

// Overlap test between closed volumes: this many vertices of each (evenly strided) are tested
// against the other, each pulled this fraction of the diagonal toward its volume's centre so that
// volumes that only touch (a shared face) do not count.
constexpr size_t kOverlapProbes = 64;
constexpr double kOverlapInset = 1e-3;

// Node hierarchies are walked recursively; this bounds the stack a malicious file can take.
// Real scenes are a few levels deep.
constexpr size_t kMaxNodeDepth = 1024;

// Directions of the parity rays of the containment test: far from the axes and from each other,
// so that axis-aligned models do not send them exactly along edges or faces.
constexpr std::array<glm::dvec3, 3> kParityDirections{
    glm::dvec3(0.2672612419, 0.5345224838, 0.8017837257),
    glm::dvec3(-0.7071067812, 0.1178511302, 0.6972166888),
    glm::dvec3(0.3539202769, -0.8846832213, 0.3034034657)};

std::string lowercase(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// tinygltf's messages are multi-line; errors must be one line.
std::string oneLine(const std::string& text) {
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

std::vector<std::string> lines(const std::string& text) {
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

std::string quoted(const std::string& name) { return name.empty() ? "" : " ('" + name + "')"; }

bool isFinite(glm::vec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Bytes per component, 0 for a component type glTF 2.0 does not define.
size_t componentSize(int componentType) {
  switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return 4;
    default:
      return 0;
  }
}

// Components per element, 0 for an unknown type.
size_t componentCount(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR:
      return 1;
    case TINYGLTF_TYPE_VEC2:
      return 2;
    case TINYGLTF_TYPE_VEC3:
      return 3;
    case TINYGLTF_TYPE_VEC4:
    case TINYGLTF_TYPE_MAT2:
      return 4;
    case TINYGLTF_TYPE_MAT3:
      return 9;
    case TINYGLTF_TYPE_MAT4:
      return 16;
    default:
      return 0;
  }
}

const char* modeName(int mode) {
  switch (mode) {
    case 0:
      return "POINTS";
    case 1:
      return "LINES";
    case 2:
      return "LINE_LOOP";
    case 3:
      return "LINE_STRIP";
    case 4:
      return "TRIANGLES";
    case 5:
      return "TRIANGLE_STRIP";
    case 6:
      return "TRIANGLE_FAN";
    default:
      return "unknown";
  }
}

template <class T>
T readScalar(const unsigned char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

// A validated accessor: `count` elements of `elementSize` bytes, `stride` apart, all inside the
// buffer.
struct AccessorView {
  const unsigned char* data = nullptr;
  size_t count = 0;
  size_t stride = 0;
  int componentType = 0;
  bool normalized = false;

  const unsigned char* element(size_t i) const { return data + i * stride; }
};

// Möller-Trumbore; returns the ray parameter of the hit, or a negative value for none. Hits on
// edges count (both triangles sharing an edge may report it; the parity test votes over rays).
double intersect(const glm::dvec3& origin, const glm::dvec3& direction, const glm::dvec3& a,
                 const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 e1 = b - a;
  const glm::dvec3 e2 = c - a;
  const glm::dvec3 p = glm::cross(direction, e2);
  const double det = glm::dot(e1, p);
  if (det == 0.0) {
    return -1.0;
  }
  const double inv = 1.0 / det;
  const glm::dvec3 s = origin - a;
  const double u = glm::dot(s, p) * inv;
  if (u < 0.0 || u > 1.0) {
    return -1.0;
  }
  const glm::dvec3 q = glm::cross(s, e1);
  const double v = glm::dot(direction, q) * inv;
  if (v < 0.0 || u + v > 1.0) {
    return -1.0;
  }
  return glm::dot(e2, q) * inv;
}

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

glm::dvec3 boundsDiagonal(const std::vector<glm::vec3>& positions) {
  glm::dvec3 lo(positions.front()), hi(positions.front());
  for (const glm::vec3& p : positions) {
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  return hi - lo;
}

// Welds positions closer than `tolerance` (a spatial hash with cells of the tolerance; the first
// vertex of a cluster is kept): every vertex gets its representative's id and position. Vertices
// stay separate (their normals and uvs may differ), only positions are shared, as closure needs.
std::vector<uint32_t> weldPositions(std::vector<glm::vec3>& positions, double tolerance, size_t& moved) {
  std::vector<uint32_t> representative(positions.size());
  std::map<std::array<int64_t, 3>, std::vector<uint32_t>> cells;
  const double cell = tolerance > 0.0 ? tolerance : 1.0;
  auto cellOf = [cell](const glm::vec3& p) {
    // Clamped: a far-away vertex of a tiny mesh must not overflow the cell index.
    const glm::dvec3 c = glm::clamp(glm::floor(glm::dvec3(p) / cell), -4e18, 4e18);
    return std::array<int64_t, 3>{static_cast<int64_t>(c.x), static_cast<int64_t>(c.y), static_cast<int64_t>(c.z)};
  };
  auto find = [&](const glm::vec3& p) -> std::optional<uint32_t> {
    const auto c = cellOf(p);
    for (int64_t dx = -1; dx <= 1; ++dx)
      for (int64_t dy = -1; dy <= 1; ++dy)
        for (int64_t dz = -1; dz <= 1; ++dz) {
          const auto it = cells.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == cells.end()) continue;
          for (uint32_t r : it->second)
            if (glm::length(glm::dvec3(positions[r]) - glm::dvec3(p)) <= tolerance) return r;
        }
    return std::nullopt;
  };
  moved = 0;
  for (uint32_t i = 0; i < positions.size(); ++i) {
    const auto r = find(positions[i]);
    if (!r) {
      representative[i] = i;
      cells[cellOf(positions[i])].push_back(i);
      continue;
    }
    representative[i] = *r;
    if (positions[i] != positions[*r]) ++moved;
    positions[i] = positions[*r];
  }
  return representative;
}

// The corners of a triangle as welded ids, rotated so the smallest comes first (winding kept).
std::array<uint32_t, 3> canonical(uint32_t a, uint32_t b, uint32_t c) {
  if (b < a && b < c) return {b, c, a};
  if (c < a && c < b) return {c, a, b};
  return {a, b, c};
}

// Meshes as exporters write them: welds positions within the tolerance, drops triangles whose
// corners coincide once welded (counted in volume.degenerate), keeps one of every set of
// duplicated triangles, and drops both triangles of a pair with the same corners and opposite
// windings (an internal wall between two parts of one volume, e.g. two boxes joined face to face).
Repairs repairVolume(Volume& volume) {
  Repairs repairs;
  if (volume.positions.empty()) return repairs;
  repairs.tolerance = kWeldTolerance * glm::length(boundsDiagonal(volume.positions));
  const std::vector<uint32_t> id = weldPositions(volume.positions, repairs.tolerance, repairs.welded);
  std::map<std::array<uint32_t, 3>, size_t> kept;  // canonical corners -> triangle in `out`
  std::vector<std::array<uint32_t, 3>> out;
  std::vector<uint8_t> dropped;
  for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
    const uint32_t a = volume.indices[t], b = volume.indices[t + 1], c = volume.indices[t + 2];
    if (id[a] == id[b] || id[b] == id[c] || id[c] == id[a]) {
      ++volume.degenerate;
      continue;
    }
    const auto key = canonical(id[a], id[b], id[c]);
    if (kept.count(key) != 0) {
      ++repairs.duplicated;
      continue;
    }
    if (auto opposite = kept.find(canonical(id[a], id[c], id[b])); opposite != kept.end()) {
      dropped[opposite->second] = 1;
      kept.erase(opposite);
      repairs.internal += 2;
      continue;
    }
    kept.emplace(key, out.size());
    out.push_back({a, b, c});
    dropped.push_back(0);
  }
  volume.indices.clear();
  for (size_t t = 0; t < out.size(); ++t)
    if (dropped[t] == 0) volume.indices.insert(volume.indices.end(), out[t].begin(), out[t].end());
  return repairs;
}

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

// The container of a glTF file: by its extension, else by its first bytes (the binary magic
// "glTF", or a JSON object), so that a file exported under another name still imports.
std::optional<bool> isBinaryGltf(const std::string& path) {
  const std::string extension = lowercase(std::filesystem::path(path).extension().string());
  if (extension == ".gltf" || extension == ".glb") {
    return extension == ".glb";
  }
  std::ifstream in(path, std::ios::binary);
  char head[64] = {};
  in.read(head, sizeof head);
  const auto n = static_cast<size_t>(in.gcount());
  if (n >= 4 && std::memcmp(head, "glTF", 4) == 0) {
    return true;
  }
  for (size_t i = 0; i < n; ++i) {
    if (!std::isspace(static_cast<unsigned char>(head[i]))) {
      return head[i] == '{' ? std::optional<bool>(false) : std::nullopt;
    }
  }
  return std::nullopt;
}

Result<void> Importer::load() {
  std::error_code ec;
  if (!std::filesystem::exists(path_, ec)) {
    return fail(ErrorCode::Io, "no such file");
  }
  if (!std::filesystem::is_regular_file(path_, ec)) {
    return fail(ErrorCode::Io, "not a regular file");
  }
  const std::optional<bool> binary = isBinaryGltf(path_);
  if (!binary) {
    return fail(ErrorCode::InvalidArgument,
                "not a glTF file (neither the extension .gltf or .glb nor glTF content)");
  }

  tinygltf::TinyGLTF loader;
  // Images are never needed: skip decoding them (and do not fail on formats stb cannot read).
  loader.SetImageLoader(
      [](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*,
         int, void*) { return true; },
      nullptr);
  std::string err;
  std::string warnings;
  const bool ok = *binary ? loader.LoadBinaryFromFile(&model_, &err, &warnings, path_)
                                      : loader.LoadASCIIFromFile(&model_, &err, &warnings, path_);
  for (const std::string& line : lines(warnings)) {
    warn(line);
  }
  if (!ok) {
    const std::string message = oneLine(err);
    return fail(ErrorCode::CorruptData,
                "cannot parse glTF: " + (message.empty() ? std::string("unknown error") : message));
  }

  // Required extensions that change how geometry is stored cannot be ignored; material and texture
  // extensions do not touch the geometry.
  for (const std::string& name : model_.extensionsRequired) {
    const bool harmless = name.starts_with("KHR_materials_") || name.starts_with("KHR_texture_") ||
                          name.starts_with("EXT_texture_") || name == "KHR_lights_punctual" ||
                          name == "KHR_mesh_quantization";
    if (!harmless) {
      return fail(ErrorCode::Unsupported,
                  "requires extension " + name + ", which is not supported");
    }
  }
  return {};
}

Result<AccessorView> Importer::viewAccessor(int accessorIndex, const std::string& what) const {
  if (accessorIndex < 0 || static_cast<size_t>(accessorIndex) >= model_.accessors.size()) {
    return fail(ErrorCode::CorruptData,
                what + " does not exist (" + std::to_string(model_.accessors.size()) +
                    " accessors)");
  }
  const tinygltf::Accessor& accessor = model_.accessors[static_cast<size_t>(accessorIndex)];
  if (accessor.sparse.isSparse) {
    return fail(ErrorCode::Unsupported, what + " is sparse, which is not supported");
  }
  if (accessor.bufferView < 0 ||
      static_cast<size_t>(accessor.bufferView) >= model_.bufferViews.size()) {
    return fail(ErrorCode::CorruptData,
                what + " has no valid buffer view (" + std::to_string(accessor.bufferView) + ")");
  }
  const tinygltf::BufferView& view = model_.bufferViews[static_cast<size_t>(accessor.bufferView)];
  if (view.buffer < 0 || static_cast<size_t>(view.buffer) >= model_.buffers.size()) {
    return fail(ErrorCode::CorruptData,
                what + ": buffer view " + std::to_string(accessor.bufferView) +
                    " refers to missing buffer " + std::to_string(view.buffer));
  }
  const tinygltf::Buffer& buffer = model_.buffers[static_cast<size_t>(view.buffer)];
  const size_t elementSize = componentSize(accessor.componentType) * componentCount(accessor.type);
  if (elementSize == 0) {
    return fail(ErrorCode::CorruptData, what + " has an invalid component type (" +
                                            std::to_string(accessor.componentType) + ") or type (" +
                                            std::to_string(accessor.type) + ")");
  }
  const size_t stride = view.byteStride != 0 ? view.byteStride : elementSize;
  if (stride < elementSize) {
    return fail(ErrorCode::CorruptData, what + " has byteStride " + std::to_string(stride) +
                                            ", smaller than its element (" +
                                            std::to_string(elementSize) + " bytes)");
  }
  if (Result<void> inside = checkAccessorRange(what, accessor, elementSize, stride); !inside) {
    return inside.error();
  }
  AccessorView out;
  out.data = buffer.data.data() + view.byteOffset + accessor.byteOffset;
  out.count = accessor.count;
  out.stride = stride;
  out.componentType = accessor.componentType;
  out.normalized = accessor.normalized;
  return out;
}

// The accessor's elements lie inside its buffer view, and the view inside its buffer.
Result<void> Importer::checkAccessorRange(const std::string& what,
                                          const tinygltf::Accessor& accessor, size_t elementSize,
                                          size_t stride) const {
  const tinygltf::BufferView& view = model_.bufferViews[static_cast<size_t>(accessor.bufferView)];
  const tinygltf::Buffer& buffer = model_.buffers[static_cast<size_t>(view.buffer)];
  // Both checks are written so that nothing can overflow, whatever the file says.
  if (view.byteOffset > buffer.data.size() ||
      view.byteLength > buffer.data.size() - view.byteOffset) {
    return fail(ErrorCode::CorruptData,
                what + ": buffer view " + std::to_string(accessor.bufferView) + " (offset " +
                    std::to_string(view.byteOffset) + ", length " +
                    std::to_string(view.byteLength) + ") lies outside buffer " +
                    std::to_string(view.buffer) + " (" + std::to_string(buffer.data.size()) +
                    " bytes)");
  }
  if (accessor.count > 0) {
    const bool fits = accessor.byteOffset <= view.byteLength &&
                      elementSize <= view.byteLength - accessor.byteOffset &&
                      accessor.count - 1 <=
                          (view.byteLength - accessor.byteOffset - elementSize) / stride;
    if (!fits) {
      return fail(ErrorCode::CorruptData,
                  what + " (" + std::to_string(accessor.count) + " elements of " +
                      std::to_string(elementSize) + " bytes, stride " + std::to_string(stride) +
                      ", offset " + std::to_string(accessor.byteOffset) +
                      ") does not fit in buffer view " + std::to_string(accessor.bufferView) +
                      " (" + std::to_string(view.byteLength) + " bytes)");
    }
  }
  return {};
}

Result<std::vector<glm::vec3>> Importer::readVec3(int accessorIndex,
                                                  const std::string& what) const {
  Result<AccessorView> view = viewAccessor(accessorIndex, what);
  if (!view) {
    return view.error();
  }
  const tinygltf::Accessor& accessor = model_.accessors[static_cast<size_t>(accessorIndex)];
  if (accessor.type != TINYGLTF_TYPE_VEC3 ||
      accessor.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT) {
    return fail(ErrorCode::Unsupported, what + " must be FLOAT VEC3 (component type " +
                                            std::to_string(accessor.componentType) + ", type " +
                                            std::to_string(accessor.type) + ")");
  }
  std::vector<glm::vec3> out(view->count);
  for (size_t i = 0; i < view->count; ++i) {
    const unsigned char* e = view->element(i);
    out[i] = glm::vec3(readScalar<float>(e), readScalar<float>(e + 4), readScalar<float>(e + 8));
    if (!isFinite(out[i])) {
      return fail(ErrorCode::CorruptData,
                  what + " element " + std::to_string(i) + " is not finite");
    }
  }
  return out;
}

Result<std::vector<glm::vec2>> Importer::readTexcoords(int accessorIndex,
                                                       const std::string& what) const {
  Result<AccessorView> view = viewAccessor(accessorIndex, what);
  if (!view) {
    return view.error();
  }
  const tinygltf::Accessor& accessor = model_.accessors[static_cast<size_t>(accessorIndex)];
  const int type = accessor.componentType;
  const bool supported =
      accessor.type == TINYGLTF_TYPE_VEC2 &&
      (type == TINYGLTF_COMPONENT_TYPE_FLOAT ||
       (accessor.normalized && (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT)));
  if (!supported) {
    return fail(ErrorCode::Unsupported,
                what + " must be VEC2 of FLOAT or normalized UNSIGNED_BYTE / UNSIGNED_SHORT");
  }
  std::vector<glm::vec2> out(view->count);
  for (size_t i = 0; i < view->count; ++i) {
    const unsigned char* e = view->element(i);
    if (type == TINYGLTF_COMPONENT_TYPE_FLOAT) {
      out[i] = glm::vec2(readScalar<float>(e), readScalar<float>(e + 4));
    } else if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
      out[i] = glm::vec2(static_cast<float>(e[0]), static_cast<float>(e[1])) / 255.0f;
    } else {
      out[i] = glm::vec2(static_cast<float>(readScalar<uint16_t>(e)),
                         static_cast<float>(readScalar<uint16_t>(e + 2))) /
               65535.0f;
    }
    if (!std::isfinite(out[i].x) || !std::isfinite(out[i].y)) {
      return fail(ErrorCode::CorruptData,
                  what + " element " + std::to_string(i) + " is not finite");
    }
  }
  return out;
}

Result<std::vector<uint32_t>> Importer::readIndices(int accessorIndex, const std::string& what,
                                                    size_t vertexCount) const {
  Result<AccessorView> view = viewAccessor(accessorIndex, what);
  if (!view) {
    return view.error();
  }
  const tinygltf::Accessor& accessor = model_.accessors[static_cast<size_t>(accessorIndex)];
  const int type = accessor.componentType;
  if (accessor.type != TINYGLTF_TYPE_SCALAR ||
      (type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
       type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
       type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)) {
    return fail(ErrorCode::Unsupported,
                what + " must be SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT");
  }
  if (view->count % 3 != 0) {
    return fail(ErrorCode::CorruptData,
                what + " has " + std::to_string(view->count) + " indices, not a multiple of 3");
  }
  std::vector<uint32_t> out(view->count);
  for (size_t i = 0; i < view->count; ++i) {
    const unsigned char* e = view->element(i);
    uint32_t index = 0;
    if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
      index = e[0];
    } else if (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
      index = readScalar<uint16_t>(e);
    } else {
      index = readScalar<uint32_t>(e);
    }
    if (index >= vertexCount) {
      return fail(ErrorCode::CorruptData, what + " index " + std::to_string(i) + " is " +
                                              std::to_string(index) + ", out of range (" +
                                              std::to_string(vertexCount) + " vertices)");
    }
    out[i] = index;
  }
  return out;
}

Result<glm::dmat4> Importer::localTransform(int nodeIndex) const {
  const tinygltf::Node& node = model_.nodes[static_cast<size_t>(nodeIndex)];
  const std::string what = "node " + std::to_string(nodeIndex) + quoted(node.name);
  glm::dmat4 local(1.0);
  if (!node.matrix.empty()) {
    if (node.matrix.size() != 16) {
      return fail(ErrorCode::CorruptData, what + " has a matrix of " +
                                              std::to_string(node.matrix.size()) + " numbers");
    }
    local = glm::make_mat4(node.matrix.data());  // glTF matrices are column-major, as glm's
  } else {
    if ((!node.translation.empty() && node.translation.size() != 3) ||
        (!node.rotation.empty() && node.rotation.size() != 4) ||
        (!node.scale.empty() && node.scale.size() != 3)) {
      return fail(ErrorCode::CorruptData, what + " has a malformed translation, rotation or scale");
    }
    glm::dvec3 translation(0.0);
    glm::dquat rotation(1.0, 0.0, 0.0, 0.0);
    glm::dvec3 scale(1.0);
    if (!node.translation.empty()) {
      translation = glm::make_vec3(node.translation.data());
    }
    if (!node.rotation.empty()) {  // glTF stores x, y, z, w
      rotation = glm::dquat(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);
      const double length = glm::length(rotation);
      if (!(length > 0.0)) {
        return fail(ErrorCode::CorruptData, what + " has a zero rotation quaternion");
      }
      rotation = rotation / length;
    }
    if (!node.scale.empty()) {
      scale = glm::make_vec3(node.scale.data());
    }
    const glm::dmat3 rs = glm::mat3_cast(rotation) *
                          glm::dmat3(glm::dvec3(scale.x, 0.0, 0.0), glm::dvec3(0.0, scale.y, 0.0),
                                     glm::dvec3(0.0, 0.0, scale.z));
    local = glm::dmat4(rs);
    local[3] = glm::dvec4(translation, 1.0);
  }
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      if (!std::isfinite(local[c][r])) {
        return fail(ErrorCode::CorruptData, what + " has a non-finite transform");
      }
    }
  }
  return local;
}

Result<void> Importer::visitNode(int nodeIndex, const glm::dmat4& parent,
                                 std::vector<uint8_t>& onPath, size_t depth) {
  if (nodeIndex < 0 || static_cast<size_t>(nodeIndex) >= model_.nodes.size()) {
    return fail(ErrorCode::CorruptData, "node " + std::to_string(nodeIndex) + " does not exist (" +
                                            std::to_string(model_.nodes.size()) + " nodes)");
  }
  const size_t index = static_cast<size_t>(nodeIndex);
  if (depth > kMaxNodeDepth) {
    return fail(ErrorCode::Unsupported, "node hierarchy deeper than " +
                                            std::to_string(kMaxNodeDepth) + " levels");
  }
  if (onPath[index] != 0) {
    return fail(ErrorCode::CorruptData,
                "node " + std::to_string(nodeIndex) + " is its own ancestor (cycle)");
  }
  Result<glm::dmat4> local = localTransform(nodeIndex);
  if (!local) {
    return local.error();
  }
  const glm::dmat4 world = parent * local.value();
  const tinygltf::Node& node = model_.nodes[index];
  if (node.mesh >= 0) {
    if (Result<void> added = addInstance(nodeIndex, world); !added) {
      return added;
    }
  }
  onPath[index] = 1;
  for (int child : node.children) {
    if (Result<void> visited = visitNode(child, world, onPath, depth + 1); !visited) {
      return visited;
    }
  }
  onPath[index] = 0;
  return {};
}

Result<void> Importer::addInstance(int nodeIndex, const glm::dmat4& world) {
  const tinygltf::Node& node = model_.nodes[static_cast<size_t>(nodeIndex)];
  const std::string nodeLabel = "node " + std::to_string(nodeIndex) + quoted(node.name);
  if (static_cast<size_t>(node.mesh) >= model_.meshes.size()) {
    return fail(ErrorCode::CorruptData, nodeLabel + " refers to mesh " + std::to_string(node.mesh) +
                                            " of " + std::to_string(model_.meshes.size()));
  }
  const tinygltf::Mesh& mesh = model_.meshes[static_cast<size_t>(node.mesh)];
  const std::string meshLabel = "mesh " + std::to_string(node.mesh) + quoted(mesh.name);
  ++report_.meshes;
  if (node.skin >= 0) {
    warn(nodeLabel + " is skinned; the skin is ignored (bind pose)");
  }

  const glm::dmat3 linear(world);
  const double det = glm::determinant(linear);
  if (!std::isfinite(det) || det == 0.0) {
    return fail(ErrorCode::InvalidArgument,
                nodeLabel + " places " + meshLabel + " with a singular transform");
  }
  const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(linear));

  // Volumes of this instance, by material.
  std::map<int, size_t> byMaterial;
  for (size_t p = 0; p < mesh.primitives.size(); ++p) {
    const tinygltf::Primitive& primitive = mesh.primitives[p];
    const std::string where = meshLabel + " primitive " + std::to_string(p);
    if (primitive.material < -1 ||
        (primitive.material >= 0 &&
         static_cast<size_t>(primitive.material) >= model_.materials.size())) {
      return fail(ErrorCode::CorruptData, where + " refers to material " +
                                              std::to_string(primitive.material) + " of " +
                                              std::to_string(model_.materials.size()));
    }
    auto [it, inserted] = byMaterial.try_emplace(primitive.material, volumes_.size());
    if (inserted) {
      Volume volume;
      volume.material = primitive.material;
      volume.label = meshLabel + " in " + nodeLabel;
      const std::string nodeName =
          node.name.empty() ? "node" + std::to_string(nodeIndex) : node.name;
      const std::string meshName =
          mesh.name.empty() ? "mesh" + std::to_string(node.mesh) : mesh.name;
      volume.name = nodeName + "/" + meshName;
      volumes_.push_back(std::move(volume));
    }
    ++report_.primitives;
    if (Result<void> added =
            addPrimitive(where, primitive, world, normalMatrix, det < 0.0, volumes_[it->second]);
        !added) {
      return added;
    }
  }
  // An instance with several materials: name each volume after its material too.
  if (byMaterial.size() > 1) {
    nameAfterMaterials(byMaterial);
  }
  return {};
}

void Importer::nameAfterMaterials(const std::map<int, size_t>& byMaterial) {
  for (const auto& [material, v] : byMaterial) {
    const std::string materialName =
        material < 0 ? "default"
                     : (model_.materials[static_cast<size_t>(material)].name.empty()
                            ? "material" + std::to_string(material)
                            : model_.materials[static_cast<size_t>(material)].name);
    volumes_[v].name += "/" + materialName;
    volumes_[v].label += " with " + (material < 0 ? std::string("the default material")
                                                  : "material " + std::to_string(material));
  }
}

int attributeAccessor(const tinygltf::Primitive& primitive, const char* semantic) {
  const auto it = primitive.attributes.find(semantic);
  return it == primitive.attributes.end() ? -1 : it->second;
}

std::string describeAccessor(const std::string& where, int accessor, const char* semantic) {
  return where + " accessor " + std::to_string(accessor) + " (" + semantic + ")";
}

// A per-vertex attribute must have one element per position.
Result<void> Importer::checkPerVertex(const std::string& what, size_t count,
                                      size_t vertexCount) const {
  if (count != vertexCount) {
    return fail(ErrorCode::CorruptData, what + " has " + std::to_string(count) + " elements for " +
                                            std::to_string(vertexCount) + " positions");
  }
  return {};
}

// The primitive's per-vertex attribute `semantic` read by `read` (readVec3, readTexcoords), empty
// when it has none; one element per position or an error.
template <class T>
Result<std::vector<T>> Importer::readPerVertex(const std::string& where, const tinygltf::Primitive& primitive,
                                               const char* semantic, size_t vertexCount,
                                               Result<std::vector<T>> (Importer::*read)(int, const std::string&)
                                                   const) const {
  const int accessor = attributeAccessor(primitive, semantic);
  if (accessor < 0) {
    return std::vector<T>();
  }
  const std::string what = describeAccessor(where, accessor, semantic);
  Result<std::vector<T>> values = (this->*read)(accessor, what);
  if (!values) {
    return values.error();
  }
  if (Result<void> counted = checkPerVertex(what, values->size(), vertexCount); !counted) {
    return counted.error();
  }
  return values;
}

// The primitive's triangle corners: its indices, or every vertex in order when it has none.
Result<std::vector<uint32_t>> Importer::readTriangles(const std::string& where,
                                                      const tinygltf::Primitive& primitive,
                                                      size_t vertexCount) const {
  if (primitive.indices >= 0) {
    return readIndices(primitive.indices, describeAccessor(where, primitive.indices, "indices"),
                       vertexCount);
  }
  if (vertexCount % 3 != 0) {
    return fail(ErrorCode::CorruptData, where + " is not indexed and has " +
                                            std::to_string(vertexCount) +
                                            " vertices, not a multiple of 3");
  }
  std::vector<uint32_t> indices;
  indices.reserve(vertexCount);
  for (size_t i = 0; i < vertexCount; ++i) {
    indices.push_back(static_cast<uint32_t>(i));
  }
  return indices;
}

// Reads and checks every attribute of a TRIANGLES primitive (its own space, untransformed).
Result<PrimitiveData> Importer::readPrimitive(const std::string& where,
                                              const tinygltf::Primitive& primitive) const {
  const int positionAccessor = attributeAccessor(primitive, "POSITION");
  if (positionAccessor < 0) {
    return fail(ErrorCode::CorruptData, where + " has no POSITION attribute");
  }
  PrimitiveData data;
  Result<std::vector<glm::vec3>> positions =
      readVec3(positionAccessor, describeAccessor(where, positionAccessor, "POSITION"));
  if (!positions) {
    return positions.error();
  }
  data.positions = std::move(positions.value());
  const size_t vertexCount = data.positions.size();
  Result<std::vector<glm::vec3>> normals = readPerVertex(where, primitive, "NORMAL", vertexCount, &Importer::readVec3);
  if (!normals) {
    return normals.error();
  }
  data.normals = std::move(normals.value());
  Result<std::vector<glm::vec2>> uvs = readPerVertex(where, primitive, "TEXCOORD_0", vertexCount, &Importer::readTexcoords);
  if (!uvs) {
    return uvs.error();
  }
  data.uvs = std::move(uvs.value());
  Result<std::vector<uint32_t>> indices = readTriangles(where, primitive, vertexCount);
  if (!indices) {
    return indices.error();
  }
  data.indices = std::move(indices.value());
  return data;
}

// Appends the primitive's vertices to the volume, in world space.
Result<void> Importer::appendVertices(const std::string& where, const PrimitiveData& data,
                                      const glm::dmat4& world, const glm::dmat3& normalMatrix,
                                      Volume& volume) {
  for (size_t i = 0; i < data.positions.size(); ++i) {
    const glm::dvec3 p = glm::dvec3(world * glm::dvec4(glm::dvec3(data.positions[i]), 1.0));
    const glm::vec3 position(p);
    if (!isFinite(position)) {
      return fail(ErrorCode::InvalidArgument,
                  where + " vertex " + std::to_string(i) + " is not finite once transformed");
    }
    volume.positions.push_back(position);
    glm::vec3 normal(0.0f);
    uint8_t fromFile = 0;
    if (!data.normals.empty()) {
      const glm::dvec3 n = normalMatrix * glm::dvec3(data.normals[i]);
      const double length = glm::length(n);
      if (length > 0.0 && std::isfinite(length)) {
        normal = glm::vec3(n / length);
        fromFile = 1;
      }
    }
    volume.normals.push_back(normal);
    volume.normalFromFile.push_back(fromFile);
    volume.uvs.push_back(data.uvs.empty() ? glm::vec2(0.0f) : data.uvs[i]);
  }
  if (data.uvs.empty()) {
    volume.missingUvs = true;
  } else {
    volume.anyUvs = true;
  }
  return {};
}

// Appends the primitive's triangles, their corners offset to its vertices at `base`.
void appendTriangles(const std::vector<uint32_t>& indices, size_t base, bool mirrored,
                     Volume& volume) {
  for (size_t t = 0; t + 2 < indices.size(); t += 3) {
    uint32_t a = indices[t];
    uint32_t b = indices[t + 1];
    uint32_t c = indices[t + 2];
    if (mirrored) {
      std::swap(b, c);  // a mirroring transform turns counter-clockwise into clockwise
    }
    const uint32_t offset = static_cast<uint32_t>(base);
    volume.indices.insert(volume.indices.end(), {offset + a, offset + b, offset + c});
  }
}

Result<void> Importer::addPrimitive(const std::string& where, const tinygltf::Primitive& primitive,
                                    const glm::dmat4& world, const glm::dmat3& normalMatrix,
                                    bool mirrored, Volume& volume) {
  if (primitive.mode != TINYGLTF_MODE_TRIANGLES) {
    return fail(ErrorCode::Unsupported, where + " has mode " + std::to_string(primitive.mode) +
                                            " (" + modeName(primitive.mode) +
                                            "); only TRIANGLES (4) is supported");
  }
  if (!primitive.targets.empty()) {
    warn(where + " has morph targets; they are ignored");
  }
  Result<PrimitiveData> data = readPrimitive(where, primitive);
  if (!data) {
    return data.error();
  }
  if (data->indices.empty()) {
    warn(where + " has no triangles");
    return {};
  }

  const size_t base = volume.positions.size();
  if (data->positions.size() > std::numeric_limits<uint32_t>::max() - base) {
    return fail(ErrorCode::Unsupported, where + " brings its mesh over 2^32 vertices");
  }
  if (Result<void> appended = appendVertices(where, data.value(), world, normalMatrix, volume);
      !appended) {
    return appended;
  }
  appendTriangles(data->indices, base, mirrored, volume);
  return {};
}

void Importer::reportRepairs(const Volume& volume, const Repairs& repairs) {
  char tolerance[32];
  std::snprintf(tolerance, sizeof tolerance, "%.3g", repairs.tolerance);
  if (repairs.welded > 0) {
    warn(volume.label + ": welded " + std::to_string(repairs.welded) + " vertex(es) onto another within " +
         tolerance);
  }
  if (volume.degenerate > 0) {
    warn(volume.label + ": dropped " + std::to_string(volume.degenerate) +
         " degenerate triangle(s) (two corners at one position)");
  }
  if (repairs.duplicated > 0) {
    warn(volume.label + ": dropped " + std::to_string(repairs.duplicated) + " duplicated triangle(s)");
  }
  if (repairs.internal > 0) {
    warn(volume.label + ": dropped " + std::to_string(repairs.internal) +
         " triangle(s) in coincident pairs of opposite winding (internal walls)");
  }
}

double totalArea(const Volume& volume) {
  const size_t triangleCount = volume.indices.size() / 3;
  double area = 0.0;
  for (size_t t = 0; t < triangleCount; ++t) {
    const glm::dvec3 a(volume.positions[volume.indices[3 * t]]);
    const glm::dvec3 b(volume.positions[volume.indices[3 * t + 1]]);
    const glm::dvec3 c(volume.positions[volume.indices[3 * t + 2]]);
    area += glm::length(glm::cross(b - a, c - a));
  }
  return area;
}

// Keep only the vertices that triangles use, in the order they are first used.
void compactVertices(Volume& volume) {
  std::vector<uint32_t> remap(volume.positions.size(), std::numeric_limits<uint32_t>::max());
  Volume compact;
  for (uint32_t& index : volume.indices) {
    if (remap[index] == std::numeric_limits<uint32_t>::max()) {
      remap[index] = static_cast<uint32_t>(compact.positions.size());
      compact.positions.push_back(volume.positions[index]);
      compact.normals.push_back(volume.normals[index]);
      compact.normalFromFile.push_back(volume.normalFromFile[index]);
      compact.uvs.push_back(volume.uvs[index]);
    }
    index = remap[index];
  }
  volume.positions = std::move(compact.positions);
  volume.normals = std::move(compact.normals);
  volume.normalFromFile = std::move(compact.normalFromFile);
  volume.uvs = std::move(compact.uvs);
}

// Signed volume (divergence theorem): positive when the winding is outward.
double enclosedVolume(const Volume& volume) {
  double sum = 0.0;
  for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
    sum += glm::dot(glm::dvec3(volume.positions[volume.indices[t]]),
                    glm::cross(glm::dvec3(volume.positions[volume.indices[t + 1]]),
                               glm::dvec3(volume.positions[volume.indices[t + 2]])));
  }
  return sum / 6.0;
}

// Per vertex, the sum of its triangles' area-weighted face normals; `agreement`, the sum over
// corners with a normal from the file of that normal's dot product with its face's.
std::vector<glm::dvec3> accumulateFaceNormals(const Volume& volume, double& agreement) {
  std::vector<glm::dvec3> accumulated(volume.positions.size(), glm::dvec3(0.0));
  agreement = 0.0;
  for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
    const uint32_t ia = volume.indices[t];
    const uint32_t ib = volume.indices[t + 1];
    const uint32_t ic = volume.indices[t + 2];
    const glm::dvec3 a(volume.positions[ia]);
    const glm::dvec3 b(volume.positions[ib]);
    const glm::dvec3 c(volume.positions[ic]);
    const glm::dvec3 face = glm::cross(b - a, c - a);  // length = twice the area
    for (uint32_t i : {ia, ib, ic}) {
      accumulated[i] += face;
      if (volume.normalFromFile[i] != 0) {
        agreement += glm::dot(face, glm::dvec3(volume.normals[i]));
      }
    }
  }
  return accumulated;
}

Result<void> Importer::finalize(Volume& volume) {
  reportRepairs(volume, repairVolume(volume));
  if (!(totalArea(volume) > 0.0)) {
    return fail(ErrorCode::InvalidArgument,
                volume.label + " has zero area (" +
                    std::to_string(volume.indices.size() / 3 + volume.degenerate) +
                    " triangles, all degenerate)");
  }
  compactVertices(volume);
  if (auto closed = checkClosed(volume); !closed) {
    return closed.error();
  }
  orientOutward(volume);
  settleNormals(volume);

  if (!volume.anyUvs) {
    volume.uvs.clear();
  } else if (volume.missingUvs) {
    warn(volume.label + ": some primitives have no TEXCOORD_0; their uvs are (0, 0)");
  }

  volume.boundsMin = glm::dvec3(volume.positions.front());
  volume.boundsMax = volume.boundsMin;
  for (const glm::vec3& p : volume.positions) {
    volume.boundsMin = glm::min(volume.boundsMin, glm::dvec3(p));
    volume.boundsMax = glm::max(volume.boundsMax, glm::dvec3(p));
  }
  return {};
}

// Topology, with the winding as read (after mirroring): an open volume fails unless allowed.
Result<void> Importer::checkClosed(Volume& volume) {
  Surface probe;
  probe.positions = volume.positions;
  probe.indices = volume.indices;
  const TopologyReport topology = checkSurface(probe);
  volume.closed = topology.closed();
  if (!volume.closed) {
    const std::string problem =
        volume.label + " is not a closed, consistently wound volume: " +
        std::to_string(topology.openEdges) + " open, " +
        std::to_string(topology.inconsistentEdges) + " inconsistently wound and " +
        std::to_string(topology.nonManifoldEdges) + " non-manifold edge(s)";
    if (!options_.allowOpenMeshes) {
      return fail(ErrorCode::InvalidArgument,
                  problem + " after the repairs (allowOpenMeshes, the tool's --allow-open, accepts it)");
    }
    warn(problem + "; kept as is");
  }
  return {};
}

// A closed volume that is inside out is turned outward.
void Importer::orientOutward(Volume& volume) {
  volume.volume = enclosedVolume(volume);
  if (volume.closed && volume.volume < 0.0) {
    for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
      std::swap(volume.indices[t + 1], volume.indices[t + 2]);
    }
    volume.volume = -volume.volume;
    warn(volume.label + " is wound inside out (clockwise seen from outside); winding reversed");
  }
}

// Area-weighted face normals: computed normals for vertices without a usable one, and the
// check that the file's normals agree with the (now outward) winding.
void Importer::settleNormals(Volume& volume) {
  double agreement = 0.0;
  const std::vector<glm::dvec3> accumulated = accumulateFaceNormals(volume, agreement);
  if (agreement < 0.0) {
    for (size_t i = 0; i < volume.normals.size(); ++i) {
      if (volume.normalFromFile[i] != 0) {
        volume.normals[i] = -volume.normals[i];
      }
    }
    warn(volume.label + ": its normals point against its winding; normals reversed");
  }
  size_t fallback = 0;
  for (size_t i = 0; i < volume.normals.size(); ++i) {
    if (volume.normalFromFile[i] != 0) {
      continue;
    }
    ++volume.computedNormals;
    const double length = glm::length(accumulated[i]);
    if (length > 0.0) {
      volume.normals[i] = glm::vec3(accumulated[i] / length);
    } else {
      volume.normals[i] = glm::vec3(0.0f, 0.0f, 1.0f);  // only on zero-area triangles
      ++fallback;
    }
  }
  if (volume.computedNormals > 0) {
    warn(volume.label + ": no usable NORMAL for " + std::to_string(volume.computedNormals) +
         " vertex(es); area-weighted smooth normals computed" +
         (fallback > 0 ? " (" + std::to_string(fallback) + " on zero-area triangles only)"
                       : std::string()));
  }
}

// Reads an optional number from an extension object; absent keeps `value`.
void readNumber(const tinygltf::Value& object, const char* key, double& value, std::string& bad) {
  if (!object.IsObject() || !object.Has(key)) {
    return;
  }
  const tinygltf::Value& v = object.Get(key);
  if (!v.IsNumber() || !std::isfinite(v.GetNumberAsDouble())) {
    bad = key;
    return;
  }
  value = v.GetNumberAsDouble();
}

const tinygltf::Value* findExtension(const tinygltf::Material& material, const char* name) {
  const auto it = material.extensions.find(name);
  return it == material.extensions.end() ? nullptr : &it->second;
}

// KHR_materials_volume's attenuationColor, when present: three finite numbers.
void readAttenuationColor(const tinygltf::Value& ext, MaterialVolume& out) {
  if (!ext.IsObject() || !ext.Has("attenuationColor")) {
    return;
  }
  const tinygltf::Value& c = ext.Get("attenuationColor");
  bool valid = c.IsArray() && c.ArrayLen() == 3;
  for (int k = 0; valid && k < 3; ++k) {
    valid = c.Get(k).IsNumber() && std::isfinite(c.Get(k).GetNumberAsDouble());
    if (valid) {
      out.color[k] = c.Get(k).GetNumberAsDouble();
    }
  }
  if (!valid) {
    out.bad = "attenuationColor";
  }
}

MaterialVolume readMaterialVolume(const tinygltf::Material& material) {
  MaterialVolume out;
  if (const tinygltf::Value* ext = findExtension(material, "KHR_materials_ior")) {
    readNumber(*ext, "ior", out.ior, out.bad);
  }
  if (const tinygltf::Value* ext = findExtension(material, "KHR_materials_transmission")) {
    readNumber(*ext, "transmissionFactor", out.transmission, out.bad);
  }
  if (const tinygltf::Value* ext = findExtension(material, "KHR_materials_volume")) {
    readNumber(*ext, "thicknessFactor", out.thickness, out.bad);
    readNumber(*ext, "attenuationDistance", out.distance, out.bad);
    readAttenuationColor(*ext, out);
  }
  return out;
}

Result<void> Importer::checkMaterialVolume(const std::string& what, const MaterialVolume& m) const {
  if (!m.bad.empty()) {
    return fail(ErrorCode::CorruptData, what + " has a malformed " + m.bad);
  }
  if (!(m.ior > 0.0) && !options_.iorOverride) {
    return fail(ErrorCode::InvalidArgument,
                what + " has ior " + std::to_string(m.ior) + ", not a refractive medium");
  }
  if (!(m.distance > 0.0)) {
    return fail(ErrorCode::CorruptData,
                what + " has attenuationDistance " + std::to_string(m.distance) + " (must be > 0)");
  }
  if (glm::any(glm::lessThan(m.color, glm::dvec3(0.0))) ||
      glm::any(glm::greaterThan(m.color, glm::dvec3(1.0)))) {
    return fail(ErrorCode::CorruptData, what + " has an attenuationColor outside [0, 1]");
  }
  if (m.thickness < 0.0 || m.transmission < 0.0) {
    return fail(ErrorCode::CorruptData,
                what + " has a negative thicknessFactor or transmissionFactor");
  }
  return {};
}

// The medium's absorption and tint from a finite attenuationDistance.
void applyAttenuation(double distance, const glm::dvec3& color, Medium& medium) {
  double sigma = 0.0;
  for (int k = 0; k < 3; ++k) {
    sigma += -std::log(std::max(color[k], kMinAttenuationColor)) / distance;
  }
  // Grey attenuation goes into tau (mean of the channel coefficients); the tint keeps only the
  // hue, brightest channel 1, so that grey is not counted twice and the tint never brightens.
  medium.absorption = static_cast<float>(sigma / 3.0);
  const double brightest = std::max({color.x, color.y, color.z, kMinAttenuationColor});
  medium.color = glm::vec3(glm::max(color, glm::dvec3(kMinAttenuationColor)) / brightest);
}

Result<Medium> Importer::mediumOf(int materialIndex) {
  Medium medium;
  medium.ior = kDefaultIor;
  if (materialIndex < 0) {
    medium.name = "default";
    warn("primitives without a material are imported as clear glass (ior 1.5)");
    return medium;
  }
  const tinygltf::Material& material = model_.materials[static_cast<size_t>(materialIndex)];
  const std::string what = "material " + std::to_string(materialIndex) + quoted(material.name);
  medium.name = material.name.empty() ? "material" + std::to_string(materialIndex) : material.name;

  const MaterialVolume m = readMaterialVolume(material);
  if (Result<void> valid = checkMaterialVolume(what, m); !valid) {
    return valid.error();
  }
  medium.ior = static_cast<float>(m.ior);
  if (std::isfinite(m.distance)) {
    applyAttenuation(m.distance, m.color, medium);
  }
  if (m.transmission <= 0.0 && m.thickness <= 0.0) {
    warn(what + " is neither transmissive nor a volume; imported as a clear medium of ior " +
         std::to_string(medium.ior) + " anyway");
  } else if (m.thickness <= 0.0) {
    warn(what + " is thin-walled (no KHR_materials_volume thickness); imported as a solid volume");
  }
  return medium;
}

// A point inside `volume`: halfway between its largest triangle and the opposite wall, found by a
// ray from that triangle's centroid against the inward normal.
glm::dvec3 Importer::interiorPoint(const Volume& volume) const {
  size_t best = 0;
  double bestArea = -1.0;
  for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
    const glm::dvec3 a(volume.positions[volume.indices[t]]);
    const glm::dvec3 b(volume.positions[volume.indices[t + 1]]);
    const glm::dvec3 c(volume.positions[volume.indices[t + 2]]);
    const double area = glm::length(glm::cross(b - a, c - a));
    if (area > bestArea) {
      bestArea = area;
      best = t;
    }
  }
  const glm::dvec3 a(volume.positions[volume.indices[best]]);
  const glm::dvec3 b(volume.positions[volume.indices[best + 1]]);
  const glm::dvec3 c(volume.positions[volume.indices[best + 2]]);
  const glm::dvec3 centroid = (a + b + c) / 3.0;
  const glm::dvec3 inward = -glm::normalize(glm::cross(b - a, c - a));
  double nearest = std::numeric_limits<double>::infinity();
  for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
    if (t == best) {
      continue;
    }
    const double hit = intersect(centroid, inward, glm::dvec3(volume.positions[volume.indices[t]]),
                                 glm::dvec3(volume.positions[volume.indices[t + 1]]),
                                 glm::dvec3(volume.positions[volume.indices[t + 2]]));
    if (hit > 0.0 && hit < nearest) {
      nearest = hit;
    }
  }
  if (!std::isfinite(nearest)) {
    nearest = 2.0 * kInteriorOffset * glm::length(volume.boundsMax - volume.boundsMin);
  }
  return centroid + inward * (0.5 * nearest);
}

// Ray parity against a closed volume, majority over three directions.
bool Importer::contains(const Volume& container, const glm::dvec3& point) const {
  if (glm::any(glm::lessThan(point, container.boundsMin)) ||
      glm::any(glm::greaterThan(point, container.boundsMax))) {
    return false;
  }
  int votes = 0;
  for (const glm::dvec3& direction : kParityDirections) {
    size_t crossings = 0;
    for (size_t t = 0; t + 2 < container.indices.size(); t += 3) {
      const double hit =
          intersect(point, direction, glm::dvec3(container.positions[container.indices[t]]),
                    glm::dvec3(container.positions[container.indices[t + 1]]),
                    glm::dvec3(container.positions[container.indices[t + 2]]));
      if (hit > 0.0) {
        ++crossings;
      }
    }
    votes += static_cast<int>(crossings % 2);
  }
  return votes >= 2;
}

// How many of up to kOverlapProbes vertices of `probed` (each pulled slightly toward its centre)
// lie inside the closed volume `container`.
std::pair<size_t, size_t> Importer::probesInside(const Volume& probed, const Volume& container) const {
  const size_t n = probed.positions.size();
  const size_t step = std::max<size_t>(1, (n + kOverlapProbes - 1) / kOverlapProbes);
  const glm::dvec3 centre = 0.5 * (probed.boundsMin + probed.boundsMax);
  const double inset = kOverlapInset * glm::length(probed.boundsMax - probed.boundsMin);
  size_t inside = 0;
  size_t tested = 0;
  for (size_t i = 0; i < n; i += step, ++tested) {
    const glm::dvec3 p(probed.positions[i]);
    const glm::dvec3 toCentre = centre - p;
    const double length = glm::length(toCentre);
    const glm::dvec3 probe = length > inset ? p + toCentre * (inset / length) : centre;
    inside += contains(container, probe) ? 1 : 0;
  }
  return {inside, tested};
}

// Pairs (u < v) of closed volumes that overlap (neither inside the other, nor apart), each named
// in a warning. Overlapping volumes are siblings: neither is the other's container, and the
// tracer takes each crossed surface's media as labelled (docs/scenes.md, "Overlapping volumes").
// Detected when a probe vertex of one lies inside the other; volumes that cross without a vertex
// inside the other (two long bars in a cross) are not detected.
std::set<std::pair<size_t, size_t>> Importer::findOverlaps() {
  std::set<std::pair<size_t, size_t>> overlaps;
  for (size_t u = 0; u < volumes_.size(); ++u) {
    for (size_t v = u + 1; v < volumes_.size(); ++v) {
      const Volume& a = volumes_[u];
      const Volume& b = volumes_[v];
      if (!a.closed || !b.closed || glm::any(glm::lessThan(a.boundsMax, b.boundsMin)) ||
          glm::any(glm::lessThan(b.boundsMax, a.boundsMin))) {
        continue;
      }
      const auto [aInB, aProbes] = probesInside(a, b);
      const auto [bInA, bProbes] = probesInside(b, a);
      const bool apart = aInB == 0 && bInA == 0;
      const bool aNested = aInB >= aProbes && bInA == 0;
      const bool bNested = bInA >= bProbes && aInB == 0;
      if (apart || aNested || bNested) {
        continue;
      }
      overlaps.emplace(u, v);
      warn(a.label + " and " + b.label +
           " overlap (neither contains the other); in the overlap a path is in the medium of the "
           "volume whose surface it crossed last (docs/scenes.md)");
    }
  }
  return overlaps;
}

Result<void> Importer::checkOverrides() const {
  if (options_.iorOverride &&
      (!std::isfinite(*options_.iorOverride) || *options_.iorOverride <= 0.0f)) {
    return fail(ErrorCode::InvalidArgument,
                "iorOverride " + std::to_string(*options_.iorOverride) + " is not finite and > 0");
  }
  if (options_.absorptionOverride &&
      (!std::isfinite(*options_.absorptionOverride) || *options_.absorptionOverride < 0.0f)) {
    return fail(ErrorCode::InvalidArgument, "absorptionOverride " +
                                                std::to_string(*options_.absorptionOverride) +
                                                " is not finite and >= 0");
  }
  return {};
}

// Walks the default scene into volumes_, each with its triangles.
Result<void> Importer::collectVolumes() {
  if (model_.scenes.empty()) {
    return fail(ErrorCode::InvalidArgument, "no scene: the file defines no scenes");
  }
  const int sceneIndex = model_.defaultScene >= 0 ? model_.defaultScene : 0;
  if (static_cast<size_t>(sceneIndex) >= model_.scenes.size()) {
    return fail(ErrorCode::CorruptData, "default scene " + std::to_string(sceneIndex) +
                                            " does not exist (" +
                                            std::to_string(model_.scenes.size()) + " scenes)");
  }
  std::vector<uint8_t> onPath(model_.nodes.size(), 0);
  for (int root : model_.scenes[static_cast<size_t>(sceneIndex)].nodes) {
    if (Result<void> visited = visitNode(root, glm::dmat4(1.0), onPath, 0); !visited) {
      return visited.error();
    }
  }
  // Volumes whose primitives were all empty carry no triangles and no dropped ones: skip them.
  std::erase_if(volumes_,
                [](const Volume& v) { return v.indices.empty() && v.degenerate == 0; });
  if (volumes_.empty()) {
    return fail(ErrorCode::InvalidArgument,
                "empty scene: scene " + std::to_string(sceneIndex) + " has no triangles");
  }
  return {};
}

// One medium per material used (in the order the volumes first use them), after air, with the
// overrides applied; each volume's medium set.
Result<void> Importer::assignMedia(Scene& scene) {
  std::map<int, uint32_t> mediumOfMaterial;
  for (Volume& volume : volumes_) {
    auto [it, inserted] =
        mediumOfMaterial.try_emplace(volume.material, static_cast<uint32_t>(scene.media.size()));
    if (inserted) {
      Result<Medium> medium = mediumOf(volume.material);
      if (!medium) {
        return medium.error();
      }
      scene.media.push_back(std::move(medium.value()));
    }
    volume.medium = it->second;
  }
  for (size_t m = 1; m < scene.media.size(); ++m) {
    if (options_.iorOverride) {
      scene.media[m].ior = *options_.iorOverride;
    }
    if (options_.absorptionOverride) {
      scene.media[m].absorption = *options_.absorptionOverride;
    }
  }
  return {};
}

// The medium stack: each volume's outside is the innermost other closed volume containing it.
// Returns volumes_.size() for a volume that none contains.
size_t Importer::innermostContainer(size_t v,
                                    const std::set<std::pair<size_t, size_t>>& overlaps) const {
  const glm::dvec3 point = interiorPoint(volumes_[v]);
  size_t container = volumes_.size();
  for (size_t u = 0; u < volumes_.size(); ++u) {
    const bool sibling = overlaps.count({std::min(u, v), std::max(u, v)}) != 0;
    if (u == v || sibling || !volumes_[u].closed || !contains(volumes_[u], point)) {
      continue;
    }
    if (container == volumes_.size() ||
        std::fabs(volumes_[u].volume) < std::fabs(volumes_[container].volume)) {
      container = u;
    }
  }
  return container;
}

// One Surface per volume, between its medium and its container's (air when none contains it).
Result<void> Importer::addSurfaces(Scene& scene,
                                   const std::set<std::pair<size_t, size_t>>& overlaps) {
  for (size_t v = 0; v < volumes_.size(); ++v) {
    const size_t container = innermostContainer(v, overlaps);
    Surface surface;
    surface.name = volumes_[v].name;
    surface.innerMedium = volumes_[v].medium;
    surface.outerMedium = container == volumes_.size() ? 0 : volumes_[container].medium;
    if (surface.outerMedium == surface.innerMedium) {
      return fail(ErrorCode::InvalidArgument,
                  volumes_[v].label + " lies inside " + volumes_[container].label +
                      ", which has the same medium ('" + scene.media[surface.innerMedium].name +
                      "'); nested volumes need different materials");
    }
    // Copies: later volumes still test containment against this one.
    surface.positions = volumes_[v].positions;
    surface.normals = volumes_[v].normals;
    surface.uvs = volumes_[v].uvs;
    surface.indices = volumes_[v].indices;
    report_.triangles += surface.indices.size() / 3;
    scene.surfaces.push_back(std::move(surface));
  }
  return {};
}

Result<Scene> Importer::run() {
  if (Result<void> valid = checkOverrides(); !valid) {
    return valid.error();
  }
  if (Result<void> loaded = load(); !loaded) {
    return loaded.error();
  }
  if (Result<void> collected = collectVolumes(); !collected) {
    return collected.error();
  }
  for (Volume& volume : volumes_) {
    if (Result<void> finalized = finalize(volume); !finalized) {
      return finalized.error();
    }
  }
  const std::set<std::pair<size_t, size_t>> overlaps = findOverlaps();

  Scene scene;
  scene.name = std::filesystem::path(path_).stem().string();
  scene.media.push_back(Medium{"air", 1.0f, 0.0f, glm::vec3(1.0f)});
  if (Result<void> assigned = assignMedia(scene); !assigned) {
    return assigned.error();
  }
  if (Result<void> added = addSurfaces(scene, overlaps); !added) {
    return added.error();
  }
  if (Result<void> valid = validateScene(scene); !valid) {
    return fail(valid.error().code, valid.error().message);
  }
  return scene;
}

}  // namespace

Result<Scene> importGltf(const std::string& path, const ImportOptions& options,
                         ImportReport* report) {
  ImportReport local;
  ImportReport& out = report != nullptr ? *report : local;
  out = ImportReport{};
  Importer importer(path, options, out);
  return importer.run();
}

}  // namespace shrefract::bake
