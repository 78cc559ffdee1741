// Object::createFromField: uploads a refraction field (coefficients and frames of its samples, the
// samples' texels, gutter rules, the Pca basis, render mesh) and creates the object's distortion
// image and descriptor sets.
#include <shrefract/field.h>
#include <shrefract/renderer.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <string>
#include <vector>

#include "core/barriers.h"
#include "core/context_impl.h"
#include "core/half.h"
#include "core/image_info.h"
#include "decompress/field_layouts.h"
#include "object/object_impl.h"
#include "shrefract/gpu_layout.h"

namespace shrefract {

static_assert(gpu::kGpuTexelEmpty == kTexelEmpty && gpu::kGpuTexelSample == kTexelSample &&
              gpu::kGpuTexelGutter == kTexelGutter, "gpu_layout.h and field.h must agree on texel kinds");

static_assert(gpu::kEncodingSh == uint32_t(Encoding::Sh) && gpu::kEncodingTable == uint32_t(Encoding::Table) &&
              gpu::kEncodingPca == uint32_t(Encoding::Pca) && gpu::kEncodingVolume == uint32_t(Encoding::Volume),
              "gpu_layout.h and field.h must agree on encodings");
static_assert(sizeof(gpu::VolumeHeader) == 48, "decompress_volume.comp reads the header as 3 vec4s");

namespace {

Result<BufferAllocation> createDeviceBuffer(ContextImpl& c, VkDeviceSize bytes, VkBufferUsageFlags usage) {
  return c.createUnboundBuffer(bytes, usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT);  // bound in one block
}

// Values per plane of the Sh coefficients: the sample count rounded up to whole invocations.
uint64_t paddedSampleCount(uint64_t samples) {
  const uint64_t group = gpu::kDecompressSamplesPerInvocation;
  return (samples + group - 1) / group * group;
}

// Sh: writes the coefficients of the sample texels as planes (gpu_layout.h, kBindingCoefficients):
// value (layer, channel c, sample s) at ((layer * channels + c) * padded + s); the padding stays as
// the caller zeroed it. T: uint8_t (U8) or uint16_t (F16).
template <class T>
void packPlanes(const std::vector<T>& in, uint32_t channels, uint32_t layers, uint64_t texels,
                const std::vector<uint32_t>& sampleTexels, T* out) {
  const size_t padded = paddedSampleCount(sampleTexels.size());
  for (uint32_t layer = 0; layer < layers; ++layer) {
    const T* layerIn = in.data() + size_t(layer) * texels * channels;
    for (uint32_t c = 0; c < channels; ++c) {
      T* plane = out + (size_t(layer) * channels + c) * padded;
      for (size_t s = 0; s < sampleTexels.size(); ++s) plane[s] = layerIn[size_t(sampleTexels[s]) * channels + c];
    }
  }
}

// Table, Pca: writes the values of each sample texel contiguously (gpu_layout.h): value (layer, v)
// of sample s at (s * layers + layer) * values + v.
template <class T>
void packSampleMajor(const std::vector<T>& in, uint32_t values, uint32_t layers, uint64_t texels,
                     const std::vector<uint32_t>& sampleTexels, T* out) {
  for (size_t s = 0; s < sampleTexels.size(); ++s)
    for (uint32_t layer = 0; layer < layers; ++layer) {
      const T* from = in.data() + (size_t(layer) * texels + sampleTexels[s]) * values;
      std::copy(from, from + values, out + (s * layers + layer) * values);
    }
}

template <class T>
void packCoefficients(const Field& field, const std::vector<T>& in, const std::vector<uint32_t>& sampleTexels,
                      void* out) {
  if (field.encoding == Encoding::Sh)
    packPlanes(in, field.channels, field.layerCount(), field.texelCount(), sampleTexels, static_cast<T*>(out));
  else
    packSampleMajor(in, field.valuesPerLayer(), field.layerCount(), field.texelCount(), sampleTexels,
                    static_cast<T*>(out));
}

// The scale/bias table the decompression reads for a U8 field (gpu_layout.h): Sh:
// SHR_SH_SCALE_BIAS_VEC4S(channels) vec4s per basis function; Table, Pca: (scale, bias) per
// (layer, value). Scales are divided by 255: the shaders multiply the byte q itself. An F16 field
// gets zeros (its shaders never read the table).
std::vector<float> scaleBiasTable(const Field& field) {
  const uint32_t layers = field.layerCount(), values = field.valuesPerLayer();
  const bool u8 = field.quantization == Quantization::U8 && !field.clustered;  // an index needs no scale
  if (field.encoding != Encoding::Sh) {
    std::vector<float> table(size_t(layers) * values * 2, 0.0f);
    for (size_t i = 0; u8 && i < size_t(layers) * values; ++i) {
      table[2 * i] = field.scale[i] / 255.0f;
      table[2 * i + 1] = field.bias[i];
    }
    return table;
  }
  const size_t stride = size_t(SHR_SH_SCALE_BIAS_VEC4S(field.channels)) * 4;
  std::vector<float> table(size_t(layers) * stride, 0.0f);
  for (uint32_t i = 0; u8 && i < layers; ++i)
    for (uint32_t ch = 0; ch < field.channels; ++ch) {
      const size_t from = size_t(i) * field.channels + ch;
      // Channels 0..3: [scale vec4, bias vec4]; channel 4: (scale, bias) of the third vec4.
      const size_t scaleAt = size_t(i) * stride + (ch < 4 ? ch : 8), biasAt = ch < 4 ? scaleAt + 4 : scaleAt + 1;
      table[scaleAt] = field.scale[from] / 255.0f;
      table[biasAt] = field.bias[from];
    }
  return table;
}

// "sh field of order 8", "table field of 16x16 nodes", "pca field of 12 components of 16x16 nodes".
std::string describeEncoding(const Field& field) {
  const std::string nodes = std::to_string(field.tableSize) + "x" + std::to_string(field.tableSize) + " nodes";
  switch (field.encoding) {
    case Encoding::Sh: return "sh field of order " + std::to_string(field.order);
    case Encoding::Table: return "table field of " + nodes;
    case Encoding::Volume: {
      const std::string n = std::to_string(field.volume.size);
      return "volume field of " + n + "x" + n + "x" + n + " voxels";
    }
    default:
      return (field.clustered ? "clustered pca field of " + std::to_string(field.components) + " tables of "
                              : "pca field of " + std::to_string(field.components) + " components of ") +
             nodes;
  }
}

struct FieldBufferSizes {
  VkDeviceSize coefficients = 0;     // at least one word
  bool coefficientsStorage = false;  // beyond the device's texel buffer limit: a storage buffer
  VkDeviceSize frames = 0;
  VkDeviceSize basis = 0;            // Pca: the basis (clustered: binary16); otherwise one placeholder vec4
};

// A Volume field's words on the device: the header, the brick entries and the stored bricks, each
// with the first voxels of its neighbours along +x, +y and +z (gpu_layout.h kVolumeApronWords).
uint64_t volumeDeviceWords(const FieldVolume& v) {
  const uint64_t stored = v.brickVoxels.size() / kVolumeBrickWords;
  return sizeof(gpu::VolumeHeader) / sizeof(uint32_t) + v.bricks.size() + stored * gpu::kVolumeApronWords;
}

// The sizes of the buffers whose size depends on the field, checked against the device's limits.
Result<FieldBufferSizes> fieldBufferSizes(const Field& field, uint64_t samples, const VkPhysicalDeviceLimits& limits) {
  const uint64_t perSample = uint64_t(field.layerCount()) * field.valuesPerLayer();
  const uint64_t valueBytes = field.coefficientValueBytes();
  const uint64_t stored = field.encoding == Encoding::Sh ? paddedSampleCount(samples) : samples;
  auto tooBig = [&](const std::string& what, uint64_t bytes, uint64_t limit, const char* limitName) {
    return makeError(ErrorCode::Unsupported, describeEncoding(field) + " with " + std::to_string(samples) +
                                                 " samples needs " + what + " of " + std::to_string(bytes) +
                                                 " bytes; the device's " + limitName + " is " + std::to_string(limit));
  };
  // decompress_table.comp indexes the values of all samples with 32-bit element numbers.
  if (field.encoding != Encoding::Sh && stored * perSample > UINT32_MAX)
    return tooBig("coefficients", stored * perSample * valueBytes, uint64_t(UINT32_MAX) * valueBytes,
                  "largest sample-major coefficient buffer (32-bit element indices)");
  FieldBufferSizes sizes;
  sizes.coefficients = std::max<VkDeviceSize>((stored * perSample * valueBytes + 3) / 4 * 4, 4);
  sizes.coefficientsStorage = sizes.coefficients / sizeof(uint32_t) > limits.maxTexelBufferElements;
  sizes.frames = std::max<VkDeviceSize>(VkDeviceSize(samples) * 12 * sizeof(float), 16);
  sizes.basis = std::max<VkDeviceSize>((VkDeviceSize(field.basis.size()) * field.basisValueBytes() + 3) / 4 * 4, 16);
  if (field.encoding == Encoding::Volume)
    sizes.basis = volumeDeviceWords(field.volume) * sizeof(uint32_t);
  if (sizes.coefficientsStorage && sizes.coefficients > limits.maxStorageBufferRange)
    return tooBig("coefficients", sizes.coefficients,
                  std::max<VkDeviceSize>(VkDeviceSize(limits.maxTexelBufferElements) * sizeof(uint32_t),
                                         limits.maxStorageBufferRange),
                  "largest texel or storage buffer");
  if (sizes.frames > limits.maxStorageBufferRange)
    return tooBig("sample frames", sizes.frames, limits.maxStorageBufferRange, "maxStorageBufferRange");
  if (sizes.basis > limits.maxStorageBufferRange)
    return tooBig(field.encoding == Encoding::Volume ? "a grid" : "a basis", sizes.basis, limits.maxStorageBufferRange,
                  "maxStorageBufferRange");
  return sizes;
}

// The instance's distortion image (RGBA16F) and jump image (R32F: a storage format every device
// supports), in one allocation held by the distortion image. Both storage (decompression), sampled
// (raster), transfer (clear, and copies out for tools and tests).
Result<std::vector<ImageAllocation>> createInstanceImages(ContextImpl& c, uint32_t width, uint32_t height) {
  const VkImageCreateInfo ici = imageInfo2D(VK_FORMAT_R16G16B16A16_SFLOAT, width, height,
                                            VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                                                VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
  VkImageCreateInfo jump = ici;
  jump.format = VK_FORMAT_R32_SFLOAT;
  return c.createImages({ici, jump}, VK_IMAGE_VIEW_TYPE_2D, VK_IMAGE_ASPECT_COLOR_BIT);
}

// A new image to TRANSFER_DST_OPTIMAL and cleared to `value` in every channel.
void recordClear(ContextImpl& c, VkCommandBuffer cmd, VkImage image, float value) {
  const VkImageMemoryBarrier2 toDst =
      imageBarrier(image, {VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_CLEAR_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                           VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL});
  recordBarriers(c, cmd, {&toDst, 1});
  const VkClearColorValue clear{{value, value, value, value}};
  c.vk.vkCmdClearColorImage(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &clear, 1, &toDst.subresourceRange);
}

// The cleared images to SHADER_READ_ONLY_OPTIMAL and the buffer copies, visible to the compute and
// fragment shaders (Object::createFromField's contract; for an instance there are no copies, and
// the buffer part of the barrier costs nothing).
void recordUploadsVisible(ContextImpl& c, VkCommandBuffer cmd, const std::array<VkImage, 2>& images) {
  const ImageTransition cleared{VK_PIPELINE_STAGE_2_CLEAR_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                                VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT,
                                VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  const std::array<VkImageMemoryBarrier2, 2> toRead{imageBarrier(images[0], cleared), imageBarrier(images[1], cleared)};
  VkMemoryBarrier2 buffersToRead{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  buffersToRead.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
  buffersToRead.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
  buffersToRead.dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  // Every way the decompression pass reads the uploaded buffers: coefficients as a uniform texel
  // buffer (sampled read), scale/bias as a uniform buffer, frames and basis as storage buffers; and
  // the raster pass a Volume field's grid as a uniform texel buffer.
  buffersToRead.dstAccessMask =
      VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_UNIFORM_READ_BIT;
  recordBarriers(c, cmd, toRead, &buffersToRead);
}

// The instance's pool and its two sets: the decompression set (every binding of
// createDecompressSetLayout) and the raster pass's distortion set.
Result<void> allocateDescriptorSets(ContextImpl& c, FieldResources& f) {
  const std::array<VkDescriptorPoolSize, 6> sizes{{
      {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1},
      {VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 1},
      {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 7},
      {VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 2},
      {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
      {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 2},
  }};
  VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dpci.maxSets = 2;
  dpci.poolSizeCount = static_cast<uint32_t>(sizes.size());
  dpci.pPoolSizes = sizes.data();
  VkResult r = c.vk.vkCreateDescriptorPool(c.device(), &dpci, c.alloc(), &f.pool);
  if (r != VK_SUCCESS) return vulkanError("vkCreateDescriptorPool", r);
  const std::array<VkDescriptorSetLayout, 2> setLayouts{f.decompressSetLayout, f.distortionSetLayout};
  std::array<VkDescriptorSet, 2> sets{};
  VkDescriptorSetAllocateInfo dsai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  dsai.descriptorPool = f.pool;
  dsai.descriptorSetCount = 2;
  dsai.pSetLayouts = setLayouts.data();
  r = c.vk.vkAllocateDescriptorSets(c.device(), &dsai, sets.data());
  if (r != VK_SUCCESS) return vulkanError("vkAllocateDescriptorSets", r);
  f.decompressSet = sets[0];
  f.distortionSet = sets[1];
  return {};
}

// Allocates and writes the decompression and distortion sets of `f`, whose buffers, views, image
// and sampler exist, with the mesh's triangle edges (`triangleEdges`).
Result<void> createDescriptorSets(ContextImpl& c, FieldResources& f, VkBuffer triangleEdges) {
  if (auto r = allocateDescriptorSets(c, f); !r) return r;
  const VkDescriptorImageInfo storageInfo{VK_NULL_HANDLE, f.distortion.view, VK_IMAGE_LAYOUT_GENERAL};
  const VkDescriptorImageInfo sampledInfo{f.sampler, f.distortion.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  const VkDescriptorImageInfo jumpStorageInfo{VK_NULL_HANDLE, f.jump.view, VK_IMAGE_LAYOUT_GENERAL};
  const VkDescriptorImageInfo jumpSampledInfo{VK_NULL_HANDLE, f.jump.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  // Every binding is written whichever shader and path reads it (unread ones over their first
  // bytes): the uniform scale/bias binding up to the uniform limit, the coefficients' storage
  // binding up to maxStorageBufferRange (all of them when it is the path).
  const VkDescriptorBufferInfo scaleBiasUniform{f.scaleBias.buffer, 0,
                                                std::min<VkDeviceSize>(f.scaleBias.size, gpu::kMaxUniformScaleBiasBytes)};
  const std::array<VkDescriptorBufferInfo, 6> bufferInfos{{
      {f.coefficients.buffer, 0, std::min<VkDeviceSize>(f.coefficientBytes, c.properties.limits.maxStorageBufferRange)},
      {f.scaleBias.buffer, 0, VK_WHOLE_SIZE},
      {f.frames.buffer, 0, VK_WHOLE_SIZE},
      {f.sampleTexels.buffer, 0, VK_WHOLE_SIZE},
      {f.gutters.buffer, 0, VK_WHOLE_SIZE},
      {f.basis.buffer, 0, VK_WHOLE_SIZE},
  }};
  const std::array<uint32_t, 6> bufferBindings{gpu::kBindingCoefficientsStorage, gpu::kBindingScaleBiasStorage,
                                               gpu::kBindingFrames,  gpu::kBindingSampleTexels,
                                               gpu::kBindingGutters, gpu::kBindingBasis};
  std::vector<VkWriteDescriptorSet> writes;
  auto write = [&](VkDescriptorSet set, uint32_t binding, VkDescriptorType type) -> VkWriteDescriptorSet& {
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = binding;
    w.descriptorCount = 1;
    w.descriptorType = type;
    writes.push_back(w);
    return writes.back();
  };
  writes.reserve(14);
  write(f.decompressSet, gpu::kBindingDistortionOut, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE).pImageInfo = &storageInfo;
  write(f.decompressSet, gpu::kBindingJumpOut, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE).pImageInfo = &jumpStorageInfo;
  // A Volume field's decode reads its grid through the grid's texel view where there is one.
  write(f.decompressSet, gpu::kBindingCoefficients, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER).pTexelBufferView =
      f.volumeWords ? &f.volumeWords : &f.coefficientWords;
  for (size_t i = 0; i < bufferBindings.size(); ++i)
    write(f.decompressSet, bufferBindings[i], VK_DESCRIPTOR_TYPE_STORAGE_BUFFER).pBufferInfo = &bufferInfos[i];
  write(f.decompressSet, gpu::kBindingScaleBias, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER).pBufferInfo = &scaleBiasUniform;
  write(f.distortionSet, gpu::kBindingDistortion, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER).pImageInfo =
      &sampledInfo;
  write(f.distortionSet, gpu::kBindingJumpDistance, VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE).pImageInfo = &jumpSampledInfo;
  const VkDescriptorBufferInfo edgesInfo{triangleEdges, 0, VK_WHOLE_SIZE};
  write(f.distortionSet, gpu::kBindingTriangleEdges, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER).pBufferInfo = &edgesInfo;
  // A Volume field's grid (the coefficients' view as a placeholder that nothing reads otherwise).
  write(f.distortionSet, gpu::kBindingVolumeGrid, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER).pTexelBufferView =
      f.volumeWords ? &f.volumeWords : &f.coefficientWords;
  c.vk.vkUpdateDescriptorSets(c.device(), static_cast<uint32_t>(writes.size()), writes.data(), 0, nullptr);
  return {};
}

}  // namespace

void destroyFieldInstance(ContextImpl& c, FieldResources& f) {
  if (f.pool) c.vk.vkDestroyDescriptorPool(c.device(), f.pool, c.alloc());
  c.destroyImage(f.jump);  // bound into the distortion image's memory, which goes last
  c.destroyImage(f.distortion);
  f.pool = VK_NULL_HANDLE;
  f.decompressSet = f.distortionSet = VK_NULL_HANDLE;
}

void destroyFieldShared(ContextImpl& c, FieldResources& f) {
  const VkDevice d = c.device();
  if (f.decompressSetLayout) c.vk.vkDestroyDescriptorSetLayout(d, f.decompressSetLayout, c.alloc());
  if (f.distortionSetLayout) c.vk.vkDestroyDescriptorSetLayout(d, f.distortionSetLayout, c.alloc());
  if (f.sampler) c.vk.vkDestroySampler(d, f.sampler, c.alloc());
  if (f.coefficientWords) c.vk.vkDestroyBufferView(d, f.coefficientWords, c.alloc());
  if (f.volumeWords) c.vk.vkDestroyBufferView(d, f.volumeWords, c.alloc());
  for (BufferAllocation* b : {&f.coefficients, &f.scaleBias, &f.frames, &f.sampleTexels, &f.gutters, &f.basis})
    c.destroyBuffer(*b);
  c.destroyBlock(f.block);
  f = FieldResources{};
}

Result<void> createFieldInstance(ContextImpl& c, ObjectImpl& object, VkCommandBuffer cmd) {
  FieldResources& f = *object.field;
  auto images = createInstanceImages(c, f.width, f.height);
  if (!images) return images.error();
  f.distortion = images.value()[0];
  f.jump = images.value()[1];
  countMemory(object, f.distortion);
  recordClear(c, cmd, f.distortion.image, 0.0f);
  recordClear(c, cmd, f.jump.image, gpu::kJumpDistanceMaxCells);  // no jump placed where nothing is decoded
  recordUploadsVisible(c, cmd, {f.distortion.image, f.jump.image});
  return createDescriptorSets(c, f, object.triangleEdges.buffer);
}

bool Object::hasField() const { return impl_->field != nullptr; }
uint32_t Object::fieldOrder() const { return impl_->field ? impl_->field->bakedOrder : 0; }
uint32_t Object::decodeOrder() const { return impl_->field ? impl_->field->order : 0; }

Result<void> Object::setDecodeOrder(uint32_t order) {
  FieldResources* f = impl_->field.get();
  if (!f || order > f->bakedOrder)
    return makeError(ErrorCode::InvalidArgument, "Object::setDecodeOrder: order " + std::to_string(order) +
                                                     " is above the field's order " + std::to_string(fieldOrder()));
  f->order = order;  // the Decompressor picks its pipeline, and decodes again, by this
  return {};
}

bool Object::tracesVolumePerFragment() const { return impl_->field && impl_->field->volumePerFragment; }

Result<void> Object::setTracesVolumePerFragment(bool perFragment) {
  FieldResources* f = impl_->field.get();
  if (!f || f->encoding != Encoding::Volume)
    return makeError(ErrorCode::InvalidArgument, "Object::setTracesVolumePerFragment: the object has no Volume field");
  if (perFragment && !f->volumeWords)
    return makeError(ErrorCode::Unsupported, "Object::setTracesVolumePerFragment: the grid exceeds the device's "
                                             "maxTexelBufferElements (" +
                                                 std::to_string(impl_->context->properties.limits.maxTexelBufferElements) + ")");
  if (f->volumePerFragment != perFragment) f->decoded = false;  // the image was not kept up while unread
  f->volumePerFragment = perFragment;
  return {};
}
VkExtent2D Object::fieldExtent() const {
  return impl_->field ? VkExtent2D{impl_->field->width, impl_->field->height} : VkExtent2D{0, 0};
}
VkImage Object::distortionImage() const { return impl_->field ? impl_->field->distortion.image : VK_NULL_HANDLE; }
VkImage Object::jumpImage() const { return impl_->field ? impl_->field->jump.image : VK_NULL_HANDLE; }

namespace {

// Samples, in texel order; only they are stored and decompressed.
std::vector<uint32_t> sampleTexelsOf(const Field& field) {
  std::vector<uint32_t> sampleTexels;
  for (uint64_t t = 0; t < field.texelCount(); ++t)
    if (field.texelKinds[t] == kTexelSample) sampleTexels.push_back(static_cast<uint32_t>(t));
  return sampleTexels;
}

MeshDesc meshDescOf(const FieldMesh& m) {
  MeshDesc mesh;
  mesh.positions = m.positions.data();
  mesh.normals = m.normals.data();
  mesh.fieldUvs = m.uvs.data();
  mesh.frontIor = m.frontIor.data();
  mesh.vertexCount = static_cast<uint32_t>(m.positions.size() / 3);
  mesh.indices = m.indices.data();
  mesh.indexCount = static_cast<uint32_t>(m.indices.size());
  return mesh;
}

// The field's description as the passes read it; its Vulkan objects are created after.
void describeField(const Field& field, uint32_t sampleCount, const FieldBufferSizes& sizes, FieldResources& f) {
  f.width = field.width;
  f.height = field.height;
  f.encoding = field.encoding;
  f.order = f.bakedOrder = field.order;
  f.tableSize = field.tableSize;
  f.components = field.components;
  f.jumpAware = field.shape().jumpAware;
  f.jumpDistance = field.jumpDistance;
  f.sampleFrameExits = field.sampleFrameExits;
  f.clustered = field.clustered;
  f.channels = field.channels;
  f.throughput = field.throughput;
  f.quantization = field.quantization;
  f.sampleCount = sampleCount;
  // Sh: a uniform buffer when the table fits (gpu_layout.h, kSpecScaleBiasStorage); the Table and
  // Pca shader always reads the storage binding.
  f.scaleBiasStorage = field.encoding == Encoding::Sh && shScaleBiasStorage(field.order, field.channels);
  f.coefficientsStorage = field.encoding == Encoding::Volume || sizes.coefficientsStorage;  // Volume: createVolumeView
  f.gutterCount = static_cast<uint32_t>(field.gutters.size());
}

// The small buffers' contents on the host, kept until their uploads are recorded.
// Writes v's stored bricks with their aprons from words[first] on, in entry order.
void writeApronBricks(const FieldVolume& v, std::vector<uint32_t>& words, size_t first) {
  const uint32_t n = v.size, per = volumeBricksPerSide(n), s = kVolumeBrickSide, a = gpu::kVolumeApronSide;
  for (uint32_t c = 0; c < per; ++c)
    for (uint32_t b = 0; b < per; ++b)
      for (uint32_t x = 0; x < per; ++x) {
        const uint32_t entry = v.bricks[(size_t(c) * per + b) * per + x];
        if (entry >= kVolumeBrickInside) continue;
        uint32_t* out = &words[first + size_t(entry) * gpu::kVolumeApronWords];
        for (uint32_t k = 0; k < gpu::kVolumeApronWords; ++k)
          out[k] = volumeVoxel(v, std::min(x * s + k % a, n - 1), std::min(b * s + (k / a) % a, n - 1),
                               std::min(c * s + k / (a * a), n - 1));
      }
}

// A Volume field's basis binding (gpu_layout.h VolumeHeader, the brick entries, then the stored
// bricks with their aprons); empty for the other encodings.
std::vector<uint32_t> volumeWords(const Field& field) {
  if (field.encoding != Encoding::Volume) return {};
  gpu::VolumeHeader head{};
  const FieldVolume& v = field.volume;
  head.grid = {v.size, field.settings.maxBounces, field.settings.pathRule == PathRule::HighestEnergy ? 1u : 0u,
               v.convex ? 1u : 0u};
  head.origin = {v.origin[0], v.origin[1], v.origin[2], v.spacing};
  const float outside = field.media[0].ior, inside = field.media[1].ior;
  head.media = {outside / inside, inside / outside, field.media[1].absorption, 0.0f};
  const size_t headWords = sizeof(head) / sizeof(uint32_t);
  std::vector<uint32_t> words(size_t(volumeDeviceWords(v)));
  std::memcpy(words.data(), &head, sizeof(head));
  for (size_t i = 0; i < v.bricks.size(); ++i)  // far entries carry their reach (gpu_layout.h kVolumeBrickFar)
    words[headWords + i] = v.bricks[i] < kVolumeBrickInside
                               ? v.bricks[i]
                               : gpu::kVolumeBrickFar + (volumeFarReach(v, i) << 1) + (v.bricks[i] == kVolumeBrickOutside);
  writeApronBricks(v, words, headWords + v.bricks.size());
  return words;
}

struct HostTables {
  std::vector<float> scaleBias;
  std::vector<float> frames;
  std::vector<uint32_t> sampleTexels;
  std::vector<uint32_t> gutters;
};

HostTables hostTables(const Field& field, const std::vector<uint32_t>& sampleTexels, const FieldBufferSizes& sizes) {
  HostTables h;
  h.scaleBias = scaleBiasTable(field);
  h.scaleBias.resize(std::max<size_t>(h.scaleBias.size(), 4), 0.0f);  // one vec4 at least (a Pca table of K = 1)
  h.frames.assign(size_t(sizes.frames / sizeof(float)), 0.0f);
  for (size_t s = 0; s < sampleTexels.size(); ++s)
    std::memcpy(&h.frames[s * 12], &field.frames[size_t(sampleTexels[s]) * 12], 12 * sizeof(float));
  h.sampleTexels = sampleTexels;
  if (h.sampleTexels.empty()) h.sampleTexels.push_back(0);  // never read: sampleCount is 0
  h.gutters.assign(std::max<size_t>(field.gutters.size(), 1) * 4, 0u);
  for (size_t g = 0; g < field.gutters.size(); ++g) {
    const GutterTexel& r = field.gutters[g];
    h.gutters[g * 4 + 0] = r.target;
    h.gutters[g * 4 + 1] = r.a;
    h.gutters[g * 4 + 2] = r.b;
    h.gutters[g * 4 + 3] = r.c;
  }
  return h;
}

// A Volume field's grid as the raster pass reads it (kBindingVolumeGrid): an R32_UINT texel view
// of the whole basis buffer, header included. Where the grid exceeds the device's
// maxTexelBufferElements there is none, and the object shades by its sample texels instead.
Result<void> createVolumeView(ContextImpl& c, const FieldBufferSizes& sizes, FieldResources& f) {
  const VkDeviceSize words = sizes.basis / sizeof(uint32_t);
  if (f.encoding != Encoding::Volume || words > c.properties.limits.maxTexelBufferElements) return {};
  VkBufferViewCreateInfo bvci{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
  bvci.buffer = f.basis.buffer;
  bvci.format = VK_FORMAT_R32_UINT;
  bvci.range = words * sizeof(uint32_t);
  const VkResult vr = c.vk.vkCreateBufferView(c.device(), &bvci, c.alloc(), &f.volumeWords);
  if (vr != VK_SUCCESS) return vulkanError("vkCreateBufferView", vr);
  f.coefficientsStorage = false;  // decompress_volume.comp reads the grid through this view
  return {};
}

struct Upload {
  BufferAllocation* target;
  const void* data;
  VkDeviceSize bytes;
};

// The field's buffers, created unbound and bound in one memory block, and the coefficients' texel
// view.
Result<void> createFieldBuffers(ContextImpl& c, const std::array<Upload, 5>& uploads, const FieldBufferSizes& sizes,
                                ObjectImpl& object) {
  FieldResources& f = *object.field;
  for (const Upload& u : uploads) {
    // The scale/bias table is read as a uniform buffer when it fits (gpu_layout.h).
    // The scale/bias table is read as a uniform buffer when it fits (gpu_layout.h); a Volume
    // field's grid (the basis) as a texel buffer by the raster pass (kBindingVolumeGrid).
    auto b = createDeviceBuffer(c, u.bytes,
                                VK_BUFFER_USAGE_STORAGE_BUFFER_BIT |
                                    (u.target == &f.scaleBias ? VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT : 0) |
                                    (u.target == &f.basis ? VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT : 0));
    if (!b) return b.error();
    *u.target = b.value();
  }
  auto coefficients = createDeviceBuffer(c, sizes.coefficients,
                                         VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT);
  if (!coefficients) return coefficients.error();
  f.coefficients = coefficients.value();
  f.coefficientBytes = sizes.coefficients;
  auto block = c.bindBlock({&f.coefficients, &f.scaleBias, &f.frames, &f.sampleTexels, &f.gutters, &f.basis});
  if (!block) return block.error();
  f.block = block.value();
  countMemory(object, f.block);
  // Read through a texel buffer when the device's limit allows (gpu_layout.h,
  // kSpecCoefficientsStorage); otherwise the view covers a prefix and is not read.
  const VkDeviceSize words = sizes.coefficients / sizeof(uint32_t);
  VkBufferViewCreateInfo bvci{VK_STRUCTURE_TYPE_BUFFER_VIEW_CREATE_INFO};
  bvci.buffer = f.coefficients.buffer;
  bvci.format = VK_FORMAT_R32_UINT;
  bvci.range = std::min<VkDeviceSize>(words, c.properties.limits.maxTexelBufferElements) * sizeof(uint32_t);
  const VkResult vr = c.vk.vkCreateBufferView(c.device(), &bvci, c.alloc(), &f.coefficientWords);
  if (vr != VK_SUCCESS) return vulkanError("vkCreateBufferView", vr);
  return createVolumeView(c, sizes, f);
}

// Records the copies of the coefficients (staged, written in place: the largest upload, no
// intermediate copy) and of the small buffers.
Result<void> recordFieldUploads(ContextImpl& c, VkCommandBuffer cmd, const Field& field,
                                const std::vector<uint32_t>& sampleTexels, const FieldBufferSizes& sizes,
                                const std::array<Upload, 5>& uploads, const FieldResources& f) {
  auto staging = c.createBuffer(sizes.coefficients, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true);
  if (!staging) return staging.error();
  BufferAllocation st = staging.value();
  c.retire([&c, st]() mutable { c.destroyBuffer(st); });
  std::memset(st.mapped, 0, sizes.coefficients);
  if (field.clustered)
    packCoefficients(field, field.clusterIndices, sampleTexels, st.mapped);
  else if (field.quantization == Quantization::U8)
    packCoefficients(field, field.coefficientsU8, sampleTexels, st.mapped);
  else
    packCoefficients(field, field.coefficientsF16, sampleTexels, st.mapped);
  const VkBufferCopy whole{0, 0, sizes.coefficients};
  c.vk.vkCmdCopyBuffer(cmd, st.buffer, f.coefficients.buffer, 1, &whole);
  for (const Upload& u : uploads)
    if (auto r = c.recordBufferUpload(cmd, u.target->buffer, u.data, u.bytes); !r) return r.error();
  return {};
}

// The sampler and set layouts every instance of the field shares.
Result<void> createFieldShared(ContextImpl& c, FieldResources& f) {
  VkSamplerCreateInfo sci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  sci.magFilter = VK_FILTER_LINEAR;
  sci.minFilter = VK_FILTER_LINEAR;
  sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  sci.addressModeU = sci.addressModeV = sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  const VkResult r = c.vk.vkCreateSampler(c.device(), &sci, c.alloc(), &f.sampler);
  if (r != VK_SUCCESS) return vulkanError("vkCreateSampler", r);
  auto decompressLayout = createDecompressSetLayout(c);
  if (!decompressLayout) return decompressLayout.error();
  f.decompressSetLayout = decompressLayout.value();
  auto distortionLayout = createDistortionSetLayout(c);
  if (!distortionLayout) return distortionLayout.error();
  f.distortionSetLayout = distortionLayout.value();
  return {};
}

}  // namespace

Result<std::unique_ptr<Object>> Object::createFromField(Context& context, const Field& field, VkCommandBuffer cmd) {
  if (auto valid = validateField(field); !valid) return valid.error();
  ContextImpl& c = ContextAccess::impl(context);
  const VkPhysicalDeviceLimits& limits = c.properties.limits;
  if (field.width > limits.maxImageDimension2D || field.height > limits.maxImageDimension2D)
    return makeError(ErrorCode::Unsupported, "field atlas " + std::to_string(field.width) + "x" +
                                                 std::to_string(field.height) + " exceeds the device's 2D image limit " +
                                                 std::to_string(limits.maxImageDimension2D));
  const std::vector<uint32_t> sampleTexels = sampleTexelsOf(field);
  auto sized = fieldBufferSizes(field, sampleTexels.size(), limits);
  if (!sized) return sized.error();
  const FieldBufferSizes sizes = sized.value();

  auto impl = std::make_shared<ObjectImpl>();
  impl->context = &c;
  // From here on the object's destructor retires whatever has been created (`cmd` may reference it).
  auto object = ObjectAccess::wrap(impl);
  if (auto r = createMeshBuffers(c, meshDescOf(field.mesh), cmd, *impl); !r) return r.error();
  object->shading.tint = frontMediumColor(field);  // one colour model in every mode
  impl->field = std::make_unique<FieldResources>();
  FieldResources& f = *impl->field;
  describeField(field, static_cast<uint32_t>(sampleTexels.size()), sizes, f);

  const HostTables host = hostTables(field, sampleTexels, sizes);
  const float placeholder[4] = {0.0f, 0.0f, 0.0f, 0.0f};  // the basis binding of a field without one
  // A clustered field's tables as the shader reads them: binary16, two to a word (gpu_layout.h).
  std::vector<uint16_t> halfTables(field.clustered ? size_t(sizes.basis / sizeof(uint16_t)) : 0, 0);
  for (size_t i = 0; field.clustered && i < field.basis.size(); ++i) halfTables[i] = floatToHalf(field.basis[i]);
  const std::vector<uint32_t> volume = volumeWords(field);
  const void* basis = !volume.empty()       ? static_cast<const void*>(volume.data())
                      : field.basis.empty() ? static_cast<const void*>(placeholder)
                      : field.clustered   ? static_cast<const void*>(halfTables.data())
                                          : static_cast<const void*>(field.basis.data());
  const std::array<Upload, 5> uploads{{
      {&f.scaleBias, host.scaleBias.data(), host.scaleBias.size() * sizeof(float)},
      {&f.frames, host.frames.data(), host.frames.size() * sizeof(float)},
      {&f.sampleTexels, host.sampleTexels.data(), host.sampleTexels.size() * sizeof(uint32_t)},
      {&f.gutters, host.gutters.data(), host.gutters.size() * sizeof(uint32_t)},
      {&f.basis, basis, sizes.basis},
  }};
  if (auto r = createFieldBuffers(c, uploads, sizes, *impl); !r) return r.error();
  if (auto r = recordFieldUploads(c, cmd, field, sampleTexels, sizes, uploads, f); !r) return r.error();
  // Then the distortion image (cleared: empty texels stay zero from here on), made visible to the
  // passes with the copies, and the descriptor sets.
  if (auto r = createFieldShared(c, f); !r) return r.error();
  if (auto created = createFieldInstance(c, *impl, cmd); !created) return created.error();
  return object;
}

}  // namespace shrefract
