// shrefract::Object: a static refractive mesh placed in the world, optionally with a refraction
// field (its GPU data and a distortion image). One upload can be drawn as many instances.
#pragma once

#include <shrefract/context.h>
#include <shrefract/field.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace shrefract {

// A triangle mesh in object space with per-vertex unit normals and (optional) field texture
// coordinates. Static: a field is baked in the space of its mesh, which is the object space of
// every instance drawn from it. Front faces wind counter-clockwise seen from outside; back faces
// are culled.
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

// One triangle's edges as the field's object pass reads them for polygon silhouette coverage
// (RendererCreateInfo::silhouetteCoverage; gpu_layout.h TriangleEdges, the same bytes). Edge k
// runs from corner k to corner k + 1 (mod 3) of the triangle as indexed. edge[k] = (m, m . a): the
// unit normal of the edge in the triangle's plane, pointing into the triangle, and its offset, so
// that m . p - w is p's distance inside the edge. neighbour[k] = (n', n' . a): the unit normal of
// the triangle across the edge (its corners' positions equal, traversed the other way) and its
// offset, so that an eye e with n' . e - w <= 0 sees that triangle from behind and the edge as a
// silhouette; (0, 0, 0, 1) for an open edge (always a silhouette), (0, 0, 0, -1) for the edges of a
// degenerate triangle (never).
struct TriangleEdges {
  std::array<std::array<float, 4>, 3> edge{};
  std::array<std::array<float, 4>, 3> neighbour{};
};
// The records of a triangle list, one per triangle in index order (corners welded by equal
// positions, so that split normals and atlas seams still find their neighbours).
std::vector<TriangleEdges> triangleEdges(const float* positions, uint32_t vertexCount, const uint32_t* indices,
                                         uint32_t indexCount);

// Run-time shading parameters of an object; cheap to change every frame.
struct ObjectShading {
  float ior = 1.5f;                         // front-surface IOR where the mesh has no frontIor
  // k in exp(-tau * k * scale) (Field mode; tau in object units): Beer-Lambert in natural units,
  // so 1 renders a medium's absorption (e.g. glTF's attenuationDistance) as it was defined.
  float absorptionScale = 1.0f;
  // Colour of the transmitted light (multiplies it in every mode): createFromField sets the colour
  // of the field's front medium (frontMediumColor, field.h); white for Object::create.
  std::array<float, 3> tint{1.0f, 1.0f, 1.0f};
  bool reflection = true;                   // add the front-surface Fresnel reflection
};

// Where an object is drawn: world = translation + scale * rotate(rotation, object). Rotation and
// uniform scale keep the field valid (directions turn with the object; lengths, and so optical
// depths, scale by `scale`); a shear or non-uniform scale would not, so there is none.
struct Transform {
  std::array<float, 4> rotation{0.0f, 0.0f, 0.0f, 1.0f};  // unit quaternion (x, y, z, w)
  std::array<float, 3> translation{0.0f, 0.0f, 0.0f};
  float scale = 1.0f;  // > 0
};

// The point and direction maps of a transform (normalizes the quaternion; shared by the passes,
// the CPU reference and hosts that place cameras relative to objects).
std::array<float, 3> transformPoint(const Transform& worldFromObject, const std::array<float, 3>& objectPoint);
std::array<float, 3> inverseTransformPoint(const Transform& worldFromObject, const std::array<float, 3>& worldPoint);
std::array<float, 3> rotateDirection(const Transform& worldFromObject, const std::array<float, 3>& objectDirection);
std::array<float, 3> inverseRotateDirection(const Transform& worldFromObject, const std::array<float, 3>& worldDirection);

struct ObjectImpl;

class Object {
 public:
  // Creates the vertex and index buffers and the triangles' edge records (TriangleEdges, 96 bytes
  // a triangle, for the field pass's polygon silhouette coverage) and records their upload into
  // `cmd` (see Environment). The index buffer turns each triangle's corners (winding kept) so that
  // its first corner starts no other triangle, appending copies of vertices where needed: each
  // vertex carries the index of the triangle it starts.
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

  // Another instance of `source`'s mesh and field, sharing their GPU data (nothing is uploaded
  // again; the shared data lives until the last instance is released): it has its own
  // worldFromObject, shading and distortion image (cleared through `cmd`, as createFromField does;
  // decompressed for the eye as this instance sees it). Starts with source's transform and shading.
  // Device memory per instance: its distortion image (gpuMemoryBytes()).
  static Result<std::unique_ptr<Object>> createInstance(Context& context, const Object& source, VkCommandBuffer cmd);

