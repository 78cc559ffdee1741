// Shared by the decompression tests: upload a field, decompress it on the GPU for an eye and read
// the distortion image back, and compare it with the CPU reference (shrefract/cpu_reference.h)
// texel by texel within stated tolerances.
#pragma once

#include <gtest/gtest.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/decompressor.h>
#include <shrefract/gpu_layout.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "engine/engine_test_support.h"

namespace shrefract::testing {

// Per-texel tolerances of a GPU distortion image against reference::decompress.
struct DistortionTolerance {
  float direction;    // absolute, per component of xyz (a unit direction, or one scaled by a throughput <= 1)
  float tauRelative;  // |tau difference| / max(1, |tau|)
  float gutter;       // gutter texels, every channel, relative to max(1, |value|)
};

// Largest differences seen, and how many texels of each kind were checked.
struct DistortionStats {
  float maxDirection = 0.0f, maxTau = 0.0f, maxGutter = 0.0f;
  uint32_t samples = 0, gutters = 0, empty = 0;
};

// Uploads `field` through Context::uploadNow; a Volume field traced in the decompression pass.
inline Result<std::unique_ptr<Object>> uploadFieldNow(Context& ctx, const Field& field) {
  return harness::uploadField(ctx, field, /*volumeInDecompression=*/true);
}

// Records one decompression of `object` for `eye`, submits it, waits, and reads the image back.
inline Result<std::vector<float>> decompressAndRead(harness::Harness& h, Decompressor& decompressor, Object& object,
                                                    const std::array<float, 3>& eye) {
  Result<void> recorded;
  auto submitted = h.submitAndWait([&](VkCommandBuffer cmd) { recorded = decompressor.record(cmd, eye, {&object}); });
  if (!submitted) return submitted.error();
  if (!recorded) return recorded.error();
  return readDistortion(h, object);
}

// Compares every texel of `gpu` with `cpu`: empty texels must be exactly zero, sample texels
// within the direction and tau tolerances (tau exactly 0 for a field without optical depth), gutter
// texels within the gutter tolerance. Adds to `stats`; fails (fatally) at the first texel outside.
inline void compareDistortion(const Field& field, const std::vector<float>& gpu, const reference::DistortionImage& cpu,
                              const DistortionTolerance& tolerance, DistortionStats& stats) {
  ASSERT_EQ(gpu.size(), cpu.rgba.size());
  for (uint64_t t = 0; t < field.texelCount(); ++t) {
    const float* g = &gpu[t * 4];
    const float* c = &cpu.rgba[t * 4];
    const uint8_t kind = field.texelKinds[t];
    if (kind == kTexelEmpty) {
      ++stats.empty;
      for (int k = 0; k < 4; ++k) ASSERT_EQ(g[k], 0.0f) << "empty texel " << t;
    } else if (kind == kTexelSample) {
      ++stats.samples;
      for (int k = 0; k < 3; ++k) {
        const float e = std::fabs(g[k] - c[k]);
        stats.maxDirection = std::max(stats.maxDirection, e);
        ASSERT_LE(e, tolerance.direction) << "texel " << t << " component " << k << ": gpu " << g[k] << " cpu " << c[k];
      }
      const float e = std::fabs(g[3] - c[3]);
      stats.maxTau = std::max(stats.maxTau, e / std::max(1.0f, std::fabs(c[3])));
      ASSERT_LE(e, tolerance.tauRelative * std::max(1.0f, std::fabs(c[3]))) << "texel " << t << " tau";
      if (!field.hasOpticalDepth()) {
        ASSERT_EQ(g[3], 0.0f) << "texel " << t << ": tau of a field without one";
      }
    } else {
      ++stats.gutters;
      for (int k = 0; k < 4; ++k) {
        const float e = std::fabs(g[k] - c[k]);
        stats.maxGutter = std::max(stats.maxGutter, e / std::max(1.0f, std::fabs(c[k])));
        ASSERT_LE(e, tolerance.gutter * std::max(1.0f, std::fabs(c[k]))) << "gutter texel " << t;
      }
    }
  }
}

// Compares the jump image read back (`gpu`, one float a texel) with reference::decompress's: texels
// that are not samples hold the cap exactly (cleared, or a gutter rule over capped values of a field
// without distances: within `cells`), sample texels within `cells` (float sums in the same order on
// both sides: the decode's differences of ~1e-6, far inside). Returns how many sample texels hold a
// distance under the cap (a jump near the eye's view); fails (fatally) at the first texel outside.
inline void compareJumpImage(const Field& field, const std::vector<float>& gpuJump,
                             const reference::DistortionImage& cpu, float cells, uint32_t& nearJump) {
  const std::vector<float>& g = gpuJump;
  ASSERT_EQ(g.size(), cpu.jump.size());
  for (uint64_t t = 0; t < field.texelCount(); ++t) {
    const uint8_t kind = field.texelKinds[t];
    if (kind == kTexelEmpty) {
      ASSERT_EQ(g[t], gpu::kJumpDistanceMaxCells) << "empty texel " << t;
      continue;
    }
    ASSERT_LE(std::fabs(g[t] - cpu.jump[t]), kind == kTexelSample ? cells : 3.0f * cells)
        << "texel " << t << ": gpu " << g[t] << " cpu " << cpu.jump[t];
    nearJump += kind == kTexelSample && cpu.jump[t] < gpu::kJumpDistanceMaxCells;
  }
}

// Texel values that differ by more than 0.01 between two images (does the decoded field follow
// the eye?).
inline uint32_t countChanged(const std::vector<float>& a, const std::vector<float>& b) {
  uint32_t changed = 0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) changed += std::fabs(a[i] - b[i]) > 1e-2f;
  return changed;
}

}  // namespace shrefract::testing
