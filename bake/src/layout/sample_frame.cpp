#include <shrefract/bake/sample_frame.h>

#include <cmath>

#include <glm/geometric.hpp>

namespace shrefract::bake {

LocalFrame frameFromNormal(glm::vec3 n) {
  // Along the latitude: up x n, unit where it is long enough to normalize without loss.
  const glm::vec3 latitude(n.z, 0.0f, -n.x);
  const float length2 = latitude.x * latitude.x + latitude.z * latitude.z;
  LocalFrame f;
  f.normal = n;
  if (length2 > kPolarCapSin2) {
    f.tangent = latitude / std::sqrt(length2);
  } else {  // near the up axis: +X projected onto the tangent plane (|n.x| < 0.1, so never short)
    const glm::vec3 x = glm::vec3(1.0f, 0.0f, 0.0f) - n * n.x;
    f.tangent = x / std::sqrt(glm::dot(x, x));
  }
  f.bitangent = glm::cross(n, f.tangent);
  return f;
}

LocalFrame frameAt(const SurfacePoint& point) {
  const glm::vec3 n = point.shadingNormal, p = point.position;
  const bool inCap = n.x * n.x + n.z * n.z <= kPolarCapSin2;
  const bool flat = std::abs(glm::dot(n, point.geometricNormal)) >= kFlatFaceCosine;
  // Up x position: horizontal, so never short against n within the cap (|n.y| > 0.99).
  const glm::vec3 around(p.z, 0.0f, -p.x);
  const float radius2 = around.x * around.x + around.z * around.z;
  if (!inCap || flat || !(radius2 > 1e-8f * glm::dot(p, p))) return frameFromNormal(n);
  const glm::vec3 t = around - n * glm::dot(around, n);
  LocalFrame f;
  f.normal = n;
  f.tangent = t / std::sqrt(glm::dot(t, t));
  f.bitangent = glm::cross(n, f.tangent);
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
