// Shared by the stability tests: bake a scene at a small size, render the field with the CPU
// reference of the engine's passes, render the exact reference (per-pixel path tracing of the same
// scene), and measure how far apart they are. Every stage is checked for NaN and Inf.
//
// What "error" means here: for the pixels where both renders see the object, the angle between the
// field's exit direction (the bilinear sample of the decompressed distortion image, as the raster
// pass reads it) and the exact path's exit direction, and the PSNR of the colours over those pixels
// (bake::compareImages). The numbers are printed as a Markdown table row ("| stability | ...") so
// that docs/stability.md can be regenerated from the test log.
#pragma once

#include <gtest/gtest.h>
#include <shrefract/bake/bake.h>
#include <shrefract/trace/image_metrics.h>
#include <shrefract/trace/reference_render.h>
#include <shrefract/trace/tracer.h>
#include <shrefract/cpu_reference.h>
#include <shrefract/field.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace shrefract::stability {

// Bake settings small enough for a 2-core CI machine: order 4, an 8x16 direction grid, a few
// hundred samples.
inline BakeSettings smallSettings(uint64_t samples = 400) {
  BakeSettings s;
  s.order = 4;
  s.directionsTheta = 8;
  s.directionsPhi = 16;
  s.sampleBudget = samples;
  s.threads = 2;
  return s;
}

// A smooth environment with structure in every direction (a wrong exit direction changes the
// colour), values in [0, 1] so the PSNR is not dominated by clamping; rounded to binary16 as the
// GPU stores it.
inline bake::Image smoothEnvironment(uint32_t width = 128) {
  bake::Image env;
  env.width = width;
  env.height = width / 2;
  env.rgba.resize(size_t(env.width) * env.height * 4);
  for (uint32_t y = 0; y < env.height; ++y)
    for (uint32_t x = 0; x < env.width; ++x) {
      const glm::vec3 d =
          bake::latLongToDirection({(float(x) + 0.5f) / float(env.width), (float(y) + 0.5f) / float(env.height)});
      const float wave = 0.15f * std::sin(3.0f * d.x + 2.0f * d.y) * std::cos(2.5f * d.z);
      const float rgb[3] = {0.5f + 0.4f * d.x + wave, 0.5f + 0.4f * d.y - wave, 0.5f + 0.35f * d.z + 0.5f * wave};
      float* p = &env.rgba[(size_t(y) * env.width + x) * 4];
      for (int k = 0; k < 3; ++k) p[k] = reference::roundToBinary16(std::clamp(rgb[k], 0.0f, 1.0f));
      p[3] = 1.0f;
    }
  return env;
}

inline size_t countNonFinite(const std::vector<float>& values) {
  return size_t(std::count_if(values.begin(), values.end(), [](float v) { return !std::isfinite(v); }));
}

// Every dequantized coefficient of every texel (sample texels hold data; the others must decode
// finite too, since the GPU reads them), and every value of a Pca basis.
inline size_t countNonFiniteCoefficients(const Field& field) {
  size_t bad = countNonFinite(field.basis);
  for (uint32_t layer = 0; layer < field.layerCount(); ++layer)
    for (uint64_t t = 0; t < field.texelCount(); ++t)
      for (uint32_t v = 0; v < field.valuesPerLayer(); ++v)
        if (!std::isfinite(fieldCoefficient(field, layer, t, v))) ++bad;
  return bad;
}

// The smallest U8 range (scale) of a (layer, channel) pair relative to the largest one of the
// field: 0 when a pair is constant over the atlas (it then decodes exactly to its bias), tiny for
// nearly constant ones. -1 for F16 fields (no shared range).
inline double smallestRangeRatio(const Field& field) {
  if (field.quantization != Quantization::U8 || field.scale.empty()) return -1.0;
  const float largest = *std::max_element(field.scale.begin(), field.scale.end());
  const float smallest = *std::min_element(field.scale.begin(), field.scale.end());
  return largest > 0.0f ? double(smallest) / double(largest) : 0.0;
}

