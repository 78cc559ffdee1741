// The unit vector along a, or +z for the zero vector: the volume's normals and paths on the CPU,
// as volume_trace.glsl unitOr.
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <cmath>

namespace shrefract {

inline glm::vec3 unitOrZ(glm::vec3 a) {
  const float len2 = glm::dot(a, a);
  return len2 > 0.0f ? (1.0f / std::sqrt(len2)) * a : glm::vec3{0.0f, 0.0f, 1.0f};
}

}  // namespace shrefract
