// Descriptor set layouts of the field passes. Each user (field objects for allocation, the
// Decompressor and the Renderer for their pipeline layouts) creates its own from these functions;
// identically defined layouts are compatible, so sets allocated by one bind to the others.
#pragma once

#include "core/context_impl.h"

namespace shrefract {

// Decompression (compute): coefficients, scale/bias, frames, sample texels, distortion image and
// jump image (storage), gutter rules, Pca basis; bindings and layouts in gpu_layout.h. Both decompression
// shaders use this one layout, so a field object has one set whatever its encoding.
Result<VkDescriptorSetLayout> createDecompressSetLayout(ContextImpl& c);

// Bytes of the scale/bias table of an Sh field (gpu_layout.h, kBindingScaleBias), and whether the
// decompression reads it from the storage binding (it exceeds kMaxUniformScaleBiasBytes). Shared
// by createFromField and Decompressor::prepare, which must agree on the pipeline variant.
VkDeviceSize shScaleBiasBytes(uint32_t order, uint32_t channels);
bool shScaleBiasStorage(uint32_t order, uint32_t channels);

// Field raster pass, set 1: the distortion image (combined image sampler), the jump image (sampled
// image, no sampler) and the triangle edges (fragment stage).
Result<VkDescriptorSetLayout> createDistortionSetLayout(ContextImpl& c);

}  // namespace shrefract
