// Decompression in data space: a compute pass that turns each field object's coefficients (SH,
// hemi-octahedral table or PCA, field.h) into its distortion image for the current eye
// (docs/technique.md, "Replay in the engine").
//
// Per texel t of an object's atlas that holds a sample (only samples are stored on the GPU; an SH
// invocation decodes 4 of them, a Table or Pca invocation one):
//   w = M_s (eye, 1);  w.z = max(w.z, 0);  w = normalize(w)  (the zero vector counts as +z)
//   s = the field's linear sum at w (evaluateSample in field.h): SH sum_i c_i Y_i(w); Table the
//       bilinear blend of the 4 grid nodes around w; Pca sum_k a_k times that blend of basis k;
//       coefficients dequantized (U8: bias + scale * q / 255)
//   texel = (s.xyz / |s.xyz|, clamp(s.tau, -65504, 65504))  (zero direction if |s.xyz|^2 <= 1e-20;
//           tau = 0 for a field without optical depth, which stores and sums none; with a
//           throughput channel the direction is multiplied by clamp(s.throughput, 0, 1))
// Empty texels stay zero (as createFromField cleared them). Then, after a barrier, a second
// dispatch applies the split layout's gutter rules: texel target = value(a) + value(b) - value(c)
// (a, b, c hold samples). The CPU mirror is shrefract/cpu_reference.h (decodeTexel, decompress).
//
// Pipelines: one per encoding and its parameters (SH order; table size and components), channel
// layout and quantization (specialization constants, so only the basis functions in use are
// evaluated and only the stored channels read), created on first use or by prepare(), and passed
// the host's pipeline cache.
//
// Contract for record():
//  - `cmd` is in the recording state, outside dynamic rendering, on a queue family with compute;
//  - the engine binds its own compute pipeline, descriptor sets and push constants; the host must
//    rebind its own compute state afterwards (graphics state is untouched);
//  - synchronization: record() begins with a barrier that waits for earlier fragment- and
//    compute-shader reads of the distortion images (on this queue, in submission order: the
//    previous frame's raster pass) before overwriting them, and ends with a barrier that makes the
//    images visible to FRAGMENT_SHADER sampled reads in SHADER_READ_ONLY_OPTIMAL. It expects the
//    images in SHADER_READ_ONLY_OPTIMAL (as createFromField and record() leave them) with their
//    contents kept (a host that copies one out transitions it back from a defined layout): the
//    empty texels are not rewritten. "The images" are each object's distortion image and its jump
//    image (Object::jumpImage), which the same barriers cover; a host that writes a distortion
//    image itself writes the jump image too, or fills it with 1 (no jump placed).
//  - frames in flight: there is one distortion image per object. Frames recorded ahead share it;
//    that is correct on one queue (the barriers order frame N's raster before frame N+1's
//    decompression) but serializes them. A host that submits the engine's work to two queues must
//    synchronize them itself.
//
// Skipping work (both on by default; lastStats() says what a call did):
//  - unchanged eye: an object whose distortion image already holds the decompression for the same
//    eye (bitwise equal world-space position; objects are static, so that is "the eye has not
//    moved relative to the object") and the same SH order is not decompressed again, and no
//    barrier touches its image. The image keeps what the earlier dispatch wrote, which the earlier
//    final barrier already made visible to every later fragment-shader read on the queue. This is
//    safe with frames in flight because there is one image per object and one queue: a frame
//    that skips reads what an earlier frame, earlier in submission order, wrote; no later frame
//    can overwrite it before this frame's raster without a new eye, and then that later frame
//    decompresses after the barrier that waits for this frame's reads. The record is made when
//    the call records the dispatch, so the host must submit what it records, in recording order;
//    a host that discards a recorded command buffer, or writes a distortion image itself, calls
//    Object::invalidateDistortion(). setSkipUnchanged(false) decompresses every call (timings).
//  - outside the view: the camera overload of record() leaves out objects whose bounds lie outside
//    the view frustum, as Renderer::recordObjects() does; their images keep their contents (and
//    the eye they were decoded for), so they are decompressed again only if the eye has moved by
//    the time they come back into view.
// Threading: as for Context (externally synchronized with everything created from the context).
#pragma once

