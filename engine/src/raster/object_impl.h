// Private side of Object: the mesh buffers and, for objects created from a field, the field's GPU
// data and distortion image (shared by the raster pass and the decompression pass).
#pragma once

#include <shrefract/renderer.h>

#include <array>
#include <memory>

#include "core/context_impl.h"

namespace shrefract {

// Interleaved vertex: position (3), normal (3), field uv (2), frontIor (1; 0 = ObjectShading::ior).
inline constexpr uint32_t kVertexFloats = 9;

// GPU layouts of the buffers: spirv/include/shrefract/gpu_layout.h (decompression bindings).
struct FieldResources {
  uint32_t width = 0, height = 0;
  Encoding encoding = Encoding::Sh;  // picks the decompression shader (Sh, or Table and Pca)
  uint32_t order = 0;                // Sh
  uint32_t tableSize = 0;            // Table, Pca
  uint32_t components = 0;           // Pca
  uint32_t channels = 4;
  bool throughput = false;           // the last channel is the throughput (raster: params.y)
  Quantization quantization = Quantization::U8;
  uint32_t sampleCount = 0;
  bool scaleBiasStorage = false;     // Sh: the scale/bias table exceeds kMaxUniformScaleBiasBytes
  bool coefficientsStorage = false;  // the coefficients exceed the device's maxTexelBufferElements
  uint32_t gutterCount = 0;
  BufferAllocation coefficients;  // Sh: channel planes; Table, Pca: sample-major (gpu_layout.h)
  VkBufferView coefficientWords = VK_NULL_HANDLE;  // R32_UINT texel view of `coefficients`
  ImageAllocation distortion;     // RGBA16F, written by the decompression pass
  BufferAllocation scaleBias;     // Sh: vec4s per basis function; Table, Pca: vec2 per (layer, value)
  BufferAllocation basis;         // Pca: the basis functions as floats (a placeholder otherwise)
  BufferAllocation frames;        // 3 vec4 per sample
  BufferAllocation sampleTexels;  // texel index per sample
  BufferAllocation gutters;       // uvec4 per rule (at least one entry, unused when gutterCount = 0)
  VkSampler sampler = VK_NULL_HANDLE;  // bilinear, clamp to edge (the raster pass's distortion lookups)
  // Identical in definition to the Decompressor's and Renderer's layouts (hence compatible).
  VkDescriptorSetLayout decompressSetLayout = VK_NULL_HANDLE;
  VkDescriptorSetLayout distortionSetLayout = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet decompressSet = VK_NULL_HANDLE;
  VkDescriptorSet distortionSet = VK_NULL_HANDLE;

  // What the distortion image holds (Decompressor::record skips an object whose image already
  // holds the decompression for the same eye and order). Unset until the first decompression is
  // recorded, and after Object::invalidateDistortion().
  bool decoded = false;
  std::array<float, 3> decodedEye{};
  uint32_t decodedOrder = 0;
};

struct ObjectImpl {
  ContextImpl* context = nullptr;
  BufferAllocation vertices;
  BufferAllocation indices;
  uint32_t indexCount = 0;
  // World-space axis-aligned bounds of the mesh's vertices (view-frustum culling).
  std::array<float, 3> boundsMin{};
  std::array<float, 3> boundsMax{};
  // Device memory of every allocation the object owns (sizes from vkGet*MemoryRequirements).
  VkDeviceSize gpuMemoryBytes = 0;
  std::unique_ptr<FieldResources> field;  // null for plain meshes
};

// Adds the device memory that `buffer` / `image` occupies to `object.gpuMemoryBytes`.
void countMemory(ContextImpl& c, ObjectImpl& object, const BufferAllocation& buffer);
void countMemory(ContextImpl& c, ObjectImpl& object, const ImageAllocation& image);

// Validates `mesh`, creates the vertex and index buffers of `object` and records their upload.
Result<void> createMeshBuffers(ContextImpl& c, const MeshDesc& mesh, VkCommandBuffer cmd, ObjectImpl& object);

// Releases everything `field` holds (immediately: callers retire this call).
void destroyFieldResources(ContextImpl& c, FieldResources& field);

}  // namespace shrefract
