// Shared by the reference renderer tests: a built-in scene with its tracer and environment, and
// the sphere's view.
#pragma once

#include <gtest/gtest.h>
#include <shrefract/bake/bake.h>
#include <shrefract/trace/image_metrics.h>
#include <shrefract/bake/layout.h>
#include <shrefract/trace/reference_render.h>
#include <shrefract/bake/sample_frame.h>
#include <shrefract/cpu_reference.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <numbers>

#include <glm/glm.hpp>

#include <memory>

namespace shrefract::bake::reference_test {

struct SphereSetup {
  Scene scene;
  std::unique_ptr<Tracer> tracer;
  Image env = proceduralEnvironment(128);
};

// A built-in scene, its tracer and the procedural environment.
inline SphereSetup builtin(const char* name, int tessellation) {
  SphereSetup s;
  auto scene = makeBuiltinScene(name, {tessellation, std::nullopt, std::nullopt});
  EXPECT_TRUE(scene.ok());
  s.scene = std::move(scene).value();
  auto tracer = Tracer::create(s.scene);
  EXPECT_TRUE(tracer.ok());
  s.tracer = std::move(tracer).value();
  return s;
}

inline SphereSetup sphere(int tessellation) { return builtin("sphere", tessellation); }

inline ReferenceOptions sphereView(uint32_t width, uint32_t height) {
  ReferenceOptions o;
  o.width = width;
  o.height = height;
  o.camera.eye = {0.0f, 0.3f, 3.5f};
  o.camera.verticalFovDegrees = 40.0f;
  o.threads = 2;
  return o;
}

}  // namespace shrefract::bake::reference_test
