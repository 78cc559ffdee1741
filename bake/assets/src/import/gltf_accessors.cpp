// glTF import: accessors and primitives as read and checked (every index, count and value).
#include "import/gltf_importer.h"

namespace shrefract::bake::gltf_detail {
namespace {

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

template <class T>
T readScalar(const unsigned char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

int attributeAccessor(const tinygltf::Primitive& primitive, const char* semantic) {
  const auto it = primitive.attributes.find(semantic);
  return it == primitive.attributes.end() ? -1 : it->second;
}

std::string describeAccessor(const std::string& where, int accessor, const char* semantic) {
  return where + " accessor " + std::to_string(accessor) + " (" + semantic + ")";
}

}  // namespace

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
  out.type = accessor.type;
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
  if (view->type != TINYGLTF_TYPE_VEC3 || view->componentType != TINYGLTF_COMPONENT_TYPE_FLOAT) {
    return fail(ErrorCode::Unsupported, what + " must be FLOAT VEC3 (component type " +
                                            std::to_string(view->componentType) + ", type " +
                                            std::to_string(view->type) + ")");
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
  const int type = view->componentType;
  const bool supported =
      view->type == TINYGLTF_TYPE_VEC2 &&
      (type == TINYGLTF_COMPONENT_TYPE_FLOAT ||
       (view->normalized && (type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
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
  const int type = view->componentType;
  if (view->type != TINYGLTF_TYPE_SCALAR ||
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

}  // namespace shrefract::bake::gltf_detail
