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

namespace shrefract::reference {
namespace {

glm::vec3 toGlm(const Vec3& v) { return {v[0], v[1], v[2]}; }
Vec3 fromGlm(const glm::vec3& v) { return {v.x, v.y, v.z}; }

const float* texelAt(const DistortionImage& image, uint32_t x, uint32_t y) {
  return &image.rgba[(size_t(y) * image.width + x) * 4];
}

}  // namespace

float fresnelDielectric(float cosI, float eta) {
  cosI = std::clamp(cosI, 0.0f, 1.0f);
  const float sin2T = eta * eta * std::max(0.0f, 1.0f - cosI * cosI);
  if (sin2T >= 1.0f) return 1.0f;
  const float cosT = std::sqrt(1.0f - sin2T);
  const float rs = (eta * cosI - cosT) / (eta * cosI + cosT);
  const float rp = (cosI - eta * cosT) / (cosI + eta * cosT);
  return 0.5f * (rs * rs + rp * rp);
}

float roundToBinary16(float value) { return halfToFloat(floatToHalf(value)); }

Vec4 decodeTexel(const Field& field, uint64_t texel, const Vec3& eye, uint32_t order, float* eyeJump) {
  if (eyeJump) *eyeJump = gpu::kJumpDistanceMaxCells;
  if (field.texelKinds[texel] != kTexelSample) return {0.0f, 0.0f, 0.0f, 0.0f};
  const float* m = &field.frames[texel * 12];
  std::array<float, 3> w{};
  for (int k = 0; k < 3; ++k) w[k] = m[4 * k] * eye[0] + m[4 * k + 1] * eye[1] + m[4 * k + 2] * eye[2] + m[4 * k + 3];
  // A Volume field's decode reads how far below its tangent plane the eye is (traceVolumeSample).
  if (field.encoding != Encoding::Volume) w[2] = std::max(w[2], 0.0f);
  float sum[5] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  evaluateSample(field, texel, w, sum, order, eyeJump);
  // As decompress_common.glsl (distortionTexel).
  const float tau = field.hasOpticalDepth() ? std::clamp(sum[3], -gpu::kMaxOpticalDepth, gpu::kMaxOpticalDepth) : 0.0f;
  Vec4 out{0.0f, 0.0f, 0.0f, tau};
  const float len2 = sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2];
  if (len2 > gpu::kMinDirectionLength2) {
    const float inv = 1.0f / std::sqrt(len2);
    for (int k = 0; k < 3; ++k) out[k] = sum[k] * inv;
    if (field.throughput) {
      const float throughput = std::clamp(sum[field.throughputChannel()], 0.0f, 1.0f);
      for (int k = 0; k < 3; ++k) out[k] *= throughput;
    }
  }
  return out;
}

DistortionImage decompress(const Field& field, const Vec3& eye, uint32_t order) {
  DistortionImage image;
  image.width = field.width;
  image.height = field.height;
  image.throughput = field.throughput;
  image.rgba.resize(size_t(field.texelCount()) * 4);
  image.jump.resize(size_t(field.texelCount()));
  for (uint64_t t = 0; t < field.texelCount(); ++t) {
    const Vec4 v = decodeTexel(field, t, eye, order, &image.jump[t]);
    for (int c = 0; c < 4; ++c) image.rgba[t * 4 + c] = roundToBinary16(v[c]);
  }
  // Rules read sample texels only (validateField), so the order of application does not matter.
  for (const GutterTexel& g : field.gutters) {
    for (int c = 0; c < 4; ++c)
      image.rgba[size_t(g.target) * 4 + c] = roundToBinary16(image.rgba[size_t(g.a) * 4 + c] +
                                                             image.rgba[size_t(g.b) * 4 + c] -
                                                             image.rgba[size_t(g.c) * 4 + c]);
    image.jump[g.target] = std::clamp(image.jump[g.a] + image.jump[g.b] - image.jump[g.c], 0.0f,
                                      gpu::kJumpDistanceMaxCells);
  }
  return image;
}

namespace {
// The four texels around (u, v) as the sampler addresses them (texel centres at half-integers,
// clamped to the edge), in the order (x0, y0), (x1, y0), (x0, y1), (x1, y1), and where (u, v)
// lies between them: shared by sampleBilinear and the raster mirror's readCell.
struct BilinearCorners {
  std::array<const float*, 4> texel{};
  float ax = 0.0f, ay = 0.0f;  // the fractions along x and y
  std::array<float, 4> weights() const {
    return {(1.0f - ax) * (1.0f - ay), ax * (1.0f - ay), (1.0f - ax) * ay, ax * ay};
  }
};

BilinearCorners bilinearCorners(const DistortionImage& image, float u, float v) {
  const float x = u * float(image.width) - 0.5f;
  const float y = v * float(image.height) - 0.5f;
  const float fx = std::floor(x), fy = std::floor(y);
  auto clampX = [&](float i) { return static_cast<uint32_t>(std::clamp(i, 0.0f, float(image.width - 1))); };
  auto clampY = [&](float j) { return static_cast<uint32_t>(std::clamp(j, 0.0f, float(image.height - 1))); };
  const uint32_t x0 = clampX(fx), x1 = clampX(fx + 1.0f), y0 = clampY(fy), y1 = clampY(fy + 1.0f);
  return {{texelAt(image, x0, y0), texelAt(image, x1, y0), texelAt(image, x0, y1), texelAt(image, x1, y1)},
          x - fx,
          y - fy};
}
}  // namespace