  // Retires every resource through the context's deferred destruction: safe while command buffers
  // that use the object are in flight, as long as the host keeps calling Context::beginFrame().
  ~Object();
  Object(const Object&) = delete;
  Object& operator=(const Object&) = delete;

  bool hasField() const;
  // The field's SH order as baked (0 for Table and Pca fields) and atlas size (0 without a field).
  uint32_t fieldOrder() const;
  VkExtent2D fieldExtent() const;
  // The SH order this object decodes with, 0..fieldOrder() (default: fieldOrder()): the first
  // (order + 1)^2 bands of the same upload, chosen at run time per object and per instance (e.g.
  // by screen coverage: coverageOrder in shrefract/decompressor.h). A change decodes the object
  // again at the next Decompressor::record(). Error (InvalidArgument): above fieldOrder(), or an
  // object without a field.
  Result<void> setDecodeOrder(uint32_t order);
  uint32_t decodeOrder() const;
  // A Volume field (field.h Encoding::Volume) is shaded per fragment by default: the raster pass
  // traces each fragment's own path through the field's distance grid at its interpolated
  // position and normal (ShadingMode::Field and FieldExitDirection), and Decompressor::record
  // leaves the object out; nothing is interpolated between the field's sample texels, whose
  // spacing then costs nothing (docs/encodings.md, "Volume traced per fragment"). false: the
  // texture-space path of the other encodings (the Decompressor traces the sample texels into the
  // distortion image, which the raster pass samples), whose cost follows the samples, not the
  // pixels, and is paid only when the eye moves. Per object and per instance. Errors:
  // InvalidArgument, an object without a Volume field; Unsupported, per fragment where the grid
  // exceeds the device's maxTexelBufferElements (such an object starts with false).
  bool tracesVolumePerFragment() const;
  Result<void> setTracesVolumePerFragment(bool perFragment);
  // The distortion image (R16G16B16A16_SFLOAT, extent fieldExtent(), one level, one layer;
  // VK_NULL_HANDLE without a field): texel (x, y) holds the decoded exit direction (xyz, unit, or
  // zero for empty texels; for a field with throughput, of length the clamped throughput) and
  // optical depth (w) for the eye of the last decompression. Between
  // engine passes it is in SHADER_READ_ONLY_OPTIMAL. Created with TRANSFER_SRC usage so that tools
  // and tests can copy it out; a host that does must return it to SHADER_READ_ONLY_OPTIMAL with its
  // contents kept (from the layout it used, not UNDEFINED): empty texels are never rewritten.
  VkImage distortionImage() const;
  // The jump image (R32_SFLOAT, the same extent, level, layer, layout and usage): texel (x, y)
  // holds how far the eye's view lies from the nearest jump of that sample's table, in table cells
  // (gpu_layout.h kBindingJumpOut), for the same decompression; 1 (no jump within a cell) where
  // nothing is decoded or the field stores no jump distance. The raster pass places jumps between
  // texels with it (docs/technique.md, "Jumps across texels").
  VkImage jumpImage() const;
  // Forgets which eye the distortion image was decompressed for, so that the next
  // Decompressor::record() rewrites it. Needed only by a host that records a decompression into a
  // command buffer it then never submits, or that writes the image itself (see decompressor.h).
  void invalidateDistortion();

  // World-space axis-aligned bounds of the mesh placed by worldFromObject (what view-frustum
  // culling tests), and its object-space bounds.
  std::array<float, 3> boundsMin() const;
  std::array<float, 3> boundsMax() const;
  std::array<float, 3> objectBoundsMin() const;
  std::array<float, 3> objectBoundsMax() const;
  // Device memory the object allocated: the sum of the memory requirements of its buffers and
  // images (mesh and its triangle edges; for a field also coefficients, scale/bias, frames, sample texel indices, gutter
  // rules, the Pca basis and the distortion image; for an instance its distortion image only).
  // Staging memory of the upload is not counted (released after it).
  uint64_t gpuMemoryBytes() const;

  Transform worldFromObject;  // cheap to change every frame (a moved object is decoded again)
  ObjectShading shading;

 private:
  friend struct ObjectAccess;  // the engine's passes (engine/src)
  explicit Object(std::shared_ptr<ObjectImpl> impl);
  std::shared_ptr<ObjectImpl> impl_;  // shared with the engine's deferred destruction
};

}  // namespace shrefract
