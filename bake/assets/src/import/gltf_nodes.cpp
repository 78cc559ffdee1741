// glTF import: the node hierarchy walked, its transforms composed, and each mesh instance's
// primitives gathered into world-space volumes, one per material.
#include "import/gltf_importer.h"

namespace shrefract::bake::gltf_detail {
namespace {

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

}  // namespace

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

}  // namespace shrefract::bake::gltf_detail