Vec4 sampleBilinear(const DistortionImage& image, float u, float v) {
  const BilinearCorners q = bilinearCorners(image, u, v);
  Vec4 out{};
  for (int c = 0; c < 4; ++c) {
    const float top = (1.0f - q.ax) * q.texel[0][c] + q.ax * q.texel[1][c];
    const float bottom = (1.0f - q.ax) * q.texel[2][c] + q.ax * q.texel[3][c];
    out[c] = (1.0f - q.ay) * top + q.ay * bottom;
  }
  return out;
}

std::vector<std::vector<float>> environmentLevels(const LatLongImage& env) {
  const uint32_t count = environmentLevelCount(env.width, env.height);
  std::vector<std::vector<float>> levels;
  std::vector<float> above(env.rgba, env.rgba + size_t(env.width) * env.height * 4);
  for (float& v : above) v = roundToBinary16(v);
  uint32_t w = env.width, h = env.height;
  for (uint32_t level = 1; level < count; ++level) {
    const uint32_t w2 = std::max(1u, w >> 1), h2 = std::max(1u, h >> 1);
    std::vector<float> next(size_t(w2) * h2 * 4);
    for (uint32_t j = 0; j < h2; ++j)
      for (uint32_t i = 0; i < w2; ++i) {
        // The destination texel centre in source texels, less half a texel: bilinear, clamped.
        const float x = (float(i) + 0.5f) * float(w) / float(w2) - 0.5f;
        const float y = (float(j) + 0.5f) * float(h) / float(h2) - 0.5f;
        const float fx = std::floor(x), fy = std::floor(y);
        const float ax = x - fx, ay = y - fy;
        auto cx = [&](float t) { return size_t(std::clamp(t, 0.0f, float(w - 1))); };
        auto cy = [&](float t) { return size_t(std::clamp(t, 0.0f, float(h - 1))); };
        const size_t x0 = cx(fx), x1 = cx(fx + 1.0f), y0 = cy(fy), y1 = cy(fy + 1.0f);
        for (size_t c = 0; c < 4; ++c) {
          auto at = [&](size_t px, size_t py) { return above[(py * w + px) * 4 + c]; };
          const float top = (1.0f - ax) * at(x0, y0) + ax * at(x1, y0);
          const float bottom = (1.0f - ax) * at(x0, y1) + ax * at(x1, y1);
          next[(size_t(j) * w2 + i) * 4 + c] = roundToBinary16((1.0f - ay) * top + ay * bottom);
        }
      }
    levels.push_back(next);
    above = std::move(next);
    w = w2;
    h = h2;
  }
  return levels;
}

float directionFootprint(const Vec3& ddx, const Vec3& ddy) {
  const float chord = std::max(glm::length(toGlm(ddx)), glm::length(toGlm(ddy)));
  return 2.0f * std::asin(std::min(0.5f * chord, 1.0f));
}

float scatterAfterOneJump(const std::array<Vec3, 4>& exits) {
  constexpr int kFirst[6] = {0, 0, 0, 1, 1, 2}, kSecond[6] = {1, 2, 3, 2, 3, 3};  // ab ac ad bc bd cd
  const glm::vec3 zero(0.0f);
  float c[6];
  for (int q = 0; q < 6; ++q) {
    const glm::vec3 a = toGlm(exits[kFirst[q]]), b = toGlm(exits[kSecond[q]]);
    c[q] = a == zero || b == zero ? 1.0f : glm::dot(a, b);
  }
  using std::max, std::min;
  float best = max(max(min(c[0], c[5]), min(c[1], c[4])), min(c[2], c[3]));       // ab|cd, ac|bd, ad|bc
  best = max(best, max(min(min(c[3], c[4]), c[5]), min(min(c[1], c[2]), c[5])));  // a|bcd, b|acd
  best = max(best, max(min(min(c[0], c[2]), c[4]), min(min(c[0], c[1]), c[3])));  // c|abd, d|abc
  return std::acos(std::clamp(best, -1.0f, 1.0f));
}

float environmentLevel(float footprint, float texelAngle, float maxLevel, float extraBias) {
  return std::clamp(std::log2(std::max(footprint, 1e-30f) / texelAngle) + (gpu::kEnvironmentLevelBias + extraBias), 0.0f,
                    maxLevel);
}

float latLongTexelAngle(float width) { return 2.0f * std::numbers::pi_v<float> / width; }
float cubeTexelAngle(float faceSize) { return 0.5f * std::numbers::pi_v<float> / faceSize; }

