#include <shrefract/trace/reference_render.h>
#include <shrefract/cpu_reference.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <thread>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "reference/reference_common.h"

namespace shrefract::bake {

using namespace reference_detail;  // reference_common.h

namespace {

// Screen tiles of the binned ray caster: each lists, in increasing order, the front-facing
// triangles whose screen bounds (plus a pixel) cover one of its pixel centres.
constexpr uint32_t kTile = 16;

struct TriangleBins {
  uint32_t tilesX = 0, tilesY = 0;
  std::vector<std::vector<uint32_t>> tiles;  // first index of each triangle (into mesh.indices)
};

TriangleBins binTriangles(const FieldMesh& mesh, const Camera& camera, uint32_t width, uint32_t height) {
  TriangleBins bins;
  bins.tilesX = (width + kTile - 1) / kTile;
  bins.tilesY = (height + kTile - 1) / kTile;
  bins.tiles.resize(size_t(bins.tilesX) * bins.tilesY);
  glm::dmat4 proj = glm::perspectiveRH_ZO(glm::radians(double(camera.verticalFovDegrees)),
                                          double(width) / double(height), 1e-3, 1e3);
  proj[1][1] *= -1.0;
  const glm::dvec3 eye(camera.eye[0], camera.eye[1], camera.eye[2]);
  const glm::dmat4 view = glm::lookAtRH(eye, glm::dvec3(toVec(camera.target)), glm::dvec3(toVec(camera.up)));
  const glm::dmat4 clipFromWorld = proj * view;
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    glm::dvec3 p[3];
    for (int k = 0; k < 3; ++k) {
      const float* q = &mesh.positions[size_t(mesh.indices[t + size_t(k)]) * 3];
      p[k] = glm::dvec3(q[0], q[1], q[2]);
    }
    // reference::render's culling test, so the lists hold exactly the triangles it could pick.
    if (glm::dot(glm::cross(p[1] - p[0], p[2] - p[0]), eye - p[0]) <= 0.0) continue;
    double lo[2] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
    double hi[2] = {-lo[0], -lo[1]};
    bool behind = false;
    for (int k = 0; k < 3; ++k) {
      const glm::dvec4 c = clipFromWorld * glm::dvec4(p[k], 1.0);
      if (!(c.w > 1e-9)) {
        behind = true;
        break;
      }
      // Pixel coordinates with pixel centres at integers (pixel (x, y) centre: ndc = (x+0.5)/W*2-1).
      const double px = (c.x / c.w + 1.0) * 0.5 * width - 0.5, py = (c.y / c.w + 1.0) * 0.5 * height - 0.5;
      lo[0] = std::min(lo[0], px), hi[0] = std::max(hi[0], px);
      lo[1] = std::min(lo[1], py), hi[1] = std::max(hi[1], py);
    }
    // A triangle reaching behind the eye: every tile (its projection is not its screen bounds).
    const int64_t x0 = behind ? 0 : std::max<int64_t>(0, int64_t(std::floor(lo[0])) - 1);
    const int64_t x1 = behind ? int64_t(width) - 1 : std::min<int64_t>(int64_t(width) - 1, int64_t(std::ceil(hi[0])) + 1);
    const int64_t y0 = behind ? 0 : std::max<int64_t>(0, int64_t(std::floor(lo[1])) - 1);
    const int64_t y1 = behind ? int64_t(height) - 1 : std::min<int64_t>(int64_t(height) - 1, int64_t(std::ceil(hi[1])) + 1);
    if (x0 > x1 || y0 > y1) continue;
    for (int64_t ty = y0 / kTile; ty <= y1 / kTile; ++ty)
      for (int64_t tx = x0 / kTile; tx <= x1 / kTile; ++tx)
        bins.tiles[size_t(ty) * bins.tilesX + size_t(tx)].push_back(static_cast<uint32_t>(t));
  }
  return bins;
}

}  // namespace

namespace {

Result<void> checkDistortionInput(const FieldMesh& mesh, const reference::DistortionImage& distortion,
                                  const Image& env, const DistortionRenderOptions& o) {
  if (auto r = checkSize("distortion render", o.width, o.height, o.samplesPerAxis); !r) return r.error();
  if (env.width == 0 || env.rgba.size() != size_t(env.width) * env.height * 4)
    return makeError(ErrorCode::InvalidArgument, "distortion render: empty environment");
  if (o.volume && o.volume->encoding != Encoding::Volume)
    return makeError(ErrorCode::InvalidArgument, "distortion render: the field traced per fragment is not a Volume field");
  if (!o.volume && (distortion.width == 0 || distortion.height == 0 ||
                    distortion.rgba.size() != size_t(distortion.width) * distortion.height * 4))
    return makeError(ErrorCode::InvalidArgument, "distortion render: the distortion image is empty or its size disagrees");
  for (uint32_t index : mesh.indices)
    if (size_t(index) * 3 + 2 >= mesh.positions.size() || size_t(index) * 3 + 2 >= mesh.normals.size() ||
        size_t(index) * 2 + 1 >= mesh.uvs.size() || (!mesh.frontIor.empty() && index >= mesh.frontIor.size()))
      return makeError(ErrorCode::InvalidArgument, "distortion render: a mesh index is out of range");
  return {};
}

// What renderDistortion's sub-samples share: the supersampled camera, the binned mesh and the
// filtered environment, built once.
struct DistortionScene {
  DistortionScene(const FieldMesh& m, const reference::DistortionImage& d, const Image& env,
                  const DistortionRenderOptions& options)
      : o(options), mesh(m), distortion(d), bigWidth(options.width * options.samplesPerAxis),
        bigHeight(options.height * options.samplesPerAxis),
        dirFromClip(directionFromClip(options.camera, bigWidth, bigHeight)),
        bins(binTriangles(m, options.camera, bigWidth, bigHeight)),
        // reference::render's filtered lookups: the engine's level chain, built once.
        levels(reference::environmentLevels(reference::LatLongImage{env.width, env.height, env.rgba.data()})),
        latLong{env.width, env.height, env.rgba.data(), &levels},
        object{&m, &d, options.shading, Transform{}, options.volume},
        edges(triangleEdges(m.positions.data(), uint32_t(m.positions.size() / 3), m.indices.data(),
                            uint32_t(m.indices.size()))) {}
  DistortionScene(const DistortionScene&) = delete;  // latLong points at levels
  DistortionScene& operator=(const DistortionScene&) = delete;

