// The CPU mirror of the environment's lookups (cpu_reference.h): its level chain, the level a
// direction's footprint reads, and the lat-long lookups over a pixel (environment.glsl,
// environment_select.glsl).
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

float environmentLevel(float footprint, float texelAngle, float maxLevel, float extraBias) {
  return std::clamp(std::log2(std::max(footprint, 1e-30f) / texelAngle) + (gpu::kEnvironmentLevelBias + extraBias), 0.0f,
                    maxLevel);
}

float latLongTexelAngle(float width) { return 2.0f * std::numbers::pi_v<float> / width; }
float cubeTexelAngle(float faceSize) { return 0.5f * std::numbers::pi_v<float> / faceSize; }

namespace {

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

}  // namespace shrefract::reference
