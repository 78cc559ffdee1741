// The exact reference renderer against the closed-form path through a sphere, and the metrics.
#include <gtest/gtest.h>
#include <shrefract/bake/image_metrics.h>
#include <shrefract/bake/reference_render.h>

#include <algorithm>
#include <cmath>

#include <glm/glm.hpp>

namespace shrefract::bake {
namespace {

float fresnel(float cosI, float eta) {
  const float sin2T = eta * eta * std::max(0.0f, 1.0f - cosI * cosI);
  if (sin2T >= 1.0f) return 1.0f;
  const float cosT = std::sqrt(1.0f - sin2T);
  const float rs = (eta * cosI - cosT) / (eta * cosI + cosT);
  const float rp = (cosI - eta * cosT) / (cosI + eta * cosT);
  return 0.5f * (rs * rs + rp * rp);
}

// Closed form on the analytic unit sphere: refract in, then at every interface the branch of
// higher energy; chords are p + t * (-2 p.t). Returns false if the eye ray misses.
bool analyticExit(glm::dvec3 eye, glm::dvec3 d, double ior, glm::dvec3& exitDir) {
  const double b = glm::dot(eye, d), c = glm::dot(eye, eye) - 1.0, disc = b * b - c;
  if (disc <= 0.0) return false;
  glm::dvec3 p = eye + d * (-b - std::sqrt(disc));
  glm::dvec3 t = glm::refract(d, p, 1.0 / ior);
  for (int k = 0; k < 16; ++k) {
    p = p + t * (-2.0 * glm::dot(p, t));
    const glm::dvec3 n = -p;  // inward normal faces the ray inside
    const float cosI = static_cast<float>(-glm::dot(t, n));
    const float r = fresnel(cosI, static_cast<float>(ior));
    if (r >= 0.5f) {
      t = glm::reflect(t, n);
    } else {
      exitDir = glm::normalize(glm::refract(t, n, ior));
      return true;
    }
  }
  exitDir = t;
  return true;
}

struct SphereErrors {
  double meanRad = 0, maxRad = 0;
  int pixels = 0;
};

SphereErrors exactVsAnalytic(int tessellation) {
  auto scene = makeBuiltinScene("sphere", {tessellation, std::nullopt, std::nullopt});
  EXPECT_TRUE(scene.ok());
  auto tracer = Tracer::create(scene.value());
  EXPECT_TRUE(tracer.ok());
  ReferenceOptions o;
  o.width = 64;
  o.height = 64;
  o.camera.eye = {0.0f, 0.3f, 3.5f};
  o.camera.verticalFovDegrees = 40.0f;
  o.threads = 2;
  const Image env = proceduralEnvironment(64);
  auto img = renderReference(*tracer.value(), scene.value(), env, o);
  EXPECT_TRUE(img.ok());
  SphereErrors e;
  const glm::dvec3 eye(0.0, 0.3, 3.5);
  for (uint32_t y = 0; y < o.height; ++y)
    for (uint32_t x = 0; x < o.width; ++x) {
      const size_t p = size_t(y) * o.width + x;
      const glm::dvec3 d(pixelDirection(o.camera, o.width, o.height, x, y));
      glm::dvec3 expected;
      if (!analyticExit(eye, d, 1.5, expected)) continue;
      // Pixels whose ray meets the polygonal silhouette differently from the analytic one.
      const double b = glm::dot(eye, d), disc = b * b - (glm::dot(eye, eye) - 1.0);
      if (disc < 0.05 || !img.value().mask[p]) continue;
      const double angle =
          std::acos(std::clamp(glm::dot(glm::dvec3(img.value().directions[p]), expected), -1.0, 1.0));
      e.meanRad += angle;
      e.maxRad = std::max(e.maxRad, angle);
      ++e.pixels;
    }
  if (e.pixels) e.meanRad /= e.pixels;
  return e;
}

TEST(ReferenceRender, ExactModeConvergesToTheClosedFormSphere) {
  double previous = 1e9;
  for (int level : {2, 4, 6}) {
    const SphereErrors e = exactVsAnalytic(level);
    std::printf("sphere tessellation %d: mean %.2e rad, max %.2e rad over %d pixels\n", level, e.meanRad, e.maxRad,
                e.pixels);
    EXPECT_GT(e.pixels, 500);
    EXPECT_LT(e.meanRad, previous * 0.5) << "error must shrink with refinement";
    previous = e.meanRad;
  }
  EXPECT_LT(previous, 2e-3);
}

TEST(ReferenceRender, ModesProduceFiniteImagesAndMasks) {
  auto scene = makeBuiltinScene("glass-of-water", {2, std::nullopt, std::nullopt});
  ASSERT_TRUE(scene.ok());
  auto tracer = Tracer::create(scene.value());
  ASSERT_TRUE(tracer.ok());
  const Image env = proceduralEnvironment(128);
  for (ReferenceMode mode : {ReferenceMode::Exact, ReferenceMode::FullTree, ReferenceMode::SingleInterface}) {
    ReferenceOptions o;
    o.mode = mode;
    o.width = 48;
    o.height = 48;
    o.camera.eye = {0.5f, 2.0f, 4.5f};
    o.treeDepth = 4;
    o.threads = 2;
    auto img = renderReference(*tracer.value(), scene.value(), env, o);
    ASSERT_TRUE(img.ok());
    size_t hits = 0;
    for (size_t p = 0; p < img.value().mask.size(); ++p) hits += img.value().mask[p];
    EXPECT_GT(hits, 100u);
    for (float v : img.value().color.rgba) ASSERT_TRUE(std::isfinite(v));
  }
}

TEST(ImageMetrics, IdenticalAndDifferentImages) {
  Image a;
  a.width = 16;
  a.height = 16;
  a.rgba.assign(16 * 16 * 4, 0.5f);
  std::vector<uint8_t> mask(256, 1);
  std::vector<glm::vec3> dirs(256, glm::vec3(0, 0, 1));
  auto same = compareImages(a, a, mask, dirs, dirs);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->psnr, 100.0);
  EXPECT_NEAR(same->ssim, 1.0, 1e-9);
  EXPECT_EQ(same->maxAngleDegrees, 0.0);
  Image b = a;
  for (size_t i = 0; i < b.rgba.size(); i += 4) b.rgba[i] = 0.6f;
  std::vector<glm::vec3> tilted(256, glm::normalize(glm::vec3(1, 0, 1)));
  auto diff = compareImages(a, b, mask, dirs, tilted);
  ASSERT_TRUE(diff.ok());
  // MSE = 0.01 / 3 over RGB -> PSNR = 10 log10(300).
  EXPECT_NEAR(diff->psnr, 10.0 * std::log10(300.0), 1e-4);  // 0.6f - 0.5f is not exactly 0.1
  EXPECT_NEAR(diff->meanAngleDegrees, 45.0, 1e-4);
  EXPECT_FALSE(compareImages(a, b, std::vector<uint8_t>(3), {}, {}).ok());
}

}  // namespace
}  // namespace shrefract::bake
