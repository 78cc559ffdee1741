// A point on a scene surface, as the tracer finds and starts paths from it (sample_frame.h builds
// a sample's frame on it).
#pragma once

#include <glm/vec3.hpp>

#include <cstdint>

namespace shrefract::bake {

struct SurfacePoint {
  glm::vec3 position{0.0f};
  glm::vec3 shadingNormal{0.0f, 0.0f, 1.0f};    // unit, interpolated vertex normal
  glm::vec3 geometricNormal{0.0f, 0.0f, 1.0f};  // unit, of the triangle (same side as the winding)
  uint32_t surface = 0;                         // index into Scene::surfaces
  uint32_t triangle = 0;                        // triangle index within that surface
};

}  // namespace shrefract::bake
