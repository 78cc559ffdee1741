// The raster pass: the environment as background and refractive objects over it, drawn with
// dynamic rendering into attachments the host provides.
//
// Objects are static world-space meshes. An object created from a refraction field
// (Object::createFromField) also owns the field's GPU data and its distortion image; the
// Decompressor (shrefract/decompressor.h) fills that image for the current eye, and
// ShadingMode::Field samples it.
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

#include <array>
#include <cstdint>
#include <memory>
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

// A triangle mesh in world space with per-vertex unit normals and (optional) field texture
// coordinates. Static: fields are baked in world space. Front faces wind counter-clockwise seen
// from outside; back faces are culled.
struct MeshDesc {
  const float* positions = nullptr;  // vertexCount * 3
  const float* normals = nullptr;    // vertexCount * 3
  const float* fieldUvs = nullptr;   // vertexCount * 2 normalized atlas coordinates, or nullptr
  // vertexCount values n_inside / n_outside of the surface the eye sees (> 0), or nullptr: then
  // ObjectShading::ior applies to the whole mesh.
  const float* frontIor = nullptr;
  uint32_t vertexCount = 0;
  const uint32_t* indices = nullptr;  // triangle list, indexCount / 3 triangles
  uint32_t indexCount = 0;
};

// Run-time shading parameters of an object; cheap to change every frame.
struct ObjectShading {
  float ior = 1.5f;                         // front-surface IOR where the mesh has no frontIor
  float absorptionScale = 1.0f;             // k in exp2(-tau * k) (Field mode)
  std::array<float, 3> tint{1.0f, 1.0f, 1.0f};  // attenuation colour, multiplies the transmitted light
  bool reflection = true;                   // add the front-surface Fresnel reflection
};

struct ObjectImpl;

class Object {
 public:
  // Creates the vertex and index buffers and records their upload into `cmd` (see Environment).
  static Result<std::unique_ptr<Object>> create(Context& context, const MeshDesc& mesh, VkCommandBuffer cmd);

  // Creates an object from a refraction field: the render mesh (field.mesh, with its atlas
  // coordinates and per-vertex frontIor) and the field's GPU data, uploaded through `cmd` (a host
  // command buffer in the recording state, on the context's queue family; staging buffers are
  // retired through the context's deferred destruction):
  //  - coefficients of the sample texels only, in one buffer (read as a texel buffer, or as a
  //    storage buffer beyond the device's texel-buffer limit): Sh, one plane per basis function and
  //    stored channel (x, y, z of the exit direction, then tau and the throughput where the field
  //    has them); Table and Pca, each sample's values contiguous; bytes (U8, with the
  //    per-(layer, value) scale/bias in a second buffer) or binary16 (F16); layout in gpu_layout.h;
  //  - the samples' frames M_s (3 vec4 rows per sample), their texel indices, the gutter rules and
  //    (Pca) the basis functions as storage buffers;
  //  - the distortion image: width x height R16G16B16A16_SFLOAT, cleared to zero (empty texels stay
  //    zero for the object's lifetime).
  // After `cmd` executes, the distortion image is in SHADER_READ_ONLY_OPTIMAL and every upload is
  // visible to compute and fragment shaders.
  // Errors: CorruptData when validateField rejects the field; Unsupported when the atlas exceeds
  // the device's 2D image limit, the coefficients both its texel and storage buffer limits (or, for
  // Table and Pca, 2^32 values), or the samples' frames or the basis its storage buffer range;
  // Vulkan on allocation failures.
  static Result<std::unique_ptr<Object>> createFromField(Context& context, const Field& field, VkCommandBuffer cmd);
  // readField(path), then createFromField. Errors name the file.
  static Result<std::unique_ptr<Object>> createFromFieldFile(Context& context, const std::string& path,
                                                             VkCommandBuffer cmd);