namespace {
// Where tap i of n sits along one of the pixel's axes, in (-1/2, 1/2) (environment_select.glsl).
float tapOffset(uint32_t i, float n) { return (float(i) + 0.5f) / n - 0.5f; }

// The level sampleLatLong reads for `footprint` (env has levels).
float latLongLevel(const LatLongImage& env, float footprint) {
  return environmentLevel(footprint, latLongTexelAngle(float(env.width)), float(env.levels->size()), env.levelBias);
}

// sampleLatLong at a level found already: bilinear in the two levels around it, linear between.
Vec3 sampleLatLongAtLevel(const LatLongImage& env, const Vec3& direction, float level) {
  float u, v;
  latLongUv(direction[0], direction[1], direction[2], u, v);  // once for both levels
  const uint32_t l0 = static_cast<uint32_t>(level);
  const float frac = level - float(l0);
  auto sampleLevel = [&](uint32_t l) {
    float c[4];
    const float* rgba = l == 0 ? env.rgba : (*env.levels)[l - 1].data();
    sampleLatLongBilinearUv(rgba, std::max(1u, env.width >> l), std::max(1u, env.height >> l), u, v, c);
    return glm::vec3(c[0], c[1], c[2]);
  };
  glm::vec3 c = sampleLevel(l0);
  if (frac > 0.0f) c = (1.0f - frac) * c + frac * sampleLevel(l0 + 1);
  return fromGlm(c);
}
}  // namespace

Vec3 sampleLatLong(const LatLongImage& env, const Vec3& direction, float footprint) {
  float out[4];
  if (!env.levels || env.levels->empty() || footprint <= 0.0f) {
    sampleLatLongBilinear(env.rgba, env.width, env.height, direction[0], direction[1], direction[2], out);
    return {out[0], out[1], out[2]};
  }
  return sampleLatLongAtLevel(env, direction, latLongLevel(env, footprint));
}

Vec3 sampleLatLongOverPixel(const LatLongImage& env, const Vec3& direction, const Vec3& ddx, const Vec3& ddy) {
  const glm::vec3 dir = toGlm(direction), dx = toGlm(ddx), dy = toGlm(ddy);
  if (dx == glm::vec3(0.0f) && dy == glm::vec3(0.0f)) return sampleLatLong(env, direction, 0.0f);
  const uint32_t taps = std::clamp(env.tapsPerAxis, 1u, kMaxEnvironmentTapsPerAxis);
  const float n = float(taps);
  const float footprint = directionFootprint(fromGlm(dx / n), fromGlm(dy / n));
  if (taps == 1) return sampleLatLong(env, direction, footprint * gpu::kOneTapFootprintScale);
  // Every tap reads the same level (the footprint's): sampleLatLong's, found once.
  const bool levels = env.levels && !env.levels->empty() && footprint > 0.0f;
  const float level = levels ? latLongLevel(env, footprint) : 0.0f;
  glm::vec3 sum(0.0f);
  for (uint32_t j = 0; j < taps; ++j)
    for (uint32_t i = 0; i < taps; ++i) {
      const float a = tapOffset(i, n), b = tapOffset(j, n);
      const glm::vec3 tap = dir + a * dx + b * dy;
      const Vec3 at = fromGlm(glm::dot(tap, tap) > 1e-12f ? tap : dir);
      sum += toGlm(levels ? sampleLatLongAtLevel(env, at, level) : sampleLatLong(env, at, footprint));
    }
  return fromGlm(sum / (n * n));
}

Vec3 cubeTexelDirection(uint32_t face, uint32_t i, uint32_t j, uint32_t faceSize) {
  const float a = 2.0f * (float(i) + 0.5f) / float(faceSize) - 1.0f;
  const float b = 2.0f * (float(j) + 0.5f) / float(faceSize) - 1.0f;
  switch (face) {
    case 0: return {1.0f, -b, -a};
    case 1: return {-1.0f, -b, a};
    case 2: return {a, 1.0f, b};
    case 3: return {a, -1.0f, -b};
    case 4: return {a, -b, 1.0f};
    default: return {-a, -b, -1.0f};
  }
}

