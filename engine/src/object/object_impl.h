// Private side of Object: the mesh buffers and, for objects created from a field, the field's GPU
// data and distortion image (shared by the raster pass and the decompression pass). An instance
// (Object::createInstance) holds copies of its source's handles and keeps the source's ObjectImpl
// alive; only the distortion image, its descriptor pool and sets are its own.
#pragma once

#include <shrefract/object.h>

#include <array>
#include <memory>

#include "core/context_impl.h"

namespace shrefract {

// Interleaved vertex: position (3), normal (3), field uv (2), frontIor (1; 0 = ObjectShading::ior),
// and the index of the triangle whose first corner it is (uint32 bits; gpu_layout.h
// kBindingTriangleEdges), so 10 words.
inline constexpr uint32_t kVertexFloats = 10;
inline constexpr uint32_t kVertexTriangleWord = 9;

// GPU layouts of the buffers: spirv/include/shrefract/gpu_layout.h (decompression bindings).
// Shared by instances: everything but the "per instance" members.
struct FieldResources {
  uint32_t width = 0, height = 0;
  Encoding encoding = Encoding::Sh;  // picks the decompression shader (Sh, or Table and Pca)
  uint32_t order = 0;                // Sh: the order decoded (per instance, <= bakedOrder)
  uint32_t bakedOrder = 0;           // Sh: the order stored
  uint32_t tableSize = 0;            // Table, Pca
  uint32_t components = 0;           // Pca
  bool jumpAware = false;            // Table, Pca: EncodingShape::jumpAware
  bool jumpDistance = false;         // Table, Pca: EncodingShape::jumpDistance (the last channel)
  bool sampleFrameExits = false;     // EncodingShape::sampleFrameExits
  bool clustered = false;            // Pca: EncodingShape::clustered (one index per sample)
  uint32_t channels = 4;
  bool throughput = false;           // the last channel is the throughput (raster: tint.a)
  // Per instance: Volume fields only, the raster pass traces each fragment's path through the grid
  // and the Decompressor leaves the object out (Object::setTracesVolumePerFragment).
  bool volumePerFragment = false;
  Quantization quantization = Quantization::U8;
  uint32_t sampleCount = 0;
  bool scaleBiasStorage = false;     // Sh: the scale/bias table exceeds kMaxUniformScaleBiasBytes
  bool coefficientsStorage = false;  // the coefficients exceed the device's maxTexelBufferElements
  uint32_t gutterCount = 0;
  VkDeviceSize coefficientBytes = 0;  // size of `coefficients` (descriptor ranges)
  MemoryBlock block;              // the memory of the buffers below (one allocation)
  BufferAllocation coefficients;  // Sh: channel planes; Table, Pca: sample-major (gpu_layout.h)
  VkBufferView coefficientWords = VK_NULL_HANDLE;  // R32_UINT texel view of `coefficients`
  VkBufferView volumeWords = VK_NULL_HANDLE;  // Volume: R32_UINT texel view of `basis` (the raster pass's grid)
  ImageAllocation distortion;     // per instance: RGBA16F, written by the decompression pass
  ImageAllocation jump;           // per instance: R32F, the eye's distance from each texel's table jump
  BufferAllocation scaleBias;     // Sh: vec4s per basis function; Table, Pca: vec2 per (layer, value)
  BufferAllocation basis;         // Pca: the basis functions as floats (a placeholder otherwise)
  BufferAllocation frames;        // 3 vec4 per sample
  BufferAllocation sampleTexels;  // texel index per sample
  BufferAllocation gutters;       // uvec4 per rule (at least one entry, unused when gutterCount = 0)
  VkSampler sampler = VK_NULL_HANDLE;  // bilinear, clamp to edge (the raster pass's distortion lookups)
  // Identical in definition to the Decompressor's and Renderer's layouts (hence compatible).
  VkDescriptorSetLayout decompressSetLayout = VK_NULL_HANDLE;
  VkDescriptorSetLayout distortionSetLayout = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;          // per instance, as are its two sets
  VkDescriptorSet decompressSet = VK_NULL_HANDLE;
  VkDescriptorSet distortionSet = VK_NULL_HANDLE;

  // Per instance: what the distortion image holds (Decompressor::record skips an object whose image
  // already holds the decompression for the same object-space eye and order). Unset until the
  // first decompression is recorded, and after Object::invalidateDistortion().
  bool decoded = false;
  std::array<float, 3> decodedEye{};
  uint32_t decodedOrder = 0;
};

struct ObjectImpl {
  ContextImpl* context = nullptr;
  // An instance: the object whose mesh and field data it uses (null for an original). Kept alive
  // until the instance is released, so the shared data goes with the last of them.
  std::shared_ptr<const ObjectImpl> source;
  BufferAllocation vertices;
  BufferAllocation indices;
  BufferAllocation triangleEdges;  // TriangleEdges per triangle (the field pass's silhouette coverage)
  MemoryBlock meshBlock;  // the memory of vertices, indices and triangle edges (one allocation)
  uint32_t indexCount = 0;
  // Object-space axis-aligned bounds of the mesh's vertices.
  std::array<float, 3> boundsMin{};
  std::array<float, 3> boundsMax{};
  // Device memory of every allocation the object made (sizes from vkGet*MemoryRequirements).
  VkDeviceSize gpuMemoryBytes = 0;
  std::unique_ptr<FieldResources> field;  // null for plain meshes

  // An original destroys the data its instances shared; that runs when the last of them is
  // released, which happens in a deferred-destruction callback (Object::~Object): no command
  // that reads the data can still be in flight then.
  ~ObjectImpl();
};

// The engine's way into Object's private state.
struct ObjectAccess {
  static ObjectImpl& impl(Object& object) { return *object.impl_; }
  static const ObjectImpl& impl(const Object& object) { return *object.impl_; }
  static std::unique_ptr<Object> wrap(std::shared_ptr<ObjectImpl> impl) {
    return std::unique_ptr<Object>(new Object(std::move(impl)));
  }
};

// The transform's rotation as a unit quaternion (identity for a zero or non-finite one).
std::array<float, 4> unitRotation(const Transform& worldFromObject);

// World-space bounds of the object's mesh placed by its worldFromObject (culling).
void worldBounds(const Object& object, std::array<float, 3>& min, std::array<float, 3>& max);

// Adds the device memory that `block` / `image` occupies to `object.gpuMemoryBytes`.
void countMemory(ObjectImpl& object, const MemoryBlock& block);
void countMemory(ObjectImpl& object, const ImageAllocation& image);

// Validates `mesh`, creates the vertex and index buffers of `object` and records their upload.
Result<void> createMeshBuffers(ContextImpl& c, const MeshDesc& mesh, VkCommandBuffer cmd, ObjectImpl& object);

// Release (immediately: callers retire these calls) what an instance owns (distortion and jump
// images, descriptor pool), and what instances share (the rest).
void destroyFieldInstance(ContextImpl& c, FieldResources& field);
void destroyFieldShared(ContextImpl& c, FieldResources& field);

// Creates `f`'s distortion image and jump image (cleared to zero and to the jump cap through
// `cmd`, then with the uploads made visible to the passes) and its descriptor sets; the shared members must exist.
Result<void> createFieldInstance(ContextImpl& c, ObjectImpl& object, VkCommandBuffer cmd);

}  // namespace shrefract