// Per pixel, the field's exit direction as the raster pass computes it: the nearest front-facing
// triangle of the render mesh along the pixel's ray (as reference::render finds it), its atlas
// coordinate, the bilinear sample of the distortion image, normalized, or the view direction when
// the sample is (nearly) zero (gpu_layout.h, kMinDirectionLength2). Zero where the ray misses.
inline std::vector<glm::vec3> fieldDirections(const Field& field, const reference::DistortionImage& distortion,
                                              const Camera& camera, uint32_t width, uint32_t height,
                                              std::vector<uint8_t>& hitMask) {
  const FieldMesh& m = field.mesh;
  std::vector<glm::vec3> out(size_t(width) * height, glm::vec3(0.0f));
  hitMask.assign(out.size(), 0);
  const glm::dvec3 eye(camera.eye[0], camera.eye[1], camera.eye[2]);
  auto vertex = [&](uint32_t i) {
    return glm::dvec3(m.positions[size_t(i) * 3], m.positions[size_t(i) * 3 + 1], m.positions[size_t(i) * 3 + 2]);
  };
  for (uint32_t y = 0; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) {
      const reference::Vec3 r = reference::pixelRay(camera, width, height, x, y);
      const glm::dvec3 d = glm::normalize(glm::dvec3(r[0], r[1], r[2]));
      double best = std::numeric_limits<double>::infinity();
      glm::dvec2 uv(0.0);
      for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
        const uint32_t i0 = m.indices[t], i1 = m.indices[t + 1], i2 = m.indices[t + 2];
        const glm::dvec3 p0 = vertex(i0), e1 = vertex(i1) - p0, e2 = vertex(i2) - p0;
        const glm::dvec3 pv = glm::cross(d, e2);
        const double det = glm::dot(e1, pv);
        if (!(det > 0.0)) continue;  // det = -dot(d, normal): back-facing or edge-on
        const glm::dvec3 tv = eye - p0;
        const double u = glm::dot(tv, pv) / det;
        if (u < 0.0 || u > 1.0) continue;
        const glm::dvec3 qv = glm::cross(tv, e1);
        const double v = glm::dot(d, qv) / det;
        if (v < 0.0 || u + v > 1.0) continue;
        const double dist = glm::dot(e2, qv) / det;
        if (dist <= 0.0 || dist >= best) continue;
        best = dist;
        const double w = 1.0 - u - v;
        for (int k = 0; k < 2; ++k)
          uv[k] = w * double(m.uvs[size_t(i0) * 2 + size_t(k)]) + u * double(m.uvs[size_t(i1) * 2 + size_t(k)]) +
                  v * double(m.uvs[size_t(i2) * 2 + size_t(k)]);
      }
      if (!std::isfinite(best)) continue;
      const size_t p = size_t(y) * width + x;
      hitMask[p] = 1;
      const reference::Vec4 s = reference::sampleBilinear(distortion, float(uv.x), float(uv.y));
      const glm::vec3 dir(s[0], s[1], s[2]);
      const float len2 = glm::dot(dir, dir);
      out[p] = len2 > 1e-20f ? dir / std::sqrt(len2) : glm::vec3(d);
    }
  return out;
}

struct StabilityCase {
  std::string name;
  bake::Scene scene;
  BakeSettings settings = smallSettings();
  Camera camera;
  uint32_t width = 64;
  uint32_t height = 48;
  uint32_t referenceBounces = 16;  // maxBounces of the exact reference (the bake's cap by default)
};

struct StabilityResult {
  bool ok = false;  // baked and rendered (the non-finite counts below are meaningful)
  Field field;
  reference::DistortionImage distortion;
  reference::RenderedImage image;  // the field through the CPU reference of the engine's passes
  bake::ReferenceImage exact;      // the exact reference
  size_t nonFiniteCoefficients = 0, nonFiniteDistortion = 0, nonFiniteImage = 0, nonFiniteExact = 0;
  double smallestRange = 0.0;  // smallestRangeRatio
  uint64_t eyeRays = 0, eyeLabelConflicts = 0, eyeTrapped = 0;  // exact eye rays of the reference view
  bake::ImageErrors errors;  // field vs exact over the pixels both see
};