#include <shrefract/context.h>
#include <shrefract/renderer.h>

#include <cstdint>
#include <initializer_list>
#include <memory>
#include <span>
#include <vector>

namespace shrefract {

// What the last Decompressor::record() call recorded.
struct DecompressStats {
  uint32_t decompressed = 0;  // field objects whose distortion image was rewritten
  uint32_t unchanged = 0;     // left out: the image already holds this eye's decompression
  uint32_t culled = 0;        // left out: outside the view frustum (camera overload only)
  uint32_t perFragment = 0;   // left out: Volume fields the raster pass traces per fragment
  uint32_t dispatches = 0;    // compute dispatches (decompression and gutter passes)
};

// An SH order for `object` from its size on screen, for Object::setDecodeOrder: with P the larger
// side, in pixels, of the screen rectangle its world bounds project to (camera, extent), band L
// varies at least L + 1 times across the object's directions, which P pixels can show only while
// 2 (L + 1) <= P: min(fieldOrder(), max(0, floor(P / 2) - 1)). fieldOrder() when a corner of the
// bounds is behind the eye (the projection is unbounded) and for non-finite cameras.
uint32_t coverageOrder(const Object& object, const Camera& camera, VkExtent2D extent);

struct DecompressorImpl;

class Decompressor {
 public:
  static Result<std::unique_ptr<Decompressor>> create(Context& context);
  // Pipelines are retired through the context's deferred destruction.
  ~Decompressor();
  Decompressor(const Decompressor&) = delete;
  Decompressor& operator=(const Decompressor&) = delete;

  // Creates the pipelines for SH fields of order `order` now, for both quantizations and every
  // channel layout (3 or 4 channels, 4 or 5 with throughput; otherwise record() creates the one it
  // needs on first use). Error (InvalidArgument): order > 32.
  Result<void> prepare(uint32_t order);
  // Creates just the pipeline `object` needs (nothing for an object without a field).
  Result<void> prepare(const Object& object);

  // Records one decompression dispatch per field object (objects without a field and null
  // entries are skipped), then one gutter dispatch per object that has gutter rules. `eye` is the
  // world-space eye position the raster pass will use (Camera::eye). Fails only when a pipeline
  // cannot be created; then nothing has been recorded.
  // Objects whose image already holds this eye's decompression are left out (see above).
  Result<void> record(VkCommandBuffer cmd, const std::array<float, 3>& eye, std::span<Object* const> objects);
  Result<void> record(VkCommandBuffer cmd, const std::array<float, 3>& eye, std::initializer_list<Object*> objects) {
    return record(cmd, eye, std::span<Object* const>(objects.begin(), objects.size()));
  }
  // The same for camera.eye, leaving out in addition the objects outside the view frustum of
  // (camera, extent), as Renderer::recordObjects() does with the same arguments.
  Result<void> record(VkCommandBuffer cmd, const Camera& camera, VkExtent2D extent,
                      std::span<Object* const> objects);
  Result<void> record(VkCommandBuffer cmd, const Camera& camera, VkExtent2D extent,
                      std::initializer_list<Object*> objects) {
    return record(cmd, camera, extent, std::span<Object* const>(objects.begin(), objects.size()));
  }

  // Counts of the last record() call (all zero after a failed call).
  const DecompressStats& lastStats() const;

  // true (default): leave out objects whose image holds the decompression for the same eye.
  // false: decompress every (visible) field object on every call, e.g. to time the pass.
  void setSkipUnchanged(bool skip);

 private:
  explicit Decompressor(std::unique_ptr<DecompressorImpl> impl);
  std::unique_ptr<DecompressorImpl> impl_;
};

}  // namespace shrefract