namespace {

// What the object pass computes from its inputs before the lookups (object_field_body.glsl).
struct FieldFragment {
  glm::vec2 uv{0.0f};
  glm::vec3 v, n;
  float cosView = 0.0f;  // -v . n before n is bent toward the viewer
  float cosI = 0.0f;
  Vec4 d{};
  float len2 = 0.0f;
  glm::vec3 exitWorld, reflectedWorld;
};

// The fragment's unit view direction and interpolated normal (object_field_body.glsl main).
std::pair<glm::vec3, glm::vec3> viewAndNormal(const SurfacePoint& point, const Vec3& eyeArray) {
  return {glm::normalize(toGlm(point.position) - toGlm(eyeArray)), glm::normalize(toGlm(point.normal))};
}

// The view, the normal bent toward the viewer and the front reflection, as both object shadings
// compute them before their exit.
FieldFragment fragmentGeometry(const SurfacePoint& point, const Vec3& eyeArray, const Transform& worldFromObject) {
  FieldFragment f;
  f.uv = glm::vec2(point.uv[0], point.uv[1]);
  std::tie(f.v, f.n) = viewAndNormal(point, eyeArray);
  f.cosI = f.cosView = -glm::dot(f.v, f.n);
  if (f.cosI < 1e-4f) {
    f.n = glm::normalize(f.n + (1e-4f - f.cosI) * -f.v);
    f.cosI = -glm::dot(f.v, f.n);
  }
  f.reflectedWorld = toGlm(rotateDirection(worldFromObject, fromGlm(glm::reflect(f.v, f.n))));
  return f;
}

FieldFragment fieldFragment(const DistortionImage& distortion, const SurfacePoint& point, const Vec3& eyeArray,
                            const Transform& worldFromObject) {
  FieldFragment f = fragmentGeometry(point, eyeArray, worldFromObject);
  f.d = sampleBilinear(distortion, point.uv[0], point.uv[1]);
  const glm::vec3 dir(f.d[0], f.d[1], f.d[2]);
  f.len2 = glm::dot(dir, dir);
  const glm::vec3 exitDirection = f.len2 > gpu::kMinDirectionLength2 ? dir / std::sqrt(f.len2) : f.v;
  f.exitWorld = toGlm(rotateDirection(worldFromObject, fromGlm(exitDirection)));
  return f;
}

// The fragment of object_volume_body.glsl: its own path traced through the Volume field's grid at
// its position and bent normal; d holds the exit and the clamped optical depth (len2 = 1).
FieldFragment volumeFragment(const Field& volume, const SurfacePoint& point, const Vec3& eyeArray,
                             const Transform& worldFromObject, VolumePath* path = nullptr) {
  FieldFragment f = fragmentGeometry(point, eyeArray, worldFromObject);
  const VolumePath traced = traceVolumePath(volume, point.position, fromGlm(f.n), fromGlm(f.v));
  if (path) *path = traced;
  const float tau = std::clamp(traced.opticalDepth, -gpu::kMaxOpticalDepth, gpu::kMaxOpticalDepth);
  f.d = {traced.exit[0], traced.exit[1], traced.exit[2], tau};
  f.len2 = 1.0f;
  f.exitWorld = toGlm(rotateDirection(worldFromObject, traced.exit));
  return f;
}

// The fragment either shading computes for `object` at `point`.
FieldFragment objectFragment(const RenderObject& object, const SurfacePoint& point, const Vec3& eye) {
  return object.volume ? volumeFragment(*object.volume, point, eye, object.worldFromObject)
                       : fieldFragment(*object.distortion, point, eye, object.worldFromObject);
}

// The four texels around a field coordinate (object_field_body.glsl TexelCell, readCell).
struct TexelCell {
  std::array<glm::vec3, 4> exit{};  // unit, object space; zero where the texel is empty
  std::array<float, 4> weight{};
  std::array<size_t, 4> texel{};  // texel indices (for the jump image, read only in jump cells)
  glm::vec2 fraction{0.0f};       // where the coordinate lies between the texels, along x and y
  float jump = 0.0f;
};

TexelCell readCell(const DistortionImage& distortion, glm::vec2 uv) {
  const BilinearCorners corners = bilinearCorners(distortion, uv.x, uv.y);
  TexelCell cell;
  cell.weight = corners.weights();
  cell.fraction = {corners.ax, corners.ay};
  for (size_t k = 0; k < 4; ++k) cell.texel[k] = size_t(corners.texel[k] - distortion.rgba.data()) / 4;
  for (int k = 0; k < 4; ++k) {
    const glm::vec3 d(corners.texel[k][0], corners.texel[k][1], corners.texel[k][2]);
    const float len2 = glm::dot(d, d);
    cell.exit[k] = len2 > gpu::kMinDirectionLength2 ? d / std::sqrt(len2) : glm::vec3(0.0f);
  }
  float minCos = 1.0f;
  for (int a = 0; a < 4; ++a)
    for (int c = a + 1; c < 4; ++c)
      if (cell.exit[a] != glm::vec3(0.0f) && cell.exit[c] != glm::vec3(0.0f))
        minCos = std::min(minCos, glm::dot(cell.exit[a], cell.exit[c]));
  cell.jump = std::clamp((gpu::kSpatialAgreeCosine - minCos) / (gpu::kSpatialAgreeCosine - gpu::kSpatialSplitCosine),
                         0.0f, 1.0f);
  return cell;
}

// Where the jump between the cell's texels lies, from the jump image (gpu_layout.h
// kSpatialPlaceTrust): the share of the pixel on the side of the texel of largest weight (own[k]:
// texel k is on it), or -1 where the cell does not qualify. scatter: the cell's scatterAfterOneJump.
// texelsDx, texelsDy: the screen axes' steps in texels (object_field_body.glsl placedShare).
float placedShare(const TexelCell& cell, const std::vector<float>& jumpImage, float scatter, glm::vec2 texelsDx,
                  glm::vec2 texelsDy, std::array<bool, 4>& own) {
  int r = 0;
  for (int k = 1; k < 4; ++k)
    if (cell.weight[k] > cell.weight[size_t(r)]) r = k;
  std::array<float, 4> side{};  // + the distance on r's side, - beyond
  float ownWeight = 0.0f;
  bool across = false;
  for (size_t k = 0; k < 4; ++k) {
    const float cells = jumpImage.empty() ? gpu::kJumpDistanceMaxCells : jumpImage[cell.texel[k]];
    if (cell.exit[k] == glm::vec3(0.0f) || !(cells < gpu::kSpatialPlaceMaxCells)) return -1.0f;
    own[k] = glm::dot(cell.exit[k], cell.exit[size_t(r)]) > gpu::kSpatialSplitCosine;
    across = across || !own[k];
    side[k] = own[k] ? cells : -cells;
    ownWeight += own[k] ? cell.weight[k] : 0.0f;
  }
  if (!across || scatter > gpu::kSpatialPlaceMaxScatter) return -1.0f;
  const float fx = cell.fraction.x, fy = cell.fraction.y;
  const float at = (1.0f - fy) * ((1.0f - fx) * side[0] + fx * side[1]) + fy * ((1.0f - fx) * side[2] + fx * side[3]);
  const float alongX = (1.0f - fy) * (side[1] - side[0]) + fy * (side[3] - side[2]);
  const float alongY = (1.0f - fx) * (side[2] - side[0]) + fx * (side[3] - side[1]);
  // The side function's change across the pixel: a linear function's box-filtered step.
  const float width = std::abs(alongX * texelsDx.x + alongY * texelsDx.y) +
                      std::abs(alongX * texelsDy.x + alongY * texelsDy.y);
  const float placed = std::clamp(0.5f + at / std::max(width, 1e-6f), 0.0f, 1.0f);
  return ownWeight + gpu::kSpatialPlaceTrust * (placed - ownWeight);
}

// The texels' weights for a placed jump: `share` of the pixel to the texels of side `own`, the rest
// to the others, each side's spread over its texels by their bilinear weights (at least 1e-4, so
// that a side the coordinate sits away from still has a colour; object_field_body.glsl
// placedWeights).
std::array<float, 4> placedWeights(const TexelCell& cell, const std::array<bool, 4>& own, float share) {
  std::array<float, 4> floor{}, weights{};
  float ownSum = 0.0f, otherSum = 0.0f;
  for (size_t k = 0; k < 4; ++k) {
    floor[k] = std::max(cell.weight[k], 1e-4f);
    (own[k] ? ownSum : otherSum) += floor[k];
  }
  for (size_t k = 0; k < 4; ++k) weights[k] = floor[k] * (own[k] ? share / ownSum : (1.0f - share) / otherSum);
  return weights;
}

// The cell's texels' own lookups, each weighed by `weights` (the bilinear ones, or placedWeights) /
// (1 + its luma); w = 0 where no texel with weight holds an exit (object_field_body.glsl
// cellColours).
glm::vec4 cellColours(const TexelCell& cell, const std::array<float, 4>& weights, const LatLongImage& env,
                      float footprint, const Transform& worldFromObject) {
  glm::vec3 sum(0.0f);
  float weight = 0.0f;
  for (size_t k = 0; k < 4; ++k) {
    if (cell.exit[k] == glm::vec3(0.0f)) continue;
    const glm::vec3 c = toGlm(sampleLatLong(env, rotateDirection(worldFromObject, fromGlm(cell.exit[k])), footprint));
    const float w = weights[k] / (1.0f + glm::dot(c, glm::vec3(gpu::kLumaRed, gpu::kLumaGreen, gpu::kLumaBlue)));
    sum += w * c;
    weight += w;
  }
  return weight > 0.0f ? glm::vec4(sum / weight, 1.0f) : glm::vec4(0.0f);
}

// A lookup's footprint widened by `blur` radians (object_field_body.glsl widenedFootprint).
float widenedFootprint(float footprint, float blur) { return std::sqrt(footprint * footprint + blur * blur); }

// How much wider a lookup at a bilinearly filtered exit of squared length len2 reads
// (object_field_body.glsl filteredExitBlur; gpu_layout.h kFilteredExitSpreadThreshold).
float filteredExitBlur(const DistortionImage& distortion, float len2) {
  if (distortion.throughput || !(len2 > gpu::kMinDirectionLength2)) return 0.0f;
  return gpu::kFilteredExitSpreadBlur *
         std::max(std::acos(std::min(std::sqrt(len2), 1.0f)) - gpu::kFilteredExitSpreadThreshold, 0.0f);
}

// The transmitted light over the pixel, interpolating directions (object_field_body.glsl
// directionsOverPixel): the taps of sampleLatLongOverPixel, each at the exit the distortion image
// holds at the tap's own place in the pixel, where it holds one (else the centre's exit moved along
// its derivatives).
glm::vec3 directionsOverPixel(const DistortionImage& distortion, const LatLongImage& env, const FieldFragment& f,
                              const LookupDerivatives& d, const Transform& worldFromObject) {
  const glm::vec3 dir = f.exitWorld, dx = toGlm(d.exitDx), dy = toGlm(d.exitDy);
  const uint32_t taps = std::clamp(env.tapsPerAxis, 1u, kMaxEnvironmentTapsPerAxis);
  // No derivatives or one tap: nothing but the centre's exit is read.
  if ((dx == glm::vec3(0.0f) && dy == glm::vec3(0.0f)) || taps == 1) {
    const float exitBlur = filteredExitBlur(distortion, f.len2);
    if (exitBlur == 0.0f) return toGlm(sampleLatLongOverPixel(env, fromGlm(dir), d.exitDx, d.exitDy));
    const float one = dx == glm::vec3(0.0f) && dy == glm::vec3(0.0f)
                          ? 0.0f
                          : directionFootprint(d.exitDx, d.exitDy) * gpu::kOneTapFootprintScale;
    return toGlm(sampleLatLong(env, fromGlm(dir), widenedFootprint(one, exitBlur)));
  }
  const float n = float(taps);
  const float footprint = directionFootprint(fromGlm(dx / n), fromGlm(dy / n));
  const glm::vec2 uvDx(d.uvDx[0], d.uvDx[1]), uvDy(d.uvDy[0], d.uvDy[1]);
  glm::vec3 sum(0.0f);
  for (uint32_t j = 0; j < taps; ++j)
    for (uint32_t i = 0; i < taps; ++i) {
      const float a = tapOffset(i, n), b = tapOffset(j, n);
      const glm::vec2 uv = f.uv + a * uvDx + b * uvDy;
      const Vec4 t = sampleBilinear(distortion, uv.x, uv.y);
      const glm::vec3 exit(t[0], t[1], t[2]);
      const float len2 = glm::dot(exit, exit);
      const glm::vec3 tap = len2 > gpu::kMinDirectionLength2
                                ? toGlm(rotateDirection(worldFromObject, fromGlm(exit / std::sqrt(len2))))
                                : dir + a * dx + b * dy;
      const float blur = filteredExitBlur(distortion, len2);
      sum += toGlm(sampleLatLong(env, fromGlm(glm::dot(tap, tap) > 1e-12f ? tap : dir), widenedFootprint(footprint, blur)));
    }
  return sum / (n * n);
}

// The transmitted light over the pixel (object_field_body.glsl transmittedOverPixel): directions
// where the texels around the centre agree, their own lookups' blend where they straddle a jump
// (placed by the jump image where the cell qualifies: placedShare).
Vec3 transmittedOverPixel(const DistortionImage& distortion, const LatLongImage& env, const FieldFragment& f,
                          const LookupDerivatives& d, const Transform& worldFromObject) {
  const TexelCell cell = readCell(distortion, f.uv);
  if (cell.jump == 0.0f) return fromGlm(directionsOverPixel(distortion, env, f, d, worldFromObject));
  const float n = float(std::clamp(env.tapsPerAxis, 1u, kMaxEnvironmentTapsPerAxis));
  const float footprint = directionFootprint(fromGlm(toGlm(d.exitDx) / n), fromGlm(toGlm(d.exitDy) / n));
  const std::array<Vec3, 4> exits{fromGlm(cell.exit[0]), fromGlm(cell.exit[1]), fromGlm(cell.exit[2]),
                                  fromGlm(cell.exit[3])};
  const float scatter = scatterAfterOneJump(exits);
  const float blur = gpu::kSpatialScatterBlur * std::max(scatter - gpu::kSpatialScatterThreshold, 0.0f);
  const glm::vec2 size(float(distortion.width), float(distortion.height));
  std::array<bool, 4> own{};
  const float share = placedShare(cell, distortion.jump, scatter, glm::vec2(d.uvDx[0], d.uvDx[1]) * size,
                                  glm::vec2(d.uvDy[0], d.uvDy[1]) * size, own);
  const glm::vec4 colours = cellColours(cell, share < 0.0f ? cell.weight : placedWeights(cell, own, share), env,
                                        widenedFootprint(footprint, blur), worldFromObject);
  const float t = cell.jump * colours.w;
  if (t == 1.0f) return fromGlm(glm::vec3(colours));  // the direction taps would weigh nothing
  const glm::vec3 directions = directionsOverPixel(distortion, env, f, d, worldFromObject);
  return fromGlm(directions + t * (glm::vec3(colours) - directions));
}

// The world exit the distortion image holds at `uv`; zero where it holds none
// (object_field_body.glsl exitWorldAt).
glm::vec3 exitWorldAt(const DistortionImage& distortion, glm::vec2 uv, const Transform& worldFromObject) {
  const Vec4 t = sampleBilinear(distortion, uv.x, uv.y);
  const glm::vec3 d(t[0], t[1], t[2]);
  const float len2 = glm::dot(d, d);
  return len2 > gpu::kMinDirectionLength2 ? toGlm(rotateDirection(worldFromObject, fromGlm(d / std::sqrt(len2))))
                                          : glm::vec3(0.0f);
}

// The exit's change across one pixel along the screen axis whose field coordinate step is uvD: the
// gentler of the two one-sided differences to the exits one pixel away (object_field_body.glsl
// exitDerivative says why); `fine` where neither neighbour holds an exit.
glm::vec3 exitDerivative(const DistortionImage& distortion, const glm::vec3& exitWorld, const glm::vec3& fine,
                         glm::vec2 uv, glm::vec2 uvD, const Transform& worldFromObject) {
  const glm::vec3 ahead = exitWorldAt(distortion, uv + uvD, worldFromObject);
  const glm::vec3 behind = exitWorldAt(distortion, uv - uvD, worldFromObject);
  if (ahead == glm::vec3(0.0f)) return behind == glm::vec3(0.0f) ? fine : exitWorld - behind;
  if (behind == glm::vec3(0.0f)) return ahead - exitWorld;
  const glm::vec3 forward = ahead - exitWorld, backward = exitWorld - behind;
  return glm::dot(forward, forward) < glm::dot(backward, backward) ? forward : backward;
}

}  // namespace

