// The raster pass: the environment as background and refractive objects over it, drawn with
// dynamic rendering into attachments the host provides.
//
// Objects (shrefract/object.h) are static meshes placed in the world by their worldFromObject
// transform; an object created from a refraction field also has the field's GPU data and a
// distortion image, which the Decompressor (shrefract/decompressor.h) fills for the current eye
// and ShadingMode::Field samples. Instances share one upload (Object::createInstance).
//
// A host frame with field objects, all on one command buffer of the context's queue family:
//   context.beginFrame();                                   // releases what was retired
//   decompressor.record(cmd, camera.eye, objects);          // compute, outside rendering
//   (host) vkCmdBeginRendering(cmd, ...);                   // its own attachments
//   renderer.recordBackground(cmd, environment, camera, extent);
//   renderer.recordObjects(cmd, environment, camera, extent, objects, ShadingMode::Field);
//   (host) vkCmdEndRendering(cmd);
// Images the engine owns (environment, coefficients, distortion images) are in
// SHADER_READ_ONLY_OPTIMAL between engine calls; the engine never touches the host's attachments'
// layouts. Frames in flight and deferred destruction: see context.h and decompressor.h.
// Threading: as for Context; recording into different command buffers must still not overlap.
//
// Contract for recordBackground()/recordObjects():
//  - the host has begun dynamic rendering (vkCmdBeginRendering) on `cmd` with one color attachment
//    of RendererCreateInfo::colorFormat and, if depthFormat is not UNDEFINED, a depth attachment of
//    that format (depth test LESS, cleared to 1.0);
//  - the host has set viewport and scissor (dynamic state) to the region to draw;
//  - the engine binds its own pipelines, descriptor sets, vertex/index buffers and push constants;
//    on return the host must rebind its own state before drawing.
//  - the background is drawn at the far plane without writing depth; objects write depth. Either
//    call may come first: drawing the objects first lets the depth test reject the background's
//    fragments under them before they are shaded (the frame benchmark does).
#pragma once

#include <shrefract/context.h>
#include <shrefract/environment.h>
#include <shrefract/field.h>
#include <shrefract/object.h>

#include <array>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace shrefract {

struct Camera {
  std::array<float, 3> eye{0.0f, 0.0f, 4.0f};
  std::array<float, 3> target{0.0f, 0.0f, 0.0f};
  std::array<float, 3> up{0.0f, 1.0f, 0.0f};
  float verticalFovDegrees = 45.0f;
  float nearPlane = 0.01f;
  float farPlane = 1000.0f;
};

enum class ShadingMode : uint32_t {
  SingleInterface = 0,  // one Snell bend at the front surface (what engines usually ship)
  // The refraction field: the distortion image, bilinearly sampled at the fragment's atlas
  // coordinate, gives the exit direction d and optical depth tau; the colour is
  //   (1 - F) * exp(-max(tau, 0) * k * s) * tint * env(d) + F * env(reflect(v, n))
  // with F the dielectric Fresnel reflectance for frontIor (ObjectShading::ior where the mesh has
  // none). For a field with a throughput channel the first term is also multiplied by
  // min(|d_stored|, 1), the bilinearly filtered throughput (the image stores d times it). A zero
  // sample (no data) looks straight through: d = v. Objects without a field are drawn with
  // SingleInterface.
  Field = 1,
  // For measurements: field objects write the decoded unit exit direction (xyz) and the optical
  // depth (w) instead of a colour, so a host can compare directions per pixel with a reference.
  // Needs a float colour attachment. Objects without a field are drawn with SingleInterface.
  FieldExitDirection = 2,
};

// The range of RendererCreateInfo::environmentTapsPerAxis (and of the CPU mirror's and the CPU
// references' tap counts, which follow it).
inline constexpr uint32_t kMaxEnvironmentTapsPerAxis = 4;

