// A surface sample and its local frame: z is the shading normal (toward the outer medium), x and
// y a tangent basis that depends on the normal alone, so the same point with the same normal gets
// bit-identical frames from every triangle that shares it.
#pragma once

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>

namespace shrefract::bake {

struct SurfacePoint {
  glm::vec3 position{0.0f};
  glm::vec3 shadingNormal{0.0f, 0.0f, 1.0f};    // unit, interpolated vertex normal
  glm::vec3 geometricNormal{0.0f, 0.0f, 1.0f};  // unit, of the triangle (same side as the winding)
  uint32_t surface = 0;                         // index into Scene::surfaces
  uint32_t triangle = 0;                        // triangle index within that surface
};

struct LocalFrame {
  glm::vec3 tangent{1.0f, 0.0f, 0.0f};
  glm::vec3 bitangent{0.0f, 1.0f, 0.0f};
  glm::vec3 normal{0.0f, 0.0f, 1.0f};
};

// Orthonormal basis around a unit normal (Duff et al. 2017, "Building an Orthonormal Basis,
// Revisited"): branch-free apart from the sign, continuous except across n.z = 0 sign changes.
LocalFrame frameFromNormal(glm::vec3 normal);

// Rows of M_s: w = normalize(M_s * (eye, 1)) is the direction from the sample toward the eye,
// in the sample's frame. Row k = (axis_k, -dot(axis_k, position)). Layout matches Field::frames.
std::array<float, 12> localFromWorldRows(const glm::vec3& position, const LocalFrame& frame);

glm::vec3 localToWorld(const LocalFrame& frame, glm::vec3 local);
glm::vec3 worldToLocal(const LocalFrame& frame, glm::vec3 world);

}  // namespace shrefract::bake