Vec3 shadeField(const DistortionImage& distortion, const LatLongImage& environment, const SurfacePoint& point,
                const Vec3& eyeArray, const ObjectShading& shading, float exposure, const Transform& worldFromObject,
                const LookupDerivatives& derivatives) {
  const FieldFragment f = fieldFragment(distortion, point, eyeArray, worldFromObject);
  LookupDerivatives d = derivatives;
  if (f.len2 > gpu::kMinDirectionLength2) {
    const glm::vec2 uvDx(d.uvDx[0], d.uvDx[1]), uvDy(d.uvDy[0], d.uvDy[1]);
    d.exitDx = fromGlm(exitDerivative(distortion, f.exitWorld, toGlm(d.exitDx), f.uv, uvDx, worldFromObject));
    d.exitDy = fromGlm(exitDerivative(distortion, f.exitWorld, toGlm(d.exitDy), f.uv, uvDy, worldFromObject));
  }
  const float ior = point.frontIor > 0.0f ? point.frontIor : shading.ior;
  const float fresnel = fresnelDielectric(f.cosI, 1.0f / ior);
  float transmittance = std::exp(-std::max(f.d[3], 0.0f) * (shading.absorptionScale * worldFromObject.scale));
  if (distortion.throughput) transmittance *= std::min(std::sqrt(f.len2), 1.0f);
  glm::vec3 color = (1.0f - fresnel) * transmittance * toGlm(shading.tint) *
                    toGlm(transmittedOverPixel(distortion, environment, f, d, worldFromObject));
  if (shading.reflection)
    color += fresnel * toGlm(sampleLatLongOverPixel(environment, fromGlm(f.reflectedWorld), d.reflectedDx, d.reflectedDy));
  return fromGlm(color * exposure);
}

