// What the parts of the CPU mirror share (cpu_reference.cpp, environment_lookup.cpp, raster.cpp).
// Private to engine/reference/src.
#pragma once

#include <shrefract/cpu_reference.h>

#include <glm/glm.hpp>

#include <cstdint>

namespace shrefract::reference {

inline glm::vec3 toGlm(const Vec3& v) { return {v[0], v[1], v[2]}; }
inline Vec3 fromGlm(const glm::vec3& v) { return {v.x, v.y, v.z}; }

// Where tap i of n sits along one of the pixel's axes, in (-1/2, 1/2) (environment_select.glsl).
inline float tapOffset(uint32_t i, float n) { return (float(i) + 0.5f) / n - 0.5f; }

// What the object pass computes from its inputs before the lookups (object_field_body.glsl).
struct FieldFragment {
  glm::vec2 uv{0.0f};
  glm::vec3 v, n;
  float cosView = 0.0f;  // -v . n before n is bent toward the viewer
  float cosI = 0.0f;
  Vec4 d{};
  float len2 = 0.0f;
  glm::vec3 exitWorld, reflectedWorld;
};

// The fragment either shading computes for `object` at `point`.
FieldFragment objectFragment(const RenderObject& object, const SurfacePoint& point, const Vec3& eye);

}  // namespace shrefract::reference
