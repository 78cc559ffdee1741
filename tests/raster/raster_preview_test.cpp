// The raster pass on lavapipe against a CPU evaluation of the same shading: the background is the
// environment seen through the camera, and the sphere's single-interface shading (Fresnel
// reflection + one Snell bend) matches the analytic sphere where the tessellation is smooth.
#include <shrefract/cpu_reference.h>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <cmath>

#include "gpu_test_support.h"
#include "offscreen/offscreen.h"
#include "session_test_support.h"

namespace shrefract {
namespace {


glm::vec3 pixel(const bake::Image& img, uint32_t x, uint32_t y) {
  const float* p = &img.rgba[(size_t(y) * img.width + x) * 4];
  return {p[0], p[1], p[2]};
}

glm::vec3 rayThroughPixel(const Camera& cam, uint32_t w, uint32_t h, uint32_t x, uint32_t y) {
  glm::mat4 proj = glm::perspectiveRH_ZO(glm::radians(cam.verticalFovDegrees), float(w) / float(h), cam.nearPlane,
                                         cam.farPlane);
  proj[1][1] *= -1.0f;
  glm::mat4 view = glm::lookAtRH(glm::vec3(cam.eye[0], cam.eye[1], cam.eye[2]),
                                 glm::vec3(cam.target[0], cam.target[1], cam.target[2]),
                                 glm::vec3(cam.up[0], cam.up[1], cam.up[2]));
  view[3] = glm::vec4(0, 0, 0, 1);
  const glm::vec2 ndc((float(x) + 0.5f) / float(w) * 2.0f - 1.0f, (float(y) + 0.5f) / float(h) * 2.0f - 1.0f);
  return glm::normalize(glm::vec3(glm::inverse(proj * view) * glm::vec4(ndc, 1.0f, 1.0f)));
}

class RasterPreview : public testing::SessionTest {
};

TEST_F(RasterPreview, BackgroundMatchesCpuEnvironmentLookup) {
  const bake::Image env = bake::proceduralEnvironment(256);
  auto gpuEnv = offscreen::uploadEnvironment(*session, env);
  ASSERT_TRUE(gpuEnv.ok()) << gpuEnv.error().message;
  offscreen::FrameSettings frame;
  frame.width = 96;
  frame.height = 64;
  frame.camera.eye = {0.3f, 0.2f, 3.0f};
  frame.camera.target = {0.0f, -0.1f, 0.0f};
  auto image = offscreen::renderFrame(*session, *gpuEnv.value(), {}, frame);
  ASSERT_TRUE(image.ok()) << image.error().message;
  // Tolerance: the GPU stores the environment as half floats (relative 2^-11) and interpolates the
  // direction per vertex of a full-screen triangle before normalizing; 2% relative + 2e-3 absolute.
  int compared = 0;
  for (uint32_t y = 1; y < frame.height; y += 7)
    for (uint32_t x = 1; x < frame.width; x += 7) {
      const glm::vec3 expected = bake::sampleLatLong(env, rayThroughPixel(frame.camera, frame.width, frame.height, x, y));
      const glm::vec3 got = pixel(image.value(), x, y);
      for (int k = 0; k < 3; ++k)
        EXPECT_NEAR(got[k], expected[k], 2e-3f + 0.02f * expected[k]) << "pixel " << x << "," << y;
      ++compared;
    }
  EXPECT_GT(compared, 50);
}

TEST_F(RasterPreview, SphereSingleInterfaceMatchesAnalyticSphere) {
  const bake::Image env = bake::proceduralEnvironment(512);
  auto gpuEnv = offscreen::uploadEnvironment(*session, env);
  ASSERT_TRUE(gpuEnv.ok());
  bake::BuiltinSceneOptions opts;
  opts.tessellation = 5;  // fine enough that interpolated normals are close to the analytic sphere
  auto scene = bake::makeBuiltinScene("sphere", opts);
  ASSERT_TRUE(scene.ok());
  auto objects = offscreen::uploadScene(*session, scene.value());
  ASSERT_TRUE(objects.ok()) << objects.error().message;
  std::vector<Object*> list;
  for (auto& o : objects.value()) list.push_back(o.get());

  offscreen::FrameSettings frame;
  frame.width = 128;
  frame.height = 128;
  frame.camera.eye = {0.0f, 0.5f, 4.0f};
  frame.camera.target = {0.0f, 0.0f, 0.0f};
  frame.camera.verticalFovDegrees = 40.0f;
  auto with = offscreen::renderFrame(*session, *gpuEnv.value(), list, frame);
  auto without = offscreen::renderFrame(*session, *gpuEnv.value(), {}, frame);
  ASSERT_TRUE(with.ok() && without.ok());

  const glm::vec3 eye(frame.camera.eye[0], frame.camera.eye[1], frame.camera.eye[2]);
  int inside = 0, differing = 0, checked = 0, matching = 0;
  for (uint32_t y = 0; y < frame.height; y += 3)
    for (uint32_t x = 0; x < frame.width; x += 3) {
      const glm::vec3 d = rayThroughPixel(frame.camera, frame.width, frame.height, x, y);
      // Analytic ray-sphere intersection with the unit sphere.
      const float b = glm::dot(eye, d);
      const float c = glm::dot(eye, eye) - 1.0f;
      const float disc = b * b - c;
      const glm::vec3 got = pixel(with.value(), x, y);
      for (int k = 0; k < 3; ++k) ASSERT_TRUE(std::isfinite(got[k]));
      if (disc < 0.0f) {
        // Outside the silhouette (with a margin for the polygonal outline) nothing changes.
        if (b * b - c < -0.05f) {
          EXPECT_LT(glm::length(got - pixel(without.value(), x, y)), 1e-6f) << x << "," << y;
        }
        continue;
      }
      ++inside;
      if (glm::length(got - pixel(without.value(), x, y)) > 1e-3f) ++differing;
      const glm::vec3 p = eye + d * (-b - std::sqrt(disc));
      const glm::vec3 n = glm::normalize(p);
      const float cosI = -glm::dot(d, n);
      if (cosI < 0.5f) continue;  // near the silhouette the tessellation's normals differ more
      const float eta = 1.0f / 1.5f;
      const glm::vec3 refl = glm::reflect(d, n);
      const glm::vec3 refr = glm::refract(d, n, eta);
      const float f = reference::fresnelDielectric(cosI, eta);
      const glm::vec3 expected = (1.0f - f) * bake::sampleLatLong(env, refr) * scene.value().media[1].color +
                                 f * bake::sampleLatLong(env, refl);
      // Tolerance: facet normals of a level-5 icosphere differ from the analytic normal by < 0.5
      // degree, which moves the refracted lookup by about a texel; 10% relative + 0.02 absolute,
      // and at least 90% of the checked pixels must meet it (edges of checker squares may not).
      bool ok = true;
      for (int k = 0; k < 3; ++k) ok = ok && std::fabs(got[k] - expected[k]) <= 0.02f + 0.1f * expected[k];
      ++checked;
      if (ok) ++matching;
    }
  EXPECT_GT(inside, 100);
  EXPECT_GT(differing, inside * 9 / 10) << "the sphere must be visible over the environment";
  EXPECT_GT(checked, 50);
  EXPECT_GE(matching * 10, checked * 9) << matching << " of " << checked << " pixels within tolerance";
}

}  // namespace
}  // namespace shrefract
