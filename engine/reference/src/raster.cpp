// The CPU mirror's pixel loop (cpu_reference.h render): the camera's rays, the nearest triangle in
// double precision, the fine derivatives of a 2x2 quad, and the shading of cpu_reference.cpp at
// every covered pixel.
#include <shrefract/cpu_reference.h>

#include <algorithm>
#include <tuple>
#include <utility>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include <shrefract/environment.h>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "core/half.h"
#include "environment/latlong.h"
#include "shrefract/gpu_layout.h"
#include "reference_internal.h"

namespace shrefract::reference {

Vec3 pixelRay(const Camera& camera, uint32_t width, uint32_t height, uint32_t x, uint32_t y) {
  const float aspect = height ? float(width) / float(height) : 1.0f;
  glm::mat4 proj = glm::perspectiveRH_ZO(glm::radians(camera.verticalFovDegrees), aspect, camera.nearPlane,
                                         camera.farPlane);
  proj[1][1] *= -1.0f;
  glm::mat4 view = glm::lookAtRH(toGlm(camera.eye), toGlm(camera.target), toGlm(camera.up));
  view[3] = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
  const glm::vec2 ndc((float(x) + 0.5f) / float(width) * 2.0f - 1.0f, (float(y) + 0.5f) / float(height) * 2.0f - 1.0f);
  return fromGlm(glm::vec3(glm::inverse(proj * view) * glm::vec4(ndc, 1.0f, 1.0f)));
}

std::optional<TriangleHit> hitTriangle(const FieldMesh& mesh, uint32_t first, const std::array<double, 3>& eyeIn,
                                       const std::array<double, 3>& rayIn) {
  const glm::dvec3 eye(eyeIn[0], eyeIn[1], eyeIn[2]), ray(rayIn[0], rayIn[1], rayIn[2]);
  glm::dvec3 p[3];
  for (int k = 0; k < 3; ++k) {
    const float* q = &mesh.positions[size_t(mesh.indices[first + uint32_t(k)]) * 3];
    p[k] = glm::dvec3(q[0], q[1], q[2]);
  }
  const glm::dvec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
  // Back faces (clockwise seen from the eye) are culled, as in the raster pipeline.
  if (glm::dot(glm::cross(e1, e2), eye - p[0]) <= 0.0) return std::nullopt;
  // Moller-Trumbore.
  const glm::dvec3 pv = glm::cross(ray, e2);
  const double det = glm::dot(e1, pv);
  if (std::fabs(det) < 1e-300) return std::nullopt;
  const glm::dvec3 tv = eye - p[0];
  const double u = glm::dot(tv, pv) / det;
  if (u < 0.0 || u > 1.0) return std::nullopt;
  const glm::dvec3 qv = glm::cross(tv, e1);
  const double v = glm::dot(ray, qv) / det;
  if (v < 0.0 || u + v > 1.0) return std::nullopt;
  const double t = glm::dot(e2, qv) / det;
  if (t <= 0.0) return std::nullopt;
  return TriangleHit{t, u, v};
}

SurfacePoint surfacePointAt(const FieldMesh& mesh, uint32_t first, const TriangleHit& hit) {
  const double bary[3] = {1.0 - hit.u - hit.v, hit.u, hit.v};
  double position[3] = {0, 0, 0}, normal[3] = {0, 0, 0}, uv[2] = {0, 0}, ior = 0.0;
  for (int k = 0; k < 3; ++k) {
    const size_t vtx = mesh.indices[first + uint32_t(k)];
    for (int c = 0; c < 3; ++c) {
      position[c] += bary[k] * double(mesh.positions[vtx * 3 + size_t(c)]);
      normal[c] += bary[k] * double(mesh.normals[vtx * 3 + size_t(c)]);
    }
    for (int c = 0; c < 2; ++c) uv[c] += bary[k] * double(mesh.uvs[vtx * 2 + size_t(c)]);
    ior += bary[k] * double(mesh.frontIor.empty() ? 0.0f : mesh.frontIor[vtx]);
  }
  SurfacePoint point;
  for (int c = 0; c < 3; ++c) {
    point.position[size_t(c)] = static_cast<float>(position[c]);
    point.normal[size_t(c)] = static_cast<float>(normal[c]);
  }
  point.uv = {static_cast<float>(uv[0]), static_cast<float>(uv[1])};
  point.frontIor = static_cast<float>(ior);
  return point;
}

LookupDerivatives pixelDerivatives(const RenderObject& object, uint32_t first, const Camera& camera, uint32_t width,
                                   uint32_t height, uint32_t x, uint32_t y) {
  const FieldMesh& mesh = *object.mesh;
  const Transform& placed = object.worldFromObject;
  const Vec3 eyeObject = inverseTransformPoint(placed, camera.eye);
  const glm::dvec3 eye(eyeObject[0], eyeObject[1], eyeObject[2]);
  glm::dvec3 p[3];
  for (int k = 0; k < 3; ++k) {
    const float* q = &mesh.positions[size_t(mesh.indices[first + uint32_t(k)]) * 3];
    p[k] = glm::dvec3(q[0], q[1], q[2]);
  }
  const glm::dvec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
  // The triangle's plane hit by the ray through pixel (px, py), barycentrics unbounded: what a
  // fragment of this triangle interpolates there, inside the triangle or not.
  auto fragmentAt = [&](uint32_t px, uint32_t py) {
    Vec3 rayObject = inverseRotateDirection(placed, pixelRay(camera, width, height, px, py));
    for (float& c : rayObject) c /= placed.scale;
    const glm::dvec3 ray(rayObject[0], rayObject[1], rayObject[2]);
    const glm::dvec3 pv = glm::cross(ray, e2);
    const double det = glm::dot(e1, pv);
    const glm::dvec3 tv = eye - p[0];
    const glm::dvec3 qv = glm::cross(tv, e1);
    TriangleHit hit{0.0, 0.0, 0.0};
    if (std::fabs(det) > 1e-300) hit = TriangleHit{glm::dot(e2, qv) / det, glm::dot(tv, pv) / det, glm::dot(ray, qv) / det};
    const SurfacePoint point = surfacePointAt(mesh, first, hit);
    return std::tuple{objectFragment(object, point, eyeObject), toGlm(point.position), toGlm(point.normal)};
  };
  const auto [self, selfPosition, selfNormal] = fragmentAt(x, y);
  const auto [nx, nxPosition, nxNormal] = fragmentAt(x ^ 1u, y);
  const auto [ny, nyPosition, nyNormal] = fragmentAt(x, y ^ 1u);
  // Fine derivatives: odd column minus even column, odd row minus even row.
  const float sx = (x & 1u) ? 1.0f : -1.0f, sy = (y & 1u) ? 1.0f : -1.0f;
  LookupDerivatives out;
  out.exitDx = fromGlm(sx * (self.exitWorld - nx.exitWorld));
  out.exitDy = fromGlm(sy * (self.exitWorld - ny.exitWorld));
  out.reflectedDx = fromGlm(sx * (self.reflectedWorld - nx.reflectedWorld));
  out.reflectedDy = fromGlm(sy * (self.reflectedWorld - ny.reflectedWorld));
  out.cosViewDx = sx * (self.cosView - nx.cosView);
  out.cosViewDy = sy * (self.cosView - ny.cosView);
  out.positionDx = fromGlm(sx * (selfPosition - nxPosition));
  out.positionDy = fromGlm(sy * (selfPosition - nyPosition));
  out.normalDx = fromGlm(sx * (selfNormal - nxNormal));
  out.normalDy = fromGlm(sy * (selfNormal - nyNormal));
  for (int k = 0; k < 2; ++k) {
    out.uvDx[size_t(k)] = sx * (self.uv[k] - nx.uv[k]);
    out.uvDy[size_t(k)] = sy * (self.uv[k] - ny.uv[k]);
  }
  return out;
}

Vec3 shadedExitDirection(const DistortionImage& distortion, const SurfacePoint& point, const Vec3& eye) {
  const Vec4 d = sampleBilinear(distortion, point.uv[0], point.uv[1]);
  glm::vec3 dir(d[0], d[1], d[2]);
  const float len2 = glm::dot(dir, dir);
  dir = len2 > gpu::kMinDirectionLength2 ? dir / std::sqrt(len2) : glm::normalize(toGlm(point.position) - toGlm(eye));
  return fromGlm(dir);
}

namespace {

// The nearest triangle any object's mesh puts under the ray, each tested in its object space.
struct NearestHit {
  std::optional<TriangleHit> hit;
  int object = -1;
  uint32_t triangle = 0;
};

// Double precision for the ray-triangle test: the GPU's coverage is exact for pixel centres away
// from edges, and so should the reference be. Each object's eye, and the ray, in its object space:
// t is the same along both (the eye and the ray are divided by the same scale), so hits of
// different objects compare as they are. candidates: only these triangles of objects[0].
NearestHit nearestHit(const std::vector<RenderObject>& objects, const std::vector<Vec3>& objectEyes, const Vec3& rayF,
                      const std::vector<uint32_t>* candidates) {
  auto toDouble = [](const Vec3& v) { return std::array<double, 3>{v[0], v[1], v[2]}; };
  NearestHit best;
  for (size_t o = 0; o < objects.size(); ++o) {
    const FieldMesh& mesh = *objects[o].mesh;
    const Transform& placed = objects[o].worldFromObject;
    Vec3 rayObject = inverseRotateDirection(placed, rayF);
    for (float& c : rayObject) c /= placed.scale;
    const std::array<double, 3> eye = toDouble(objectEyes[o]), ray = toDouble(rayObject);
    auto test = [&](uint32_t t) {
      const std::optional<TriangleHit> hit = hitTriangle(mesh, t, eye, ray);
      if (!hit || (best.hit && hit->t >= best.hit->t)) return;
      best = {hit, static_cast<int>(o), t};
    };
    if (candidates) {
      for (uint32_t t : *candidates) test(t);
    } else {
      for (uint32_t t = 0; size_t(t) + 2 < mesh.indices.size(); t += 3) test(t);
    }
  }
  return best;
}

}  // namespace

PixelRenderer::PixelRenderer(const std::vector<RenderObject>& objects, const LatLongImage& environment,
                             const Camera& camera, uint32_t width, uint32_t height, float exposure,
                             bool silhouetteCoverage)
    : objects_(objects), environment_(environment), camera_(camera), width_(width), height_(height),
      exposure_(exposure), silhouetteCoverage_(silhouetteCoverage) {
  // The chain the engine builds at upload, unless the caller has it already.
  if (!environment_.levels) {
    levels_ = environmentLevels(environment);
    environment_.levels = &levels_;
  }
  for (const RenderObject& object : objects_) {
    objectEyes_.push_back(inverseTransformPoint(object.worldFromObject, camera.eye));
    edges_.push_back(triangleEdges(object.mesh->positions.data(), uint32_t(object.mesh->positions.size() / 3),
                                   object.mesh->indices.data(), uint32_t(object.mesh->indices.size())));
  }
}

// The background, level 0 (sampleLatLong without a footprint), reads environment_'s pixels alone,
// whatever chain it carries.
PixelRenderer::Pixel PixelRenderer::pixel(uint32_t x, uint32_t y, const Vec3& ray,
                                          const std::vector<uint32_t>* candidates) const {
  Pixel out;
  const NearestHit best = nearestHit(objects_, objectEyes_, ray, candidates);
  if (best.object < 0) {
    out.colour = sampleLatLong(environment_, ray);
    return out;
  }
  const RenderObject& object = objects_[size_t(best.object)];
  const SurfacePoint point = surfacePointAt(*object.mesh, best.triangle, *best.hit);
  const Vec3& eye = objectEyes_[size_t(best.object)];
  const LookupDerivatives derivatives = pixelDerivatives(object, best.triangle, camera_, width_, height_, x, y);
  const Vec3 c = object.volume ? shadeVolume(*object.volume, environment_, point, eye, object.shading, exposure_,
                                             object.worldFromObject, derivatives, &out.direction)
                               : shadeField(*object.distortion, environment_, point, eye, object.shading, exposure_,
                                            object.worldFromObject, derivatives);
  if (!object.volume)
    out.direction = rotateDirection(object.worldFromObject, shadedExitDirection(*object.distortion, point, eye));
  out.colour = silhouetteCoverage_ ? overBackground(c, point, eye, derivatives, environment_, ray,
                                                    &edges_[size_t(best.object)][best.triangle / 3])
                                   : c;
  out.object = best.object;
  return out;
}

RenderedImage render(const std::vector<RenderObject>& objects, const LatLongImage& environment, const Camera& camera,
                     uint32_t width, uint32_t height, float exposure, bool silhouetteCoverage) {
  const PixelRenderer renderer(objects, environment, camera, width, height, exposure, silhouetteCoverage);
  RenderedImage image;
  image.width = width;
  image.height = height;
  image.rgba.assign(size_t(width) * height * 4, 0.0f);
  image.object.assign(size_t(width) * height, -1);
  image.directions.assign(size_t(width) * height * 3, 0.0f);
  for (uint32_t py = 0; py < height; ++py)
    for (uint32_t px = 0; px < width; ++px) {
      const PixelRenderer::Pixel p = renderer.pixel(px, py, pixelRay(camera, width, height, px, py));
      const size_t at = size_t(py) * width + px;
      for (int k = 0; k < 3; ++k) image.rgba[at * 4 + size_t(k)] = p.colour[size_t(k)];
      image.rgba[at * 4 + 3] = 1.0f;
      image.object[at] = p.object;
      for (int k = 0; k < 3; ++k) image.directions[at * 3 + size_t(k)] = p.direction[size_t(k)];
    }
  return image;
}

}  // namespace shrefract::reference
