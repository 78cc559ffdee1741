// Bilinear lookup in a lat-long image on the CPU, as the engine's environment sampler does it on
// the GPU (texel centres at (i + 0.5) / size, repeat in u, clamp in v; environment.glsl's uv).
// Used by the cube-map conversion and by the CPU reference.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>

namespace shrefract {

// Where `direction` (any non-zero length) falls in a lat-long image: u in [0, 1] around the
// vertical axis, v in [0, 1] from +y down.
inline void latLongUv(float dx, float dy, float dz, float& u, float& v) {
  const float len = std::sqrt(dx * dx + dy * dy + dz * dz);
  dx /= len;
  dy /= len;
  dz /= len;
  const float pi = std::numbers::pi_v<float>;
  u = 0.5f + std::atan2(dx, -dz) * (0.5f / pi);
  v = std::acos(std::clamp(dy, -1.0f, 1.0f)) * (1.0f / pi);
}

// Writes the 4 channels at (u, v) (latLongUv) to out[0..3]. Reading several levels of one chain
// at one direction, the direction's (u, v) is found once.
// Preconditions: width, height > 0; rgba holds width * height * 4 floats.
inline void sampleLatLongBilinearUv(const float* rgba, uint32_t width, uint32_t height, float u, float v, float* out) {
  const float x = u * float(width) - 0.5f;
  const float y = v * float(height) - 0.5f;
  const float fx = std::floor(x), fy = std::floor(y);
  const float ax = x - fx, ay = y - fy;
  const int64_t w = width, h = height;
  auto wrapX = [&](int64_t i) { return static_cast<size_t>(((i % w) + w) % w); };
  auto clampY = [&](int64_t j) { return static_cast<size_t>(std::clamp<int64_t>(j, 0, h - 1)); };
  const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  const size_t x0 = wrapX(ix), x1 = wrapX(ix + 1), y0 = clampY(iy), y1 = clampY(iy + 1);
  auto at = [&](size_t px, size_t py, size_t c) { return rgba[(py * width + px) * 4 + c]; };
  for (size_t c = 0; c < 4; ++c) {
    const float top = (1.0f - ax) * at(x0, y0, c) + ax * at(x1, y0, c);
    const float bottom = (1.0f - ax) * at(x0, y1, c) + ax * at(x1, y1, c);
    out[c] = (1.0f - ay) * top + ay * bottom;
  }
}

// Writes the 4 channels at `direction` (any non-zero length) to out[0..3].
// Preconditions: width, height > 0; rgba holds width * height * 4 floats.
inline void sampleLatLongBilinear(const float* rgba, uint32_t width, uint32_t height, float dx, float dy, float dz,
                                  float* out) {
  float u, v;
  latLongUv(dx, dy, dz, u, v);
  sampleLatLongBilinearUv(rgba, width, height, u, v, out);
}

}  // namespace shrefract