  // Retires every resource through the context's deferred destruction: safe while command buffers
  // that use the object are in flight, as long as the host keeps calling Context::beginFrame().
  ~Object();
  Object(const Object&) = delete;
  Object& operator=(const Object&) = delete;

  bool hasField() const;
  // The field's SH order (0 for Table and Pca fields) and atlas size (0 without a field).
  uint32_t fieldOrder() const;
  VkExtent2D fieldExtent() const;
  // The distortion image (R16G16B16A16_SFLOAT, extent fieldExtent(), one level, one layer;
  // VK_NULL_HANDLE without a field): texel (x, y) holds the decoded exit direction (xyz, unit, or
  // zero for empty texels; for a field with throughput, of length the clamped throughput) and
  // optical depth (w) for the eye of the last decompression. Between
  // engine passes it is in SHADER_READ_ONLY_OPTIMAL. Created with TRANSFER_SRC usage so that tools
  // and tests can copy it out; a host that does must return it to SHADER_READ_ONLY_OPTIMAL with its
  // contents kept (from the layout it used, not UNDEFINED): empty texels are never rewritten.
  VkImage distortionImage() const;
  // Forgets which eye the distortion image was decompressed for, so that the next
  // Decompressor::record() rewrites it. Needed only by a host that records a decompression into a
  // command buffer it then never submits, or that writes the image itself (see decompressor.h).
  void invalidateDistortion();

  // World-space axis-aligned bounds of the mesh (what view-frustum culling tests).
  std::array<float, 3> boundsMin() const;
  std::array<float, 3> boundsMax() const;
  // Device memory the object holds: the sum of the memory requirements of its buffers and images
  // (mesh; for a field also coefficients, scale/bias, frames, sample texel indices, gutter rules,
  // the Pca basis and the distortion image). Staging memory of the upload is not counted (released after it).
  uint64_t gpuMemoryBytes() const;

  ObjectShading shading;
  ObjectImpl& impl() { return *impl_; }
  const ObjectImpl& impl() const { return *impl_; }

 private:
  explicit Object(std::unique_ptr<ObjectImpl> impl);
  std::unique_ptr<ObjectImpl> impl_;
};

enum class ShadingMode : uint32_t {
  SingleInterface = 0,  // one Snell bend at the front surface (what engines usually ship)
  // The refraction field: the distortion image, bilinearly sampled at the fragment's atlas
  // coordinate, gives the exit direction d and optical depth tau; the colour is
  //   (1 - F) * exp2(-max(tau, 0) * k) * tint * env(d) + F * env(reflect(v, n))
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

struct RendererCreateInfo {
  VkFormat colorFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
  VkFormat depthFormat = VK_FORMAT_D32_SFLOAT;  // VK_FORMAT_UNDEFINED: no depth attachment
  float exposure = 1.0f;
  // recordObjects() leaves out objects whose bounds lie outside the camera's view frustum (they
  // would produce no fragment). Off only to measure what culling saves.
  bool frustumCulling = true;
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
  // Field mode: each field object's distortion image must have been written for this camera's
  // eye by Decompressor::record() earlier on the same queue (outside the render pass); the
  // Decompressor leaves it in SHADER_READ_ONLY_OPTIMAL, visible to fragment shaders. Null entries
  // are skipped. Several objects in one call are drawn in order with depth testing. Objects whose
  // bounds lie outside the view frustum of (camera, extent) are not drawn (frustumCulling); the
  // Decompressor's camera overload leaves out the same objects.
  void recordObjects(VkCommandBuffer cmd, const Environment& environment, const Camera& camera, VkExtent2D extent,
                     const std::vector<Object*>& objects, ShadingMode mode = ShadingMode::SingleInterface);
  // Counts of the last recordObjects() call.
  const DrawStats& lastDrawStats() const;

 private:
  explicit Renderer(std::unique_ptr<RendererImpl> impl);
  std::unique_ptr<RendererImpl> impl_;
};

}  // namespace shrefract
