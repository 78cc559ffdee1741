// A surface sample and its local frame: z is the shading normal (toward the outer medium), x and
// y a tangent basis. The tangent follows the latitude around the object's up axis (+Y, glTF's up),
// so that samples a rotation about that axis maps onto each other (a torus's ring, a glass's wall,
// a sphere's parallels) get the same frame relative to their geometry and, with exits stored in the
// frame (field.h BakeRecord::exitFrame), the same functions: a Pca basis then spends no
// functions on rotated copies. A frame depends on the sample's point alone, so every triangle that
// shares a traced point gets the same, bit-identical frame.
#pragma once

#include <shrefract/trace/surface_point.h>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>

namespace shrefract::bake {

struct LocalFrame {
  glm::vec3 tangent{1.0f, 0.0f, 0.0f};
  glm::vec3 bitangent{0.0f, 1.0f, 0.0f};
  glm::vec3 normal{0.0f, 0.0f, 1.0f};
};

// Within asin(0.1), about 5.7 deg, of the up axis the latitude turns too fast to follow (and is
// undefined on the axis): there the tangent is +X projected onto the tangent plane.
inline constexpr float kPolarCapSin2 = 0.01f;

// Right-handed orthonormal frame around a unit normal: tangent = normalize(up x n) outside the polar
// cap (continuous there), bitangent = n x tangent. Discontinuous only across the cap's rim.
LocalFrame frameFromNormal(glm::vec3 normal);

// Shading normals within this angle of the triangle's own normal mark a flat face: about 0.08 deg.
inline constexpr float kFlatFaceCosine = 1.0f - 1e-6f;

// The frame a sample's directions are traced and stored in: frameFromNormal, except in the polar
// cap of a curved surface off the axis, where the tangent is up x position in the tangent plane.
// That is the latitude through the point, so the cap of a surface of revolution (a torus's top and
// bottom rings, a sphere's polar caps) keeps the symmetry the rest of it has. A flat face across
// the axis (a cube's top) keeps +X: there up x position would turn the frame from sample to sample
// of alike geometry (docs/technique.md, "Sample layouts").
LocalFrame frameAt(const SurfacePoint& point);

// Rows of M_s: w = normalize(M_s * (eye, 1)) is the direction from the sample toward the eye,
// in the sample's frame. Row k = (axis_k, -dot(axis_k, position)). Layout matches Field::frames.
std::array<float, 12> localFromWorldRows(const glm::vec3& position, const LocalFrame& frame);

glm::vec3 localToWorld(const LocalFrame& frame, glm::vec3 local);
glm::vec3 worldToLocal(const LocalFrame& frame, glm::vec3 world);

}  // namespace shrefract::bake
