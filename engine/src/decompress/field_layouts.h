// Descriptor set layouts of the field passes. Each user (field objects for allocation, the
// Decompressor and the Renderer for their pipeline layouts) creates its own from these functions;
// identically defined layouts are compatible, so sets allocated by one bind to the others.
#pragma once

#include "core/context_impl.h"

namespace shrefract {

// Decompression (compute): coefficients, scale/bias, frames, sample texels, distortion image
// (storage), gutter rules; bindings and layouts in gpu_layout.h.
Result<VkDescriptorSetLayout> createDecompressSetLayout(ContextImpl& c);

// Field raster pass, set 1: the distortion image as a combined image sampler (fragment stage).
Result<VkDescriptorSetLayout> createDistortionSetLayout(ContextImpl& c);

}  // namespace shrefract
