// Object: a static mesh placed by its worldFromObject, its lifetime and instances (the field's
// upload: field_object.cpp).
#include <shrefract/object.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/context_impl.h"
#include "object/object_impl.h"
#include "shrefract/gpu_layout.h"

namespace shrefract {

using Vec3 = std::array<float, 3>;

void worldBounds(const Object& object, Vec3& min, Vec3& max) {
  const ObjectImpl& o = ObjectAccess::impl(object);
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 p{(corner & 1) ? o.boundsMax[0] : o.boundsMin[0], (corner & 2) ? o.boundsMax[1] : o.boundsMin[1],
                 (corner & 4) ? o.boundsMax[2] : o.boundsMin[2]};
    const Vec3 w = transformPoint(object.worldFromObject, p);
    for (int k = 0; k < 3; ++k) {
      min[k] = corner == 0 ? w[k] : std::min(min[k], w[k]);
      max[k] = corner == 0 ? w[k] : std::max(max[k], w[k]);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Lifetime.

Object::Object(std::shared_ptr<ObjectImpl> impl) : impl_(std::move(impl)) {}

Object::~Object() {
  // What this object allocated goes once the frames that may use it are done; the mesh and field
  // data an original shares with instances go with the last ObjectImpl (~ObjectImpl).
  std::shared_ptr<ObjectImpl> o = std::move(impl_);
  ContextImpl* c = o->context;
  c->retire([o]() mutable {
    if (o->field) destroyFieldInstance(*o->context, *o->field);
    o.reset();
  });
}

ObjectImpl::~ObjectImpl() {
  if (source || !context) return;  // an instance's mesh and field data are its source's
  context->destroyBuffer(vertices);
  context->destroyBuffer(indices);
  context->destroyBuffer(triangleEdges);
  context->destroyBlock(meshBlock);
  if (field) destroyFieldShared(*context, *field);
}

void countMemory(ObjectImpl& object, const MemoryBlock& block) { object.gpuMemoryBytes += block.memoryBytes; }
void countMemory(ObjectImpl& object, const ImageAllocation& image) { object.gpuMemoryBytes += image.memoryBytes; }

std::array<float, 3> Object::boundsMin() const {
  Vec3 min{}, max{};
  worldBounds(*this, min, max);
  return min;
}
std::array<float, 3> Object::boundsMax() const {
  Vec3 min{}, max{};
  worldBounds(*this, min, max);
  return max;
}
std::array<float, 3> Object::objectBoundsMin() const { return impl_->boundsMin; }
std::array<float, 3> Object::objectBoundsMax() const { return impl_->boundsMax; }
uint64_t Object::gpuMemoryBytes() const { return impl_->gpuMemoryBytes; }
void Object::invalidateDistortion() {
  if (impl_->field) impl_->field->decoded = false;
}

// ---------------------------------------------------------------------------------------------
// Creation.

namespace {

// The index buffer with each triangle's corners turned (its winding kept) so that its first corner,
// the provoking vertex whose flat attributes the fragment reads, starts no other triangle; where
// all three already do, a copy of the first corner is appended (copyOf: the vertex each appended
// vertex copies). triangleOf[v]: the triangle vertex v starts (0 where it starts none).
struct ProvokingVertices {
  std::vector<uint32_t> indices, copyOf, triangleOf;
};

ProvokingVertices assignProvokingVertices(const uint32_t* indices, uint32_t indexCount, uint32_t vertexCount) {
  ProvokingVertices out;
  out.indices.assign(indices, indices + indexCount);
  out.triangleOf.assign(vertexCount, 0u);
  std::vector<bool> starts(vertexCount, false);
  for (uint32_t t = 0; 3 * t < indexCount; ++t) {
    uint32_t* corner = &out.indices[3 * size_t(t)];
    int startable = -1;
    for (int k = 0; k < 3 && startable < 0; ++k)
      if (!starts[corner[k]]) startable = k;
    if (startable > 0) std::rotate(corner, corner + startable, corner + 3);
    if (startable < 0) {  // a copy of the first corner
      out.copyOf.push_back(corner[0]);
      corner[0] = static_cast<uint32_t>(starts.size());
      starts.push_back(false);
      out.triangleOf.push_back(0u);
    }
    starts[corner[0]] = true;
    out.triangleOf[corner[0]] = t;
  }
  return out;
}

// The interleaved vertices (kVertexFloats words each) of `mesh` in the order of `provoking`'s
// vertices (a copy reads its source's attributes), each with the triangle it starts; an error names
// the first vertex that is not finite or has a frontIor that is not positive.
Result<std::vector<float>> interleaveVertices(const MeshDesc& mesh, const ProvokingVertices& provoking) {
  const size_t vertexCount = provoking.triangleOf.size();
  std::vector<float> interleaved(vertexCount * kVertexFloats);
  for (size_t v = 0; v < vertexCount; ++v) {
    const uint32_t from = v < mesh.vertexCount ? uint32_t(v) : provoking.copyOf[v - mesh.vertexCount];
    float* out = &interleaved[v * kVertexFloats];
    for (int k = 0; k < 3; ++k) out[k] = mesh.positions[3 * from + uint32_t(k)];
    for (int k = 0; k < 3; ++k) out[3 + k] = mesh.normals[3 * from + uint32_t(k)];
    out[6] = mesh.fieldUvs ? mesh.fieldUvs[2 * from] : 0.0f;
    out[7] = mesh.fieldUvs ? mesh.fieldUvs[2 * from + 1] : 0.0f;
    out[8] = mesh.frontIor ? mesh.frontIor[from] : 0.0f;
    std::memcpy(&out[kVertexTriangleWord], &provoking.triangleOf[v], sizeof(uint32_t));
    for (uint32_t k = 0; k < kVertexTriangleWord; ++k)
      if (!std::isfinite(out[k]))
        return makeError(ErrorCode::InvalidArgument, "Object::create: vertex " + std::to_string(from) + " is not finite");
    if (mesh.frontIor && !(out[8] > 0.0f))
      return makeError(ErrorCode::InvalidArgument,
                       "Object::create: frontIor of vertex " + std::to_string(from) + " is not positive");
  }
  return interleaved;
}

}  // namespace

Result<void> createMeshBuffers(ContextImpl& c, const MeshDesc& mesh, VkCommandBuffer cmd, ObjectImpl& o) {
  if (!mesh.positions || !mesh.normals || !mesh.indices || mesh.vertexCount == 0 || mesh.indexCount == 0 ||
      mesh.indexCount % 3 != 0)
    return makeError(ErrorCode::InvalidArgument, "Object::create: a mesh needs positions, normals and a triangle list");
  for (uint32_t i = 0; i < mesh.indexCount; ++i)
    if (mesh.indices[i] >= mesh.vertexCount)
      return makeError(ErrorCode::InvalidArgument, "Object::create: index " + std::to_string(i) + " is out of range");
  const ProvokingVertices provoking = assignProvokingVertices(mesh.indices, mesh.indexCount, mesh.vertexCount);
  auto vertices = interleaveVertices(mesh, provoking);
  if (!vertices) return vertices.error();
  const std::vector<float>& interleaved = vertices.value();
  const std::vector<TriangleEdges> edges =
      triangleEdges(mesh.positions, mesh.vertexCount, mesh.indices, mesh.indexCount);
  static_assert(sizeof(TriangleEdges) == sizeof(gpu::TriangleEdges));
  o.indexCount = mesh.indexCount;
  for (uint32_t v = 0; v < mesh.vertexCount; ++v)
    for (int k = 0; k < 3; ++k) {
      const float p = mesh.positions[3 * v + k];
      o.boundsMin[k] = v == 0 ? p : std::min(o.boundsMin[k], p);
      o.boundsMax[k] = v == 0 ? p : std::max(o.boundsMax[k], p);
    }
  const VkDeviceSize vbytes = interleaved.size() * sizeof(float);
  const VkDeviceSize ibytes = VkDeviceSize(mesh.indexCount) * sizeof(uint32_t);
  const VkDeviceSize ebytes = edges.size() * sizeof(TriangleEdges);
  auto vb = c.createUnboundBuffer(vbytes, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  if (!vb) return vb.error();
  o.vertices = vb.value();
  auto ib = c.createUnboundBuffer(ibytes, VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  if (!ib) return ib.error();
  o.indices = ib.value();
  auto eb = c.createUnboundBuffer(ebytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  if (!eb) return eb.error();
  o.triangleEdges = eb.value();
  auto block = c.bindBlock({&o.vertices, &o.indices, &o.triangleEdges});
  if (!block) return block.error();
  o.meshBlock = block.value();
  countMemory(o, o.meshBlock);
  if (auto r = c.recordBufferUpload(cmd, o.vertices.buffer, interleaved.data(), vbytes); !r) return r.error();
  if (auto r = c.recordBufferUpload(cmd, o.indices.buffer, provoking.indices.data(), ibytes); !r) return r.error();
  if (auto r = c.recordBufferUpload(cmd, o.triangleEdges.buffer, edges.data(), ebytes); !r) return r.error();
  VkMemoryBarrier2 barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  barrier.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  barrier.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  barrier.dstStageMask =
      VK_PIPELINE_STAGE_2_VERTEX_INPUT_BIT | VK_PIPELINE_STAGE_2_INDEX_INPUT_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  barrier.dstAccessMask =
      VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_2_INDEX_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
  VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  dep.memoryBarrierCount = 1;
  dep.pMemoryBarriers = &barrier;
  c.vk.vkCmdPipelineBarrier2(cmd, &dep);
  return {};
}

Result<std::unique_ptr<Object>> Object::create(Context& context, const MeshDesc& mesh, VkCommandBuffer cmd) {
  ContextImpl& c = ContextAccess::impl(context);
  auto impl = std::make_shared<ObjectImpl>();
  impl->context = &c;
  // From here on the object's destructor retires whatever has been created (`cmd` may reference it).
  auto object = ObjectAccess::wrap(impl);
  if (auto r = createMeshBuffers(c, mesh, cmd, *impl); !r) return r.error();
  return object;
}

Result<std::unique_ptr<Object>> Object::createInstance(Context& context, const Object& of, VkCommandBuffer cmd) {
  ContextImpl& c = ContextAccess::impl(context);
  const std::shared_ptr<ObjectImpl>& from = of.impl_;
  if (from->context != &c)
    return makeError(ErrorCode::InvalidArgument, "Object::createInstance: the source belongs to another context");
  std::shared_ptr<const ObjectImpl> source = from->source ? from->source : from;
  auto impl = std::make_shared<ObjectImpl>();
  impl->context = &c;
  impl->source = source;
  impl->vertices = source->vertices;
  impl->indices = source->indices;
  impl->triangleEdges = source->triangleEdges;
  impl->indexCount = source->indexCount;
  impl->boundsMin = source->boundsMin;
  impl->boundsMax = source->boundsMax;
  auto object = ObjectAccess::wrap(impl);
  object->worldFromObject = of.worldFromObject;
  object->shading = of.shading;
  if (source->field) {
    // The shared handles, without the source's own image, pool and sets.
    impl->field = std::make_unique<FieldResources>(*source->field);
    FieldResources& f = *impl->field;
    f.distortion = {};
    f.pool = VK_NULL_HANDLE;
    f.decompressSet = f.distortionSet = VK_NULL_HANDLE;
    f.decoded = false;
    if (auto r = createFieldInstance(c, *impl, cmd); !r) return r.error();
  }
  return object;
}

}  // namespace shrefract
