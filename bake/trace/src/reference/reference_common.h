// What the CPU renderers of this folder share (reference_render.cpp, exact_distortion.cpp,
// distortion_render.cpp): the supersampled camera's rays, size checks, the per-pixel accumulation
// of sub-samples and the row scheduler. Private to shrefract::trace.
#pragma once

#include <shrefract/trace/reference_render.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

namespace shrefract::bake::reference_detail {

using Clock = std::chrono::steady_clock;

// Largest supersampled image side: the sub-sample grid of one render.
constexpr uint32_t kMaxSupersampledSide = 65536;

inline glm::vec3 toVec(const std::array<float, 3>& a) { return {a[0], a[1], a[2]}; }

inline uint32_t threadCount(uint32_t requested) {
  return requested ? requested : std::max(1u, std::thread::hardware_concurrency());
}

// The inverse of reference::pixelRay's projection, computed once per image: the same float
// operations, so rays are bit-identical to pixelRay's.
inline glm::mat4 directionFromClip(const Camera& camera, uint32_t width, uint32_t height) {
  const float aspect = height ? float(width) / float(height) : 1.0f;
  glm::mat4 proj =
      glm::perspectiveRH_ZO(glm::radians(camera.verticalFovDegrees), aspect, camera.nearPlane, camera.farPlane);
  proj[1][1] *= -1.0f;
  glm::mat4 view = glm::lookAtRH(toVec(camera.eye), toVec(camera.target), toVec(camera.up));
  view[3] = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
  return glm::inverse(proj * view);
}

// The (unnormalized) ray through the point (x, y) of a width x height image, in pixels with pixel
// centres at whole numbers.
inline glm::vec3 rayAt(const glm::mat4& dirFromClip, uint32_t width, uint32_t height, float x, float y) {
  const glm::vec2 ndc((x + 0.5f) / float(width) * 2.0f - 1.0f, (y + 0.5f) / float(height) * 2.0f - 1.0f);
  return glm::vec3(dirFromClip * glm::vec4(ndc, 1.0f, 1.0f));
}

// The ray through the centre of pixel (x, y), as pixelRay.
inline glm::vec3 rayThrough(const glm::mat4& dirFromClip, uint32_t width, uint32_t height, uint32_t x, uint32_t y) {
  return rayAt(dirFromClip, width, height, float(x), float(y));
}

inline Result<void> checkSize(const char* who, uint32_t width, uint32_t height, uint32_t samplesPerAxis) {
  if (width == 0 || height == 0 || width > 16384 || height > 16384)
    return makeError(ErrorCode::InvalidArgument, std::string(who) + ": size must be 1..16384 per axis");
  if (samplesPerAxis < 1 || samplesPerAxis > kMaxSamplesPerAxis)
    return makeError(ErrorCode::InvalidArgument, std::string(who) + ": samples per axis " +
                                                     std::to_string(samplesPerAxis) + " is outside 1.." +
                                                     std::to_string(kMaxSamplesPerAxis));
  if (uint64_t(width) * samplesPerAxis > kMaxSupersampledSide || uint64_t(height) * samplesPerAxis > kMaxSupersampledSide)
    return makeError(ErrorCode::InvalidArgument, std::string(who) + ": " + std::to_string(width) + "x" +
                                                     std::to_string(height) + " at " + std::to_string(samplesPerAxis) +
                                                     "x" + std::to_string(samplesPerAxis) +
                                                     " samples per pixel is beyond " +
                                                     std::to_string(kMaxSupersampledSide) + " sub-samples per axis");
  return {};
}

// One sub-sample of a supersampled renderer.
struct Sample {
  glm::vec3 color{0.0f};
  glm::vec3 direction{0.0f};  // transmitted exit direction (zero off the object)
  bool hit = false;
};

// Accumulates the S x S sub-samples of one pixel into the output (colour mean, coverage, mask,
// normalized mean direction).
struct PixelAccumulator {
  glm::vec3 color{0.0f};
  glm::vec3 direction{0.0f};
  uint32_t hits = 0;

  void add(const Sample& s) {
    for (int k = 0; k < 3; ++k) color[k] += std::isfinite(s.color[k]) ? s.color[k] : 0.0f;
    if (s.hit) {
      ++hits;
      direction += s.direction;
    }
  }

  void store(ReferenceImage& out, size_t p, uint32_t samplesPerPixel) const {
    for (int k = 0; k < 3; ++k) out.color.rgba[p * 4 + size_t(k)] = color[k] / float(samplesPerPixel);
    out.color.rgba[p * 4 + 3] = 1.0f;
    out.coverage[p] = float(hits) / float(samplesPerPixel);
    out.mask[p] = 2 * hits > samplesPerPixel ? 1 : 0;
    const float len2 = glm::dot(direction, direction);
    out.directions[p] = len2 > 0.0f && std::isfinite(len2) ? direction / std::sqrt(len2) : glm::vec3(0.0f);
  }
};

inline ReferenceImage emptyImage(uint32_t width, uint32_t height) {
  ReferenceImage out;
  const size_t pixels = size_t(width) * height;
  out.color.width = width;
  out.color.height = height;
  out.color.rgba.assign(pixels * 4, 0.0f);
  out.directions.assign(pixels, glm::vec3(0.0f));
  out.mask.assign(pixels, 0);
  out.coverage.assign(pixels, 0.0f);
  return out;
}

// Runs `renderRow(y, rays)` for every row on `threads` threads (the calling thread among them),
// reporting progress from the calling thread.
template <typename RenderRow>
uint64_t forEachRow(uint32_t height, uint32_t threads, Clock::time_point start,
                    const std::function<void(const ReferenceProgress&)>& progress, RenderRow renderRow) {
  std::atomic<uint32_t> nextRow{0}, rowsDone{0};
  std::atomic<uint64_t> rays{0};
  auto report = [&]() {
    if (!progress) return;
    ReferenceProgress p;
    p.rowsDone = rowsDone.load();
    p.rowsTotal = height;
    p.rays = rays.load();
    p.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    progress(p);
  };
  auto worker = [&](bool caller) {
    auto lastReport = Clock::now();
    for (uint32_t y; (y = nextRow.fetch_add(1)) < height;) {
      uint64_t rowRays = 0;
      renderRow(y, rowRays);
      rays.fetch_add(rowRays);
      rowsDone.fetch_add(1);
      if (caller && Clock::now() - lastReport >= std::chrono::milliseconds(100)) {
        report();
        lastReport = Clock::now();
      }
    }
  };
  std::vector<std::thread> pool;
  for (uint32_t t = 1; t < threads; ++t) pool.emplace_back(worker, false);
  worker(true);
  for (auto& t : pool) t.join();
  report();
  return rays.load();
}
}  // namespace shrefract::bake::reference_detail
