// A procedural lat-long environment: sky, sun, three small bright lights and a checkered ground.
// Every refraction artefact shows on it: the checker bends, the lights become caustic sparkles,
// the horizon line shows distortion, and nothing needs a file.
#include <shrefract/assets/image.h>

#include <glm/common.hpp>
#include <glm/exponential.hpp>
#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace shrefract::bake {
namespace {

// Samples per pixel along each axis: 4x4 box-filtered samples keep the checker and disk edges
// from aliasing.
constexpr int kSubsamples = 4;

const glm::vec3 kHorizonSky(0.85f, 0.90f, 1.00f);
const glm::vec3 kZenithSky(0.18f, 0.36f, 0.85f);
const glm::vec3 kCheckerLight(0.75f, 0.75f, 0.72f);
const glm::vec3 kCheckerDark(0.08f, 0.08f, 0.10f);
// Mean of the two checker colours, so the fade toward the horizon keeps the average brightness.
const glm::vec3 kGroundFar = 0.5f * (kCheckerLight + kCheckerDark);
// Ground-plane distance (units, eye at height 1 above it) beyond which the checker has faded out:
// at distance 8 a unit square spans about 1/64 radian, about 2.5 pixels of a 1024-wide map.
constexpr float kCheckerFadeDistance = 8.0f;

struct Disk {
  glm::vec3 direction;  // normalized in lightsAndSun()
  float angularRadius;  // radians
  glm::vec3 radiance;
};

// Sun: angular radius 0.03 rad (about 3.4 times the real sun), radiance 30.
// Lights: 0.015 rad (enlarged to 1.5 pixels on small maps so they never vanish), 50 / 100 / 200.
std::array<Disk, 4> lightsAndSun(float pixelAngle) {
  const float lightRadius = std::max(0.015f, 1.5f * pixelAngle);
  const float sunRadius = std::max(0.03f, 1.5f * pixelAngle);
  return {{
      {glm::normalize(glm::vec3(-0.35f, 0.55f, -0.75f)), sunRadius, 30.0f * glm::vec3(1.0f, 0.95f, 0.85f)},
      {glm::normalize(glm::vec3(0.60f, 0.50f, -0.30f)), lightRadius, 50.0f * glm::vec3(1.0f, 0.85f, 0.6f)},
      {glm::normalize(glm::vec3(-0.70f, 0.40f, 0.25f)), lightRadius, 100.0f * glm::vec3(1.0f)},
      {glm::normalize(glm::vec3(0.10f, 0.85f, 0.45f)), lightRadius, 200.0f * glm::vec3(0.7f, 0.85f, 1.0f)},
  }};
}

glm::vec3 radiance(glm::vec3 dir, const std::array<Disk, 4>& disks) {
  if (dir.y < 0.0f) {
    // Ray from the eye (origin) to the ground plane y = -1.
    const float distance = 1.0f / -dir.y;
    const glm::vec3 hit = dir * distance;
    const int parity = (static_cast<int>(std::floor(hit.x)) + static_cast<int>(std::floor(hit.z))) & 1;
    const glm::vec3 checker = parity ? kCheckerLight : kCheckerDark;
    const float horizontal = distance * std::sqrt(std::max(0.0f, 1.0f - dir.y * dir.y));
    const float fade = std::exp(-(horizontal / kCheckerFadeDistance) * (horizontal / kCheckerFadeDistance));
    return glm::mix(kGroundFar, checker, fade);
  }
  glm::vec3 sky = glm::mix(kHorizonSky, kZenithSky, std::sqrt(dir.y));
  // A soft glow around the sun (disks[0]).
  const float sunAngle = std::acos(std::clamp(glm::dot(dir, disks[0].direction), -1.0f, 1.0f));
  sky += 0.6f * std::exp(-(sunAngle / 0.15f) * (sunAngle / 0.15f)) * glm::vec3(1.0f, 0.9f, 0.7f);
  for (const Disk& disk : disks) {
    if (glm::dot(dir, disk.direction) >= std::cos(disk.angularRadius)) {
      return disk.radiance;
    }
  }
  return sky;
}

}  // namespace

Image proceduralEnvironment(uint32_t width) {
  width = std::max(8u, width & ~1u);
  const uint32_t height = width / 2;
  const auto disks = lightsAndSun(glm::two_pi<float>() / static_cast<float>(width));

  Image image;
  image.width = width;
  image.height = height;
  image.rgba.resize(static_cast<size_t>(width) * height * 4);
  const float inv = 1.0f / static_cast<float>(kSubsamples * kSubsamples);
  for (uint32_t j = 0; j < height; ++j) {
    for (uint32_t i = 0; i < width; ++i) {
      glm::vec3 sum(0.0f);
      for (int sy = 0; sy < kSubsamples; ++sy) {
        for (int sx = 0; sx < kSubsamples; ++sx) {
          const glm::vec2 uv(
              (static_cast<float>(i) + (static_cast<float>(sx) + 0.5f) / kSubsamples) /
                  static_cast<float>(width),
              (static_cast<float>(j) + (static_cast<float>(sy) + 0.5f) / kSubsamples) /
                  static_cast<float>(height));
          sum += radiance(latLongToDirection(uv), disks);
        }
      }
      float* out = &image.rgba[4 * (static_cast<size_t>(j) * width + i)];
      out[0] = sum.x * inv;
      out[1] = sum.y * inv;
      out[2] = sum.z * inv;
      out[3] = 1.0f;
    }
  }
  return image;
}

}  // namespace shrefract::bake
