// Transform: world = t + s * q v q*, the one implementation the passes, the CPU reference and
// hosts share (no Vulkan calls: the fuzz targets link it with the CPU reference).
#include <shrefract/object.h>

#include <array>
#include <cmath>

#include "object/object_impl.h"

namespace shrefract {

namespace {

using Vec3 = std::array<float, 3>;

std::array<float, 4> unitQuaternion(const std::array<float, 4>& q) {
  const float n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(n > 0.0f) || !std::isfinite(n)) return {0.0f, 0.0f, 0.0f, 1.0f};
  return {q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}

Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// v + 2 u x (u x v + w v), as rotateByQuaternion in the shaders.
Vec3 rotate(const std::array<float, 4>& q, const Vec3& v) {
  const Vec3 u{q[0], q[1], q[2]};
  const Vec3 c = cross(u, v);
  const Vec3 inner{c[0] + q[3] * v[0], c[1] + q[3] * v[1], c[2] + q[3] * v[2]};
  const Vec3 t = cross(u, inner);
  return {v[0] + 2.0f * t[0], v[1] + 2.0f * t[1], v[2] + 2.0f * t[2]};
}

std::array<float, 4> conjugate(const std::array<float, 4>& q) { return {-q[0], -q[1], -q[2], q[3]}; }

}  // namespace

std::array<float, 4> unitRotation(const Transform& t) { return unitQuaternion(t.rotation); }

Vec3 rotateDirection(const Transform& t, const Vec3& d) { return rotate(unitQuaternion(t.rotation), d); }

Vec3 inverseRotateDirection(const Transform& t, const Vec3& d) {
  return rotate(conjugate(unitQuaternion(t.rotation)), d);
}

Vec3 transformPoint(const Transform& t, const Vec3& p) {
  const Vec3 r = rotateDirection(t, p);
  return {t.translation[0] + t.scale * r[0], t.translation[1] + t.scale * r[1], t.translation[2] + t.scale * r[2]};
}

Vec3 inverseTransformPoint(const Transform& t, const Vec3& p) {
  const Vec3 d{p[0] - t.translation[0], p[1] - t.translation[1], p[2] - t.translation[2]};
  const Vec3 r = inverseRotateDirection(t, d);
  return {r[0] / t.scale, r[1] / t.scale, r[2] / t.scale};
}

}  // namespace shrefract
