// Shared by the field render tests: image comparison against the CPU reference, environments,
// and the fixture holding a session.
#pragma once

#include <gtest/gtest.h>
#include <shrefract/bake/bake.h>
#include <shrefract/assets/scene.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/gpu_layout.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>
#include <string>

#include "engine/synthetic_field.h"
#include "gpu_test_support.h"
#include "offscreen/offscreen.h"
#include "session_test_support.h"

namespace shrefract::field_render {



// Image tolerance, declared as data: a pixel passes when every channel is within
// kAbsolute + kRelative * |reference|; at most kFailFraction of the pixels may fail.
// Why these numbers: both sides decode the same binary16 distortion texels and the same binary16
// environment, but the GPU interpolates attributes and bilinear weights in its own precision
// (lavapipe: 8-bit filter weights, i.e. up to 1/512 texel of position error), so colours differ
// by a fraction of the environment's gradient per texel (about 0.01 for this environment).
// Pixels whose centre lies within a rounding error of a silhouette can be covered on one side only.
struct ImageTolerance {
  float absolute;
  float relative;
  float failFraction;
};
constexpr ImageTolerance kFieldTolerance{0.02f, 0.02f, 0.005f};
// Cube map against lat-long: the cube is resampled from the lat-long (one more bilinear step,
// about half a texel of blur on a 256x128 map), then filtered by the GPU's cube sampling.
constexpr ImageTolerance kCubeTolerance{0.02f, 0.03f, 0.005f};

// A smooth environment with structure in every direction, so that a wrong exit direction changes
// the colour, rounded to binary16 as the GPU stores it.
inline bake::Image smoothEnvironment(uint32_t width) {
  bake::Image env;
  env.width = width;
  env.height = width / 2;
  env.rgba.resize(size_t(env.width) * env.height * 4);
  for (uint32_t y = 0; y < env.height; ++y)
    for (uint32_t x = 0; x < env.width; ++x) {
      const glm::vec3 d = bake::latLongToDirection({(float(x) + 0.5f) / float(env.width),
                                                    (float(y) + 0.5f) / float(env.height)});
      const float wave = 0.15f * std::sin(3.0f * d.x + 2.0f * d.y) * std::cos(2.5f * d.z);
      const float rgb[3] = {0.55f + 0.4f * d.x + wave, 0.5f + 0.4f * d.y - wave, 0.5f + 0.35f * d.z + 0.5f * wave};
      float* p = &env.rgba[(size_t(y) * env.width + x) * 4];
      for (int k = 0; k < 3; ++k) p[k] = reference::roundToBinary16(std::max(0.0f, rgb[k]));
      p[3] = 1.0f;
    }
  return env;
}

struct Comparison {
  uint32_t pixels = 0, failed = 0;
  float maxDiff = 0.0f;
};

inline Comparison compare(const bake::Image& gpu, const std::vector<float>& cpu, const ImageTolerance& tol,
                   const std::vector<int32_t>* mask = nullptr, bake::Image* diff = nullptr) {
  Comparison c;
  if (diff) {
    diff->width = gpu.width;
    diff->height = gpu.height;
    diff->rgba.assign(gpu.rgba.size(), 1.0f);
  }
  for (size_t p = 0; p < size_t(gpu.width) * gpu.height; ++p) {
    if (mask && (*mask)[p] < 0) continue;
    ++c.pixels;
    bool ok = true;
    for (size_t k = 0; k < 3; ++k) {
      const float e = std::fabs(gpu.rgba[p * 4 + k] - cpu[p * 4 + k]);
      c.maxDiff = std::max(c.maxDiff, e);
      ok = ok && e <= tol.absolute + tol.relative * std::fabs(cpu[p * 4 + k]);
      if (diff) diff->rgba[p * 4 + k] = std::min(1.0f, 10.0f * e);
    }
    if (!ok) ++c.failed;
  }
  return c;
}

inline void writeForInspection(const std::string& name, const bake::Image& image) {
  if (auto written = bake::writeImage(name, image); written)
    std::fprintf(stderr, "wrote %s\n", name.c_str());
  else
    std::fprintf(stderr, "could not write %s: %s\n", name.c_str(), written.error().message.c_str());
}

class FieldRender : public testing::SessionTest {
 protected:
  void SetUp() override {
    SessionTest::SetUp();
    if (session) std::printf("device: %s\n", session->harness->deviceName().c_str());
  }
  // `convex`: what the baked grid is taken for (FieldVolume::convex); `forceConvex`: the flag set
  // on a grid that is not, so that the GPU's and the CPU's traces both stop at the first way out.
  void expectVolumeMirror(const char* sceneName, std::array<float, 3> eye, bool convex, bool forceConvex = false);
};


}  // namespace shrefract::field_render
