#include <shrefract/bake/sample_frame.h>

#include <cmath>

#include <glm/geometric.hpp>

namespace shrefract::bake {

LocalFrame frameFromNormal(glm::vec3 n) {
  const float sign = std::copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float b = n.x * n.y * a;
  LocalFrame f;
  f.tangent = glm::vec3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
  f.bitangent = glm::vec3(b, sign + n.y * n.y * a, -n.y);
  f.normal = n;
  return f;
}

std::array<float, 12> localFromWorldRows(const glm::vec3& p, const LocalFrame& f) {
  return {f.tangent.x,   f.tangent.y,   f.tangent.z,   -glm::dot(f.tangent, p),
          f.bitangent.x, f.bitangent.y, f.bitangent.z, -glm::dot(f.bitangent, p),
          f.normal.x,    f.normal.y,    f.normal.z,    -glm::dot(f.normal, p)};
}

glm::vec3 localToWorld(const LocalFrame& f, glm::vec3 v) { return f.tangent * v.x + f.bitangent * v.y + f.normal * v.z; }

glm::vec3 worldToLocal(const LocalFrame& f, glm::vec3 v) {
  return {glm::dot(f.tangent, v), glm::dot(f.bitangent, v), glm::dot(f.normal, v)};
}

}  // namespace shrefract::bake