namespace {

// object_volume_body.glsl lookupOverCell: `cells` x `cells` taps over one traced path's cell.
glm::vec3 lookupOverCell(const LatLongImage& env, uint32_t cells, const glm::vec3& dir, const glm::vec3& dx,
                         const glm::vec3& dy) {
  const float n = float(cells);
  const float footprint = directionFootprint(fromGlm(dx / n), fromGlm(dy / n));
  glm::vec3 sum(0.0f);
  for (uint32_t j = 0; j < cells; ++j)
    for (uint32_t i = 0; i < cells; ++i) {
      const glm::vec3 tap = dir + tapOffset(i, n) * dx + tapOffset(j, n) * dy;
      sum += toGlm(sampleLatLong(env, fromGlm(glm::dot(tap, tap) > 1e-12f ? tap : dir), footprint));
    }
  return sum / (n * n);
}

// object_volume_body.glsl pathsOverPixel: taps x taps paths at the centres of the pixel's cells,
// each looked up over its cell; `apart` when one leaves beyond acos(kVolumeRefineCosine) from the
// centre path's exit.
glm::vec3 pathsOverPixel(const Field& volume, const LatLongImage& env, uint32_t taps, const SurfacePoint& point,
                         const Vec3& eye, const Transform& worldFromObject, const glm::vec3& exitWorld,
                         const LookupDerivatives& d, const glm::vec3& dx, const glm::vec3& dy, bool& apart) {
  const float n = float(taps);
  const uint32_t cells = std::max(std::clamp(env.tapsPerAxis, 1u, kMaxEnvironmentTapsPerAxis) / taps, 1u);
  const glm::vec3 p0 = toGlm(point.position), n0 = toGlm(point.normal);
  glm::vec3 sum(0.0f);
  apart = false;
  for (uint32_t j = 0; j < taps; ++j)
    for (uint32_t i = 0; i < taps; ++i) {
      const float a = tapOffset(i, n), b = tapOffset(j, n);
      SurfacePoint tap = point;
      tap.position = fromGlm(p0 + a * toGlm(d.positionDx) + b * toGlm(d.positionDy));
      tap.normal = fromGlm(n0 + a * toGlm(d.normalDx) + b * toGlm(d.normalDy));
      const FieldFragment f = fragmentGeometry(tap, eye, worldFromObject);
      const VolumePath path = traceVolumePath(volume, tap.position, fromGlm(f.n), fromGlm(f.v));
      const glm::vec3 exit = toGlm(rotateDirection(worldFromObject, path.exit));
      apart = apart || glm::dot(exit, exitWorld) < gpu::kVolumeRefineCosine;
      sum += lookupOverCell(env, cells, exit, dx / n, dy / n);
    }
  return sum / (n * n);
}

// object_volume_body.glsl transmittedOverPixel: the jump rule on the exit's derivatives, then
// kVolumeTracedTapsPerAxis^2 paths traced at the pixel's cells, each looked up over its cell, or
// kVolumeRefinedTapsPerAxis^2 where they disagree and the transmitted term weighs enough.
glm::vec3 volumeOverPixel(const Field& volume, const LatLongImage& env, const SurfacePoint& point, const Vec3& eye,
                          const Transform& worldFromObject, const glm::vec3& exitWorld, const LookupDerivatives& d,
                          float weight) {
  glm::vec3 dx = toGlm(d.exitDx), dy = toGlm(d.exitDy);
  const float jump = 2.0f * (1.0f - gpu::kSpatialSplitCosine);
  const bool jumpX = glm::dot(dx, dx) > jump, jumpY = glm::dot(dy, dy) > jump;
  if (jumpX != jumpY) (jumpX ? dx : dy) = glm::vec3(0.0f);
  const uint32_t taps = std::clamp(env.tapsPerAxis, 1u, kMaxEnvironmentTapsPerAxis);
  const uint32_t traced = std::min(gpu::kVolumeTracedTapsPerAxis, taps);
  if (traced == 1) return toGlm(sampleLatLongOverPixel(env, fromGlm(exitWorld), fromGlm(dx), fromGlm(dy)));
  bool apart = false;
  const glm::vec3 mean = pathsOverPixel(volume, env, traced, point, eye, worldFromObject, exitWorld, d, dx, dy, apart);
  if (!apart || !env.refineVolumePaths || weight < gpu::kVolumeRefineWeight) return mean;
  return pathsOverPixel(volume, env, gpu::kVolumeRefinedTapsPerAxis, point, eye, worldFromObject, exitWorld, d, dx, dy,
                        apart);
}

}  // namespace

