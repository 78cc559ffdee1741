// Synthetic refraction fields for the engine tests: a band of a sphere (theta in [0.2 pi, 0.8 pi],
// so no degenerate pole triangles) whose atlas texel (x, y) is the surface point at
// phi = 2 pi (x + 0.5) / width, theta between the band's limits at (y + 0.5) / height, with the
// frame of that point's outward normal, and smooth pseudo-random SH coefficients (a dominant
// band-0 term so that the decoded sums never come near zero). Optional empty texels (last column)
// and gutter texels (last row, each filled by a rule from sample texels above it).
// Deterministic for a given seed.
#pragma once

#include <shrefract/field.h>
#include <shrefract/sh.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

namespace shrefract::testing {

struct SyntheticFieldOptions {
  uint32_t width = 24;
  uint32_t height = 16;
  uint32_t order = 2;
  uint32_t channels = 4;
  Quantization quantization = Quantization::U8;
  bool emptyAndGutters = false;  // last column empty, last row gutters
  uint32_t seed = 1;
  float radius = 1.0f;
  std::array<float, 3> center{0.0f, 0.0f, 0.0f};
  uint32_t meshSegments = 24;  // quads around; meshSegments / 2 quads from top to bottom of the band
  float frontIor = 1.5f;
};

inline constexpr float kBandTheta0 = 0.2f * std::numbers::pi_v<float>;
inline constexpr float kBandTheta1 = 0.8f * std::numbers::pi_v<float>;

// Surface point and outward normal of the band at normalized atlas coordinates (u, v).
inline void bandPoint(const SyntheticFieldOptions& o, float u, float v, float* position, float* normal) {
  const float phi = 2.0f * std::numbers::pi_v<float> * u;
  const float theta = kBandTheta0 + (kBandTheta1 - kBandTheta0) * v;
  // y up: theta from +Y, phi around it starting at +Z toward +X.
  normal[0] = std::sin(theta) * std::sin(phi);
  normal[1] = std::cos(theta);
  normal[2] = std::sin(theta) * std::cos(phi);
  for (int k = 0; k < 3; ++k) position[k] = o.center[size_t(k)] + o.radius * normal[k];
}

inline Field makeSyntheticField(const SyntheticFieldOptions& o) {
  Field f;
  f.width = o.width;
  f.height = o.height;
  f.order = o.order;
  f.channels = o.channels;
  f.quantization = o.quantization;
  f.settings.order = o.order;
  f.settings.quantization = o.quantization;
  f.settings.source = "synthetic";
  f.media.push_back(FieldMedium{"air", 1.0f, 0.0f, {1.0f, 1.0f, 1.0f}});
  f.media.push_back(FieldMedium{"glass", o.frontIor, o.channels == 4 ? 0.5f : 0.0f, {1.0f, 1.0f, 1.0f}});

  const uint32_t texels = o.width * o.height;
  f.texelKinds.assign(texels, kTexelSample);
  f.frames.assign(size_t(texels) * 12, 0.0f);
  std::vector<float> directions(size_t(texels) * 3);
  for (uint32_t y = 0; y < o.height; ++y)
    for (uint32_t x = 0; x < o.width; ++x) {
      const uint32_t t = y * o.width + x;
      if (o.emptyAndGutters && x == o.width - 1) {
        f.texelKinds[t] = kTexelEmpty;
        continue;
      }
      if (o.emptyAndGutters && y == o.height - 1) {
        f.texelKinds[t] = kTexelGutter;
        continue;
      }
      float p[3], n[3];
      bandPoint(o, (float(x) + 0.5f) / float(o.width), (float(y) + 0.5f) / float(o.height), p, n);
      // Duff et al. orthonormal basis around n.
      const float sign = std::copysign(1.0f, n[2]);
      const float a = -1.0f / (sign + n[2]);
      const float b = n[0] * n[1] * a;
      const float tangent[3] = {1.0f + sign * n[0] * n[0] * a, sign * b, -sign * n[0]};
      const float bitangent[3] = {b, sign + n[1] * n[1] * a, -n[1]};
      const float* axes[3] = {tangent, bitangent, n};
      for (int r = 0; r < 3; ++r) {
        float* row = &f.frames[size_t(t) * 12 + size_t(r) * 4];
        for (int k = 0; k < 3; ++k) row[k] = axes[r][k];
        row[3] = -(axes[r][0] * p[0] + axes[r][1] * p[1] + axes[r][2] * p[2]);
      }
      for (int k = 0; k < 3; ++k) directions[size_t(t) * 3 + size_t(k)] = -n[k];
    }
  if (o.emptyAndGutters)
    for (uint32_t x = 0; x + 2 < o.width; ++x) {
      const uint32_t y = o.height - 1;
      f.gutters.push_back(GutterTexel{y * o.width + x, (y - 1) * o.width + x, (y - 1) * o.width + x + 1,
                                      (y - 2) * o.width + x + 1});
    }
  if (o.emptyAndGutters) {
    // The last row's texel at x = width - 2 has no rule in the loop above (x + 1 is empty).
    const uint32_t y = o.height - 1, x = o.width - 2;
    f.gutters.push_back(GutterTexel{y * o.width + x, (y - 1) * o.width + x, (y - 1) * o.width + x - 1,
                                    (y - 2) * o.width + x - 1});
  }

  // Smooth coefficients: per (layer, channel) an amplitude and two phases.
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  const uint32_t layers = f.basisCount();
  std::vector<float> amplitude(size_t(layers) * 4), phaseX(size_t(layers) * 4), phaseY(size_t(layers) * 4);
  for (size_t i = 0; i < amplitude.size(); ++i) {
    amplitude[i] = uniform(rng);
    phaseX[i] = 3.0f * uniform(rng);
    phaseY[i] = 3.0f * uniform(rng);
  }
  std::vector<float> coefficients(size_t(layers) * texels * o.channels, 0.0f);
  for (uint32_t layer = 0; layer < layers; ++layer) {
    const int l = static_cast<int>(std::sqrt(float(layer)));
    const float bandScale = 0.25f / float(1 + l);
    for (uint32_t t = 0; t < texels; ++t) {
      if (f.texelKinds[t] != kTexelSample) continue;
      const float x = float(t % o.width), y = float(t / o.width);
      for (uint32_t c = 0; c < o.channels; ++c) {
        const size_t k = size_t(layer) * 4 + c;
        float value = bandScale * amplitude[k] * (1.0f + 0.5f * std::sin(0.31f * x + phaseX[k]) * std::cos(0.27f * y + phaseY[k]));
        if (layer == 0) {
          // Band 0 carries the dominant direction (into the sphere) and a positive optical depth.
          value += c < 3 ? 3.0f * directions[size_t(t) * 3 + c] : 2.0f + 0.5f * std::sin(0.2f * x);
        }
        coefficients[(size_t(layer) * texels + t) * o.channels + c] = value;
      }
    }
  }
  (void)encodeCoefficients(f, coefficients);

  // Render mesh: the band as (segments) x (segments / 2) quads, atlas coordinates at the corners.
  const uint32_t nu = o.meshSegments, nv = std::max(1u, o.meshSegments / 2);
  const float uMax = o.emptyAndGutters ? float(o.width - 1) / float(o.width) : 1.0f;
  const float vMax = o.emptyAndGutters ? float(o.height - 1) / float(o.height) : 1.0f;
  for (uint32_t j = 0; j <= nv; ++j)
    for (uint32_t i = 0; i <= nu; ++i) {
      const float u = uMax * float(i) / float(nu), v = vMax * float(j) / float(nv);
      float p[3], n[3];
      bandPoint(o, u, v, p, n);
      f.mesh.positions.insert(f.mesh.positions.end(), {p[0], p[1], p[2]});
      f.mesh.normals.insert(f.mesh.normals.end(), {n[0], n[1], n[2]});
      f.mesh.uvs.insert(f.mesh.uvs.end(), {u, v});
      f.mesh.frontIor.push_back(o.frontIor);
    }
  for (uint32_t j = 0; j < nv; ++j)
    for (uint32_t i = 0; i < nu; ++i) {
      const uint32_t a = j * (nu + 1) + i, b = a + 1, c = a + nu + 1, d = c + 1;
      // Counter-clockwise seen from outside: v grows downward (theta), u grows toward +X from +Z.
      f.mesh.indices.insert(f.mesh.indices.end(), {a, c, b, b, c, d});
    }
  return f;
}

}  // namespace shrefract::testing
