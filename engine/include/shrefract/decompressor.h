// Decompression in data space: a compute pass that turns each field object's SH coefficients into
// its distortion image for the current eye (TECHNIQUE.md, "How it is replayed", step 1).
//
// Per texel t of an object's atlas that holds a sample:
//   w = M_s (eye, 1);  w.z = max(w.z, 0);  w = normalize(w)  (the zero vector counts as +z)
//   s = sum_i c_i Y_i(w)  over i < (L+1)^2, c_i dequantized (U8: bias + scale * q / 255)
//   texel = (s.xyz / |s.xyz|, clamp(s.w, -65504, 65504))  (zero direction if |s.xyz|^2 <= 1e-20)
// Empty texels become zero. Then, after a barrier, a second dispatch applies the split layout's
// gutter rules: texel target = value(a) + value(b) - value(c) (a, b, c hold samples).
// The CPU mirror is shrefract/cpu_reference.h (decodeTexel, decompress).
//
// Pipelines: one per SH order (the order is a specialization constant, so only the basis
// functions in use are evaluated), created on first use or by prepare(), and passed the host's
// pipeline cache.
//
// Contract for record():
//  - `cmd` is in the recording state, outside dynamic rendering, on a queue family with compute;
//  - the engine binds its own compute pipeline, descriptor sets and push constants; the host must
//    rebind its own compute state afterwards (graphics state is untouched);
//  - synchronization: record() begins with a barrier that waits for earlier fragment- and
//    compute-shader reads of the distortion images (on this queue, in submission order: the
//    previous frame's raster pass) before overwriting them, and ends with a barrier that makes the
//    images visible to FRAGMENT_SHADER sampled reads in SHADER_READ_ONLY_OPTIMAL. It expects the
//    images in SHADER_READ_ONLY_OPTIMAL (as createFromField and record() leave them) and discards
//    their previous contents.
//  - frames in flight: there is one distortion image per object. Frames recorded ahead share it;
//    that is correct on one queue (the barriers order frame N's raster before frame N+1's
//    decompression) but serializes them. A host that submits the engine's work to two queues must
//    synchronize them itself.
// Threading: as for Context (externally synchronized with everything created from the context).
#pragma once

#include <shrefract/context.h>
#include <shrefract/renderer.h>

#include <cstdint>
#include <memory>
#include <vector>

namespace shrefract {

struct DecompressorImpl;

class Decompressor {
 public:
  static Result<std::unique_ptr<Decompressor>> create(Context& context);
  // Pipelines are retired through the context's deferred destruction.
  ~Decompressor();
  Decompressor(const Decompressor&) = delete;
  Decompressor& operator=(const Decompressor&) = delete;

  // Creates the pipeline for SH order `order` now (otherwise record() creates it on first use).
  // Precondition: order <= 32.
  Result<void> prepare(uint32_t order);

  // Records one decompression dispatch per field object (objects without a field and null
  // entries are skipped), then one gutter dispatch per object that has gutter rules. `eye` is the
  // world-space eye position the raster pass will use (Camera::eye). Fails only when a pipeline
  // cannot be created; then nothing has been recorded.
  Result<void> record(VkCommandBuffer cmd, const std::array<float, 3>& eye, const std::vector<Object*>& objects);

 private:
  explicit Decompressor(std::unique_ptr<DecompressorImpl> impl);
  std::unique_ptr<DecompressorImpl> impl_;
};

}  // namespace shrefract