  const DistortionRenderOptions& o;
  const FieldMesh& mesh;
  const reference::DistortionImage& distortion;
  uint32_t bigWidth, bigHeight;
  glm::mat4 dirFromClip;
  TriangleBins bins;
  std::vector<std::vector<float>> levels;
  reference::LatLongImage latLong;
  reference::RenderObject object;
  std::vector<TriangleEdges> edges;
};

// One sub-sample: reference::render's per-pixel operations for pixel (bx, by) of the big image.
Sample distortionSample(const DistortionScene& c, uint32_t bx, uint32_t by) {
  Sample sample;
  const DistortionRenderOptions& o = c.o;
  const glm::vec3 rayF = rayThrough(c.dirFromClip, c.bigWidth, c.bigHeight, bx, by);
  const std::array<double, 3> eyeD{o.camera.eye[0], o.camera.eye[1], o.camera.eye[2]};
  const std::array<double, 3> ray{rayF.x, rayF.y, rayF.z};
  std::optional<reference::TriangleHit> best;
  uint32_t bestTriangle = 0;
  for (uint32_t t : c.bins.tiles[size_t(by / kTile) * c.bins.tilesX + bx / kTile]) {
    const std::optional<reference::TriangleHit> hit = reference::hitTriangle(c.mesh, t, eyeD, ray);
    if (!hit || (best && hit->t >= best->t)) continue;
    best = hit;
    bestTriangle = t;
  }
  if (!best) {
    const reference::Vec3 env = reference::sampleLatLong(c.latLong, {rayF.x, rayF.y, rayF.z});
    sample.color = glm::vec3(env[0], env[1], env[2]);
    return sample;
  }
  // reference::render's per-sample operations, through its own functions.
  const reference::SurfacePoint point = reference::surfacePointAt(c.mesh, bestTriangle, *best);
  const reference::LookupDerivatives derivatives =
      reference::pixelDerivatives(c.object, bestTriangle, o.camera, c.bigWidth, c.bigHeight, bx, by);
  reference::Vec3 dir{};
  const reference::Vec3 shaded =
      o.volume ? reference::shadeVolume(*o.volume, c.latLong, point, o.camera.eye, o.shading, o.exposure, Transform{},
                                        derivatives, &dir)
               : reference::shadeField(c.distortion, c.latLong, point, o.camera.eye, o.shading, o.exposure, Transform{},
                                       derivatives);
  // Blended with the background by its silhouette coverage, as reference::render does by default.
  const reference::Vec3 covered = reference::overBackground(shaded, point, o.camera.eye, derivatives, c.latLong,
                                                            {rayF.x, rayF.y, rayF.z}, &c.edges[bestTriangle / 3]);
  sample.color = glm::vec3(covered[0], covered[1], covered[2]);
  sample.hit = true;
  if (!o.volume) dir = reference::shadedExitDirection(c.distortion, point, o.camera.eye);
  sample.direction = glm::vec3(dir[0], dir[1], dir[2]);
  return sample;
}

}  // namespace

Result<ReferenceImage> renderDistortion(const FieldMesh& mesh, const reference::DistortionImage& distortion,
                                        const Image& env, const DistortionRenderOptions& o) {
  if (auto r = checkDistortionInput(mesh, distortion, env, o); !r) return r.error();
  const auto start = Clock::now();
  ReferenceImage out = emptyImage(o.width, o.height);
  const uint32_t s = o.samplesPerAxis;
  const DistortionScene scene(mesh, distortion, env, o);
  out.rays = forEachRow(o.height, threadCount(o.threads), start, {}, [&](uint32_t y, uint64_t& rays) {
    for (uint32_t x = 0; x < o.width; ++x) {
      PixelAccumulator pixel;
      for (uint32_t j = 0; j < s; ++j)
        for (uint32_t i = 0; i < s; ++i) pixel.add(distortionSample(scene, x * s + i, y * s + j));
      pixel.store(out, size_t(y) * o.width + x, s * s);
    }
    rays += uint64_t(o.width) * s * s;
  });
  out.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return out;
}

}  // namespace shrefract::bake
