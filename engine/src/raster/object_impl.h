// Private side of Object: the mesh buffers and, for objects created from a field, the field's GPU
// data and distortion image (shared by the raster pass and the decompression pass).
#pragma once

#include <shrefract/renderer.h>

#include <memory>

#include "core/context_impl.h"

namespace shrefract {

// Interleaved vertex: position (3), normal (3), field uv (2), frontIor (1; 0 = ObjectShading::ior).
inline constexpr uint32_t kVertexFloats = 9;

struct FieldResources {
  uint32_t width = 0, height = 0;
  uint32_t order = 0;
  uint32_t gutterCount = 0;
  ImageAllocation coefficients;  // 2D array, layer = basis function
  ImageAllocation distortion;    // RGBA16F, written by the decompression pass
  BufferAllocation scaleBias;    // vec4 per (basis function, scale|bias)
  BufferAllocation frames;       // 3 vec4 per texel
  BufferAllocation kinds;        // packed bytes
  BufferAllocation gutters;      // uvec4 per rule (at least one entry, unused when gutterCount = 0)
  VkSampler sampler = VK_NULL_HANDLE;  // bilinear, clamp to edge; texelFetch ignores it
  // Identical in definition to the Decompressor's and Renderer's layouts (hence compatible).
  VkDescriptorSetLayout decompressSetLayout = VK_NULL_HANDLE;
  VkDescriptorSetLayout distortionSetLayout = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet decompressSet = VK_NULL_HANDLE;
  VkDescriptorSet distortionSet = VK_NULL_HANDLE;
};

struct ObjectImpl {
  ContextImpl* context = nullptr;
  BufferAllocation vertices;
  BufferAllocation indices;
  uint32_t indexCount = 0;
  std::unique_ptr<FieldResources> field;  // null for plain meshes
};

// Validates `mesh`, creates the vertex and index buffers of `object` and records their upload.
Result<void> createMeshBuffers(ContextImpl& c, const MeshDesc& mesh, VkCommandBuffer cmd, ObjectImpl& object);

// Releases everything `field` holds (immediately: callers retire this call).
void destroyFieldResources(ContextImpl& c, FieldResources& field);

}  // namespace shrefract
