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

// What renderDistortion's sub-samples share, built once: the supersampled camera, the binned mesh
// and reference::render's per-pixel set-up (the environment's chain, the triangles' edges).
struct DistortionScene {
  DistortionScene(const FieldMesh& m, const reference::DistortionImage& d, const Image& env,
                  const DistortionRenderOptions& options)
      : bigWidth(options.width * options.samplesPerAxis), bigHeight(options.height * options.samplesPerAxis),
        dirFromClip(directionFromClip(options.camera, bigWidth, bigHeight)),
        bins(binTriangles(m, options.camera, bigWidth, bigHeight)),
        pixels({reference::RenderObject{&m, &d, options.shading, Transform{}, options.volume}},
               reference::LatLongImage{env.width, env.height, env.rgba.data()}, options.camera, bigWidth, bigHeight,
               options.exposure) {}

  uint32_t bigWidth, bigHeight;
  glm::mat4 dirFromClip;
  TriangleBins bins;
  reference::PixelRenderer pixels;
};

// One sub-sample: reference::render's pixel (bx, by) of the big image, cast against the triangles
// of its tile only.
Sample distortionSample(const DistortionScene& c, uint32_t bx, uint32_t by) {
  const glm::vec3 ray = rayThrough(c.dirFromClip, c.bigWidth, c.bigHeight, bx, by);
  const std::vector<uint32_t>& tile = c.bins.tiles[size_t(by / kTile) * c.bins.tilesX + bx / kTile];
  const reference::PixelRenderer::Pixel p = c.pixels.pixel(bx, by, {ray.x, ray.y, ray.z}, &tile);
  Sample sample;
  sample.color = glm::vec3(p.colour[0], p.colour[1], p.colour[2]);
  sample.hit = p.object >= 0;
  sample.direction = glm::vec3(p.direction[0], p.direction[1], p.direction[2]);
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