struct RendererCreateInfo {
  VkFormat colorFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
  VkFormat depthFormat = VK_FORMAT_D32_SFLOAT;  // VK_FORMAT_UNDEFINED: no depth attachment
  float exposure = 1.0f;
  // recordObjects() leaves out objects whose bounds lie outside the camera's view frustum (they
  // would produce no fragment). Off only to measure what culling saves.
  bool frustumCulling = true;
  // The sample count of the host's attachments (MSAA: the attachments, and their resolve, are the
  // host's). Must be one the device supports for colour and, with depth, depth attachments
  // (framebufferColorSampleCounts / framebufferDepthSampleCounts), else Renderer::create fails with
  // Unsupported.
  VkSampleCountFlagBits sampleCount = VK_SAMPLE_COUNT_1_BIT;
  // At one sample per pixel, a field fragment where a smooth surface turns away from the eye, or
  // beside an edge of its triangle whose neighbour faces away (faceted glass; Object's
  // TriangleEdges), writes the share of its pixel it covers as alpha, and the object pass blends it
  // over what the attachment holds (the background, or the host's scene drawn before): a
  // silhouette's pixels are no longer all glass or all background (docs/technique.md,
  // "Silhouettes and MSAA"). The
  // colour format must support blending (VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BLEND_BIT, else
  // Renderer::create fails with Unsupported); such a fragment still writes depth. Ignored with
  // MSAA (the samples cover the silhouette) and in ShadingMode::FieldExitDirection (its alpha is
  // the optical depth).
  bool silhouetteCoverage = true;
  // Taps per axis of each filtered environment lookup in the object pass, 1 to 4: n x n taps
  // over the parallelogram the looked-up direction sweeps across the pixel, each at the exit the
  // distortion image holds there. 4 (the default) follows exits that turn within a pixel (a rim,
  // a jump) and keeps a bright source's image to the pixel's box; 1 is one trilinear lookup with
  // a wider blur (docs/technique.md, "Taps"; costs in docs/performance.md). Outside 1..4 Renderer::create fails with
  // InvalidArgument.
  uint32_t environmentTapsPerAxis = 4;
  // An object whose Volume field is traced per fragment traces min(2, environmentTapsPerAxis)^2
  // paths a pixel; where one of them leaves more than 10 degrees from the pixel's centre path (a
  // bounce that changes within the pixel) and the transmitted light weighs at least half the
  // pixel's, it traces 4x4 instead, so that one sample per pixel averages both sides of the
  // discontinuity as supersampling does (docs/technique.md, "A volume traced per fragment"). Off:
  // the 2x2 paths everywhere, for a host bound by its object pass. Ignored with one tap per axis.
  bool refineVolumePaths = true;
};

// What the last recordObjects() call did.
struct DrawStats {
  uint32_t drawn = 0;   // draw calls recorded
  uint32_t culled = 0;  // objects left out: bounds outside the view frustum
};

struct RendererImpl;

class Renderer {
 public:
  static Result<std::unique_ptr<Renderer>> create(Context& context, const RendererCreateInfo& info);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // `extent` is the size of the host's viewport, for the camera's aspect ratio.
  // Lat-long and cube-map environments are both accepted (each has its own pipeline variant).
  void recordBackground(VkCommandBuffer cmd, const Environment& environment, const Camera& camera,
                        VkExtent2D extent);
  // Field mode (the default; an object without a field is drawn with the single interface): each
  // field object's distortion image must have been written for this camera's
  // eye by Decompressor::record() earlier on the same queue (outside the render pass); the
  // Decompressor leaves it in SHADER_READ_ONLY_OPTIMAL, visible to fragment shaders. An object
  // whose Volume field is traced per fragment (Object::tracesVolumePerFragment) reads no image:
  // each fragment traces its own path through the field's grid. Null entries
  // are skipped. Several objects in one call are drawn in order with depth testing. Objects whose
  // bounds lie outside the view frustum of (camera, extent) are not drawn (frustumCulling); the
  // Decompressor's camera overload leaves out the same objects.
  void recordObjects(VkCommandBuffer cmd, const Environment& environment, const Camera& camera, VkExtent2D extent,
                     std::span<Object* const> objects, ShadingMode mode = ShadingMode::Field);
  void recordObjects(VkCommandBuffer cmd, const Environment& environment, const Camera& camera, VkExtent2D extent,
                     std::initializer_list<Object*> objects, ShadingMode mode = ShadingMode::Field) {
    recordObjects(cmd, environment, camera, extent, std::span<Object* const>(objects.begin(), objects.size()), mode);
  }
  // Counts of the last recordObjects() call.
  const DrawStats& lastDrawStats() const;

 private:
  explicit Renderer(std::unique_ptr<RendererImpl> impl);
  std::unique_ptr<RendererImpl> impl_;
};

}  // namespace shrefract