Vec3 shadeVolume(const Field& volume, const LatLongImage& environment, const SurfacePoint& point, const Vec3& eyeArray,
                 const ObjectShading& shading, float exposure, const Transform& worldFromObject,
                 const LookupDerivatives& d, Vec3* exitWorld) {
  VolumePath path;
  const FieldFragment f = volumeFragment(volume, point, eyeArray, worldFromObject, &path);
  if (exitWorld) *exitWorld = fromGlm(f.exitWorld);
  const float ior = point.frontIor > 0.0f ? point.frontIor : shading.ior;
  const float fresnel = fresnelDielectric(f.cosI, 1.0f / ior);
  float transmittance = std::exp(-std::max(f.d[3], 0.0f) * (shading.absorptionScale * worldFromObject.scale));
  if (volume.throughput) transmittance *= std::clamp(path.throughput, 0.0f, 1.0f);
  glm::vec3 color = (1.0f - fresnel) * transmittance * toGlm(shading.tint) *
                    volumeOverPixel(volume, environment, point, eyeArray, worldFromObject, f.exitWorld, d,
                                    (1.0f - fresnel) * transmittance);
  if (shading.reflection)
    color += fresnel * toGlm(sampleLatLongOverPixel(environment, fromGlm(f.reflectedWorld), d.reflectedDx, d.reflectedDy));
  return fromGlm(color * exposure);
}

