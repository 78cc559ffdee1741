// CPU reference of the run-time passes, for tests and tools: the same decompression
// (spirv/shaders/decompress.comp, decompress_table.comp, gutter.comp) and field shading
// (object_field_body.glsl), in the
// same float operations where it matters (clamping, normalization, thresholds), and a small ray
// caster that plays the rasterizer. Slow and simple on purpose; not for production rendering.
//
// What differs from the GPU, and why tests need a tolerance: the order of the float sums, the GPU's
// sqrt/inversesqrt/exp precision, its bilinear weights (fixed point on many devices, 8 bits on
// lavapipe), its RGBA16F environment (the reference samples the float image it is given; pass
// it through roundToBinary16 to match), its level-of-detail precision between the environment's
// levels (render's filtered lookups), and rasterization at triangle edges.
//
// All functions are thread-safe (no shared state).
#pragma once

#include <shrefract/field.h>
#include <shrefract/field_decode.h>
#include <shrefract/object.h>
#include <shrefract/renderer.h>

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace shrefract::reference {

using Vec3 = std::array<float, 3>;
using Vec4 = std::array<float, 4>;

// IEEE binary16 round trip (round to nearest even, saturating at +-65504 as the engine's uploads
// do): the value an RGBA16F image holds for `value`.
float roundToBinary16(float value);

// Texel `texel` (y * width + x) of the field decoded for the world-space eye position, as the
// decompression shaders compute it before the RGBA16F store (decompress.comp for Sh,
// decompress_table.comp for Table and Pca): for a sample texel,
//   w = M_s (eye, 1), w.z = max(w.z, 0) (zero counts as +z),
//   s = evaluateSample(field, texel, w) (field.h: the linear sum of any encoding, every channel),
//   xyz = s.xyz normalized, or zero if |s.xyz|^2 <= 1e-20;
//         times clamp(s.throughput, 0, 1) when field.throughput (the last channel),
//   w = s.tau clamped to +-65504 when the field has an optical depth channel, 0 otherwise;
// zero for empty and gutter texels. Preconditions: validateField(field) succeeded, texel in range.
// `order`: an SH field decoded at a lower order (Object::setDecodeOrder); ignored otherwise.
// eyeJump (optional): what the jump image holds for the texel (evaluateSample's eyeJump; the cap
// gpu::kJumpDistanceMaxCells for empty and gutter texels).
Vec4 decodeTexel(const Field& field, uint64_t texel, const Vec3& eye, uint32_t order = UINT32_MAX,
                 float* eyeJump = nullptr);

// A distortion image as the engine leaves it: width * height RGBA texels, row-major, each value
// representable in binary16.
struct DistortionImage {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<float> rgba;  // ((y * width) + x) * 4 + channel
  // The field has a throughput channel: |xyz| is the clamped throughput, not 1 (decompress sets it).
  bool throughput = false;
  // The jump image (R32F, gpu_layout.h kBindingJumpOut): per texel, the eye's distance from the
  // nearest jump of the texel's table, in cells. Empty, or all at gpu::kJumpDistanceMaxCells: no
  // jump is placed between texels (an image of exact paths, a field without the jump distance).
  std::vector<float> jump;
};

// The whole atlas for `eye`: decodeTexel for every texel, rounded to binary16, then every gutter
// rule target = a + b - c computed in float on the rounded values and rounded again. The jump
// image: each texel's eyeJump, then the same gutter rules in float, clamped to
// 0..gpu::kJumpDistanceMaxCells (gutter.comp).
// Precondition: validateField(field) succeeded.
DistortionImage decompress(const Field& field, const Vec3& eye, uint32_t order = UINT32_MAX);

// Bilinear sample at normalized coordinates (u, v), as a sampler with LINEAR filtering and
// CLAMP_TO_EDGE addressing: texel centres at ((i + 0.5) / width, (j + 0.5) / height), exact
// weights. Precondition: the image is not empty.
Vec4 sampleBilinear(const DistortionImage& image, float u, float v);

// A lat-long environment (shrefract/environment.h convention): width * height * 4 linear floats.
struct LatLongImage {
  uint32_t width = 0;
  uint32_t height = 0;
  const float* rgba = nullptr;
  // Levels 1.. of its chain (environmentLevels). Null or empty: every lookup reads level 0 (render()
  // builds the chain itself when it is null; an empty chain keeps it unfiltered).
  const std::vector<std::vector<float>>* levels = nullptr;
  // Taps per axis of sampleLatLongOverPixel, as RendererCreateInfo::environmentTapsPerAxis
  // (clamped to 1..kMaxEnvironmentTapsPerAxis).
  uint32_t tapsPerAxis = RendererCreateInfo{}.environmentTapsPerAxis;
  // As RendererCreateInfo::refineVolumePaths: shadeVolume traces a pixel whose paths disagree again
  // with kVolumeRefinedTapsPerAxis^2 paths.
  bool refineVolumePaths = RendererCreateInfo{}.refineVolumePaths;
  // Levels added to every filtered lookup's (sampleLatLong with a footprint), on top of
  // kEnvironmentLevelBias: 0 mirrors the engine's shaders; the CPU references choose their own
  // (bake::ReferenceOptions::environmentLevelBias).
  float levelBias = 0.0f;
};

// Levels 1 .. environmentLevelCount(width, height) - 1 of the chain the engine builds at upload
// (environment.cpp): level l, max(1, w >> l) x max(1, h >> l), is level l - 1 resampled
// bilinearly at its texel centres with clamp to edge, as a linear vkCmdBlitImage does (the 2x2 box
// where the size is even), every level rounded to binary16 as the RGBA16F image holds it (level 0
// is rounded before filtering; environment.rgba itself is left alone).
std::vector<std::vector<float>> environmentLevels(const LatLongImage& environment);

// The level selection of spirv/include/shrefract/environment.glsl, same float operations:
// the angle (radians) a unit direction with screen derivatives ddx, ddy spans across the pixel,
// 2 asin(min(max(|ddx|, |ddy|) / 2, 1)) ...
float directionFootprint(const Vec3& ddx, const Vec3& ddy);
// ... and the level for it, clamp(log2(max(footprint, 1e-30) / texelAngle) + kEnvironmentLevelBias,
// 0, maxLevel) (gpu_layout.h: 0).
// extraBias (LatLongImage::levelBias) is added to the bias before the clamp; 0 is the shaders'.
float environmentLevel(float footprint, float texelAngle, float maxLevel, float extraBias = 0.0f);
// Radians per level 0 texel: 2 pi / width (lat-long, at the equator), pi / (2 faceSize) (cube).
float latLongTexelAngle(float width);
float cubeTexelAngle(float faceSize);

// The exact unpolarized dielectric Fresnel reflectance of environment.glsl, same float
// operations: cosI clamped to [0, 1], eta = n_from / n_to; 1 under total internal reflection.
float fresnelDielectric(float cosI, float eta);

// Lookup in `direction` (any non-zero length) for a footprint of `footprint` radians across the
// pixel: bilinear in the two levels around environmentLevel(...) (repeat in u, clamp in v) and
// linear between them, as the engine's sampler does with its explicit level; level 0 alone when
// footprint is 0 or environment.levels is null. Precondition: the image is not empty.
Vec3 sampleLatLong(const LatLongImage& environment, const Vec3& direction, float footprint = 0.0f);

// The environment averaged over the pixel, as environment_select.glsl lookupEnvironmentOverPixel
// (same float operations): for `direction` with screen derivatives ddx, ddy, the mean of n^2
// sampleLatLong taps (n = environment.tapsPerAxis) at direction + a ddx + b ddy (a, b the cell
// centres of (-1/2, 1/2)), each with directionFootprint(ddx / n, ddy / n), one tap with that
// footprint times gpu::kOneTapFootprintScale; a tap that cancels to zero reads `direction`. Zero
// derivatives: sampleLatLong(environment, direction) once.
Vec3 sampleLatLongOverPixel(const LatLongImage& environment, const Vec3& direction, const Vec3& ddx, const Vec3& ddy);

// World direction of the centre of texel (i, j) of cube face `face` (0..5: +X, -X, +Y, -Y, +Z,
// -Z), not normalized; see CubeEnvironmentDesc.
Vec3 cubeTexelDirection(uint32_t face, uint32_t i, uint32_t j, uint32_t faceSize);

// What the fragment shader sees at a point of a field object's front surface.
struct SurfacePoint {
  Vec3 position{};        // world space
  Vec3 normal{};          // interpolated vertex normal (normalized inside)
  std::array<float, 2> uv{};  // normalized atlas coordinates
  float frontIor = 0.0f;  // n_inside / n_outside; 0: shading.ior
};

// Screen derivatives (fine, as the GPU's) of a fragment's two lookup directions, for
// sampleLatLongOverPixel; zero reads level 0 once. The field coordinate's derivatives place each
// transmitted tap in the distortion image (shadeField).
struct LookupDerivatives {
  Vec3 exitDx{}, exitDy{};            // the exit (refracted) direction
  Vec3 reflectedDx{}, reflectedDy{};  // the front reflection
  std::array<float, 2> uvDx{}, uvDy{};  // the field coordinate
  float cosViewDx = 0.0f, cosViewDy = 0.0f;  // the cosine between the view and the interpolated normal
  Vec3 positionDx{}, positionDy{};  // the surface point, in the space of SurfacePoint::position
  Vec3 normalDx{}, normalDy{};  // the interpolated normal as interpolated (SurfacePoint::normal)
};

// How far four texels' exits (unit vectors; zero for an empty texel, which agrees with every
// other) still spread once one jump may split them into two groups, in radians: the widest angle
// within a group, for the split that makes it narrowest (object_field_body.glsl; gpu_layout.h
// kSpatialScatterThreshold says what the raster pass does with it).
float scatterAfterOneJump(const std::array<Vec3, 4>& exits);

// The share of its pixel the fragment at `point` (object space, as `eye`) covers at a smooth
// silhouette, from the cosine between the view and the interpolated normal and its screen
// derivatives (object_field_body.glsl silhouetteCoverage; RendererCreateInfo::silhouetteCoverage):
// 1 where the cosine changes slowly.
float silhouetteCoverage(const SurfacePoint& point, const Vec3& eye, const LookupDerivatives& derivatives);

// The share of its pixel the fragment at `point` of a triangle with edge records `edges` covers
// beside the triangle's silhouette edges (object_field_body.glsl polygonCoverage): for each edge
// whose neighbour the eye sees from behind (or open), the distance inside it over its change
// across the pixel (|d/dx| + |d/dy|, the width of the pixel along the edge's normal), 0.5 at the
// edge and 1 half a pixel inside; the least of them, 1 without a silhouette edge. `point` and
// `eye` in the space of the mesh, as `edges` (triangleEdges).
float polygonCoverage(const TriangleEdges& edges, const SurfacePoint& point, const Vec3& eye,
                      const LookupDerivatives& derivatives);

// A shaded fragment's colour as the object pass leaves it at one sample per pixel: blended by its
// silhouette coverage (the smooth surface's, and where `edges` is given its triangle's polygon
// coverage: the lesser) over the background the pixel's ray `ray` (world space) reads there, the
// environment's level 0 (render() and the bake's renderDistortion both).
Vec3 overBackground(const Vec3& colour, const SurfacePoint& point, const Vec3& eye, const LookupDerivatives& derivatives,
                    const LatLongImage& environment, const Vec3& ray, const TriangleEdges* edges = nullptr);

// ShadingMode::Field for one fragment (see renderer.h), before the colour attachment's format
// conversion. `distortion` must be decompressed for the same eye. When distortion.throughput is
// set, the transmitted term is multiplied by min(|d.xyz|, 1) of the bilinear sample d, as the GPU
// does for an object whose field has a throughput channel (ObjectPushConstants.tint.a).
// `point` and `eye` are in the object's space; the exit and reflection directions are turned to
// world space with worldFromObject's rotation before the lookups, and the optical depth scaled by
// its scale, as the object pass does. `derivatives` filter the two lookups (sampleLatLongOverPixel);
// render() computes them as the GPU's fine derivatives do (pixelDerivatives). As the object pass,
// the exit's are then replaced by the gentler of its one-sided differences to the exits the
// distortion image holds one pixel away (uv -/+ uvDx, uvDy; object_field_body.glsl exitDerivative).
Vec3 shadeField(const DistortionImage& distortion, const LatLongImage& environment, const SurfacePoint& point,
                const Vec3& eye, const ObjectShading& shading, float exposure = 1.0f,
                const Transform& worldFromObject = Transform{}, const LookupDerivatives& derivatives = {});

// ShadingMode::Field for one fragment of an object whose Volume field is traced per fragment
// (Object::tracesVolumePerFragment; object_volume_body.glsl): the fragment's path, traceVolumePath
// at its position and its normal bent toward the viewer as shadeField bends it, gives the exit and
// the optical depth (clamped to +-kMaxOpticalDepth) of shadeField's formula, and where the field
// has a throughput channel the transmitted term is multiplied by the path's throughput clamped to
// [0, 1]. The transmitted light: the exit's derivatives (fine: pixelDerivatives traces the quad's
// neighbours too) without an axis across which the exit jumps beyond acos(kSpatialSplitCosine)
// while the other's does not, then min(kVolumeTracedTapsPerAxis, environment.tapsPerAxis)^2 paths
// traced at the centres of the pixel's cells (position and normal moved along positionDx, Dy and
// normalDx, Dy), each read over its cell with the remaining taps per axis (one path: the centre's,
// sampleLatLongOverPixel); where one of them leaves beyond acos(kVolumeRefineCosine) from the centre
// path's exit and the transmitted term weighs at least kVolumeRefineWeight ((1 - F) times the
// transmittance), kVolumeRefinedTapsPerAxis^2 paths instead (environment.refineVolumePaths).
// exitWorld (optional): the centre path's exit, in world space.
// Precondition: a Volume field.
Vec3 shadeVolume(const Field& volume, const LatLongImage& environment, const SurfacePoint& point, const Vec3& eye,
                 const ObjectShading& shading, float exposure = 1.0f, const Transform& worldFromObject = Transform{},
                 const LookupDerivatives& derivatives = {}, Vec3* exitWorld = nullptr);

// One object for render(): its mesh (positions, normals, uvs, frontIor, indices as in FieldMesh)
// and its decompressed image, or the Volume field it traces per fragment. Pointers must stay valid
// during render().
struct RenderObject {
  const FieldMesh* mesh = nullptr;
  const DistortionImage* distortion = nullptr;  // decompressed for the eye in object space
  ObjectShading shading;
  Transform worldFromObject;  // where the mesh is placed
  // Set: shaded by shadeVolume (and its exits in pixelDerivatives) instead, `distortion` unread.
  const Field* volume = nullptr;
};

struct RenderedImage {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<float> rgba;     // row 0 at the top, alpha 1
  std::vector<int32_t> object; // per pixel: index of the visible object, -1 for the background
  std::vector<float> directions; // per pixel: xyz of the unit world-space exit direction shaded there; 0 for the background
};

// World-space direction of the ray from the eye through the centre of pixel (x, y) (row 0 at the
// top), for the engine's projection (Vulkan clip space, y down). Not normalized.
Vec3 pixelRay(const Camera& camera, uint32_t width, uint32_t height, uint32_t x, uint32_t y);

// The ray caster's steps, for tools that cast rays against a field mesh themselves (the report's
// binned caster): one implementation, so both give the same pixels bit for bit.
struct TriangleHit {
  double t = 0.0, u = 0.0, v = 0.0;  // ray parameter and barycentrics of corners 1 and 2
};
// Triangle `first / 3` of `mesh` (first: the index of its first corner in mesh.indices) hit by the
// ray eye + t * ray, t > 0: Moller-Trumbore in double. Back faces (clockwise seen from the eye, as
// the GPU culls) and misses give nothing.
std::optional<TriangleHit> hitTriangle(const FieldMesh& mesh, uint32_t first, const std::array<double, 3>& eye,
                                       const std::array<double, 3>& ray);
// The fragment inputs at a hit: position, normal, uv and frontIor interpolated in double.
SurfacePoint surfacePointAt(const FieldMesh& mesh, uint32_t first, const TriangleHit& hit);
// The exit direction shadeField looks up at `point`: the bilinear distortion sample normalized, or
// the view direction where it vanishes.
Vec3 shadedExitDirection(const DistortionImage& distortion, const SurfacePoint& point, const Vec3& eye);

// The derivatives the object pass computes for pixel (x, y) where the visible surface is triangle
// `first / 3` of object.mesh: the world exit and reflection directions shaded at the centres of the
// pixel, of its 2x2 quad's neighbour in x (x ^ 1) and in y (y ^ 1), all on the plane of that
// triangle (its attributes extrapolated beyond its edges, as the GPU's helper lanes do), and their
// fine derivatives (odd minus even column, odd minus even row).
LookupDerivatives pixelDerivatives(const RenderObject& object, uint32_t first, const Camera& camera, uint32_t width,
                                   uint32_t height, uint32_t x, uint32_t y);

// The background pass and Field-mode objects, ray cast per pixel centre (each object in its own
// space: the ray brought into it by the inverse of worldFromObject): the nearest front-facing
// triangle (counter-clockwise seen from the eye, as the GPU culls) with its perspective-correct
// barycentric attributes, shaded with shadeField and pixelDerivatives' filtered lookups (the chain
// built with environmentLevels when environment.levels is null); the environment's level 0 in the
// ray's direction where no triangle is hit, as the background pass reads it. Near and far planes are ignored (scenes in tests sit well inside them).
// silhouetteCoverage: as RendererCreateInfo::silhouetteCoverage at one sample per pixel, each
// object pixel is blended with that background by its coverage (over the background only, where
// the GPU blends over whatever was drawn before).
RenderedImage render(const std::vector<RenderObject>& objects, const LatLongImage& environment, const Camera& camera,
                     uint32_t width, uint32_t height, float exposure = 1.0f, bool silhouetteCoverage = true);

// render()'s set-up and per-pixel operations, for renderers that choose their own pixels and rays
// (the bake's supersampled, binned renderDistortion): one implementation of the pixel, so that
// both give the same pixels bit for bit. Construction takes render()'s arguments and builds the
// environment's chain when environment.levels is null. Immutable after construction: pixel() may
// be called from any thread. The objects' meshes and images and the environment's pixels must
// outlive it.
class PixelRenderer {
 public:
  PixelRenderer(const std::vector<RenderObject>& objects, const LatLongImage& environment, const Camera& camera,
                uint32_t width, uint32_t height, float exposure = 1.0f, bool silhouetteCoverage = true);
  PixelRenderer(const PixelRenderer&) = delete;  // environment_ may point at levels_
  PixelRenderer& operator=(const PixelRenderer&) = delete;

  struct Pixel {
    Vec3 colour{};        // as render() writes it (alpha 1)
    Vec3 direction{};     // the unit world-space exit direction shaded there; zero for the background
    int32_t object = -1;  // the visible object, -1 for the background
  };

  // Pixel (x, y) of the width x height image, cast along `ray` (pixelRay(camera, width, height,
  // x, y), or the same bits computed another way). candidates: where given, the only triangles
  // tested (first indices into mesh.indices, in increasing order) of the one object there must be;
  // they must include every triangle the ray can hit (a caller's screen tiles). Null: every
  // triangle of every object, as render().
  Pixel pixel(uint32_t x, uint32_t y, const Vec3& ray, const std::vector<uint32_t>* candidates = nullptr) const;

 private:
  std::vector<RenderObject> objects_;
  std::vector<Vec3> objectEyes_;                  // the camera's eye in each object's space
  std::vector<std::vector<TriangleEdges>> edges_;  // per object, per triangle: polygon coverage
  std::vector<std::vector<float>> levels_;         // the chain, when the caller gave none
  LatLongImage environment_;                       // with its chain
  Camera camera_;
  uint32_t width_ = 0, height_ = 0;
  float exposure_ = 1.0f;
  bool silhouetteCoverage_ = true;
};

}  // namespace shrefract::reference