// Bakes, decompresses, renders and compares. Failures of a stage are reported as test failures
// (ADD_FAILURE) and leave ok = false.
inline StabilityResult runCase(const StabilityCase& c) {
  StabilityResult r;
  bake::BakeOptions options;
  options.settings = c.settings;
  options.settings.source = c.name;
  auto baked = bake::bakeField(c.scene, options);
  if (!baked) {
    ADD_FAILURE() << c.name << ": bake failed: " << baked.error().message;
    return r;
  }
  r.field = std::move(baked).value();
  if (auto valid = validateField(r.field); !valid) ADD_FAILURE() << c.name << ": " << valid.error().message;
  r.nonFiniteCoefficients = countNonFiniteCoefficients(r.field);
  r.smallestRange = smallestRangeRatio(r.field);

  const bake::Image env = smoothEnvironment();
  r.distortion = reference::decompress(r.field, c.camera.eye);
  r.nonFiniteDistortion = countNonFinite(r.distortion.rgba);
  const reference::LatLongImage cpuEnv{env.width, env.height, env.rgba.data()};
  ObjectShading shading;  // as Object::createFromField sets it: k = 1, the front medium's tint, reflection on
  shading.tint = frontMediumColor(r.field);
  r.image = reference::render({{&r.field.mesh, &r.distortion, shading}}, cpuEnv, c.camera, c.width, c.height);
  r.nonFiniteImage = countNonFinite(r.image.rgba);

  auto tracer = bake::Tracer::create(c.scene);
  if (!tracer) {
    ADD_FAILURE() << c.name << ": tracer: " << tracer.error().message;
    return r;
  }
  bake::ReferenceOptions ro;
  ro.width = c.width;
  ro.height = c.height;
  ro.camera = c.camera;
  ro.maxBounces = c.referenceBounces;
  ro.threads = 2;
  auto exact = bake::renderReference(*tracer.value(), c.scene, env, ro);
  if (!exact) {
    ADD_FAILURE() << c.name << ": reference: " << exact.error().message;
    return r;
  }
  r.exact = std::move(exact).value();
  // renderReference writes 0 for a non-finite colour; the exit directions show what the tracer gave.
  r.nonFiniteExact = countNonFinite(r.exact.color.rgba);
  for (const glm::vec3& d : r.exact.directions)
    if (!std::isfinite(d.x) || !std::isfinite(d.y) || !std::isfinite(d.z)) ++r.nonFiniteExact;

  bake::TraceSettings ts;
  ts.maxBounces = c.referenceBounces;
  for (uint32_t y = 0; y < c.height; ++y)
    for (uint32_t x = 0; x < c.width; ++x) {
      const bake::EyeRayResult hit = tracer.value()->traceEyeRay(
          glm::vec3(c.camera.eye[0], c.camera.eye[1], c.camera.eye[2]),
          bake::pixelDirection(c.camera, c.width, c.height, x, y), ts);
      if (!hit.hit) continue;
      ++r.eyeRays;
      r.eyeLabelConflicts += hit.transmitted.labelConflicts;
      r.eyeTrapped += hit.transmitted.trapped ? 1 : 0;
    }

  std::vector<uint8_t> fieldMask;
  const std::vector<glm::vec3> directions =
      fieldDirections(r.field, r.distortion, c.camera, c.width, c.height, fieldMask);
  std::vector<uint8_t> mask(fieldMask.size());
  for (size_t p = 0; p < mask.size(); ++p) mask[p] = fieldMask[p] && r.exact.mask[p] && r.image.object[p] >= 0;
  const bake::Image approx{r.image.width, r.image.height, r.image.rgba};
  auto errors = bake::compareImages(approx, r.exact.color, mask, directions, r.exact.directions);
  if (!errors) {
    ADD_FAILURE() << c.name << ": compare: " << errors.error().message;
    return r;
  }
  r.errors = errors.value();
  r.ok = true;
  return r;
}

// One Markdown row per case; docs/stability.md collects them (columns explained there).
inline void printRow(const std::string& name, const StabilityResult& r) {
  const size_t triangles = r.field.mesh.indices.size() / 3;
  std::printf(
      "| stability | %s | %zu | %llu | %.2f | %.2f | %llu | %.1e | %llu / %llu | %llu | %llu | %.2f | %.2f | %.1f | "
      "%.1f | %zu |\n",
      name.c_str(), triangles, static_cast<unsigned long long>(r.field.statistics.samples),
      double(r.field.statistics.fitRmsDegrees), double(r.field.statistics.heldOutRmsDegrees),
      static_cast<unsigned long long>(r.field.statistics.trappedPaths), r.smallestRange,
      static_cast<unsigned long long>(r.eyeTrapped),
      static_cast<unsigned long long>(r.eyeRays), static_cast<unsigned long long>(r.eyeLabelConflicts),
      static_cast<unsigned long long>(r.errors.pixels), r.errors.meanAngleDegrees, r.errors.p95AngleDegrees,
      r.errors.maxAngleDegrees, r.errors.psnr,
      r.nonFiniteCoefficients + r.nonFiniteDistortion + r.nonFiniteImage + r.nonFiniteExact);
  std::fflush(stdout);
}

// The checks every case shares: it ran, nothing is NaN or Inf anywhere, and the object was seen.
inline void expectFiniteAndSeen(const std::string& name, const StabilityResult& r, uint64_t minPixels = 50) {
  ASSERT_TRUE(r.ok) << name;
  EXPECT_EQ(r.nonFiniteCoefficients, 0u) << name << ": NaN/Inf coefficients";
  EXPECT_EQ(r.nonFiniteDistortion, 0u) << name << ": NaN/Inf in the distortion image";
  EXPECT_EQ(r.nonFiniteImage, 0u) << name << ": NaN/Inf in the rendered image";
  EXPECT_EQ(r.nonFiniteExact, 0u) << name << ": NaN/Inf in the exact reference";
  EXPECT_GE(r.errors.pixels, minPixels) << name << ": the object is not in view";
  EXPECT_TRUE(std::isfinite(r.errors.meanAngleDegrees) && std::isfinite(r.errors.psnr)) << name;
}

// Geometry helpers for hand-made scenes.
inline bake::Surface transformed(bake::Surface s, double scale, glm::dvec3 offset) {
  for (glm::vec3& p : s.positions) p = glm::vec3(glm::dvec3(p) * scale + offset);
  return s;
}

inline Camera cameraAt(glm::dvec3 eye, glm::dvec3 target, double sceneSize, float fov = 40.0f) {
  Camera c;
  c.eye = {float(eye.x), float(eye.y), float(eye.z)};
  c.target = {float(target.x), float(target.y), float(target.z)};
  c.verticalFovDegrees = fov;
  c.nearPlane = float(0.01 * sceneSize);
  c.farPlane = float(1000.0 * sceneSize);
  return c;
}

}  // namespace shrefract::stability