float silhouetteCoverage(const SurfacePoint& point, const Vec3& eye, const LookupDerivatives& derivatives) {
  const auto [v, n] = viewAndNormal(point, eye);
  const float cosView = -glm::dot(v, n);
  const float dx = derivatives.cosViewDx, dy = derivatives.cosViewDy, g = std::sqrt(dx * dx + dy * dy);
  return g > 0.0f ? std::clamp(0.5f + gpu::kSilhouetteCoverageScale * cosView / g, 0.0f, 1.0f) : 1.0f;
}

float polygonCoverage(const TriangleEdges& edges, const SurfacePoint& point, const Vec3& eye,
                      const LookupDerivatives& derivatives) {
  const glm::vec3 p = toGlm(point.position), e = toGlm(eye);
  const glm::vec3 dPdx = toGlm(derivatives.positionDx), dPdy = toGlm(derivatives.positionDy);
  float coverage = 1.0f;
  for (size_t k = 0; k < 3; ++k) {
    const glm::vec4 across(edges.neighbour[k][0], edges.neighbour[k][1], edges.neighbour[k][2], edges.neighbour[k][3]);
    if (glm::dot(glm::vec3(across), e) - across.w > 0.0f) continue;  // the neighbour faces the eye
    const glm::vec3 m(edges.edge[k][0], edges.edge[k][1], edges.edge[k][2]);
    const float g = std::fabs(glm::dot(m, dPdx)) + std::fabs(glm::dot(m, dPdy));
    if (g > 0.0f) coverage = std::min(coverage, std::clamp(0.5f + (glm::dot(m, p) - edges.edge[k][3]) / g, 0.0f, 1.0f));
  }
  return coverage;
}

Vec3 overBackground(const Vec3& colour, const SurfacePoint& point, const Vec3& eye, const LookupDerivatives& derivatives,
                    const LatLongImage& environment, const Vec3& ray, const TriangleEdges* edges) {
  float coverage = silhouetteCoverage(point, eye, derivatives);
  if (edges) coverage = std::min(coverage, polygonCoverage(*edges, point, eye, derivatives));
  if (coverage >= 1.0f) return colour;
  const Vec3 background = sampleLatLong(environment, ray);
  Vec3 out{};
  for (size_t k = 0; k < 3; ++k) out[k] = coverage * colour[k] + (1.0f - coverage) * background[k];
  return out;
}

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
