// Scenes for the baker: media (air, glass, water), the surfaces between them, built-in test scenes
// and the topology checks that every scene (built-in or imported) must pass before it is baked.
#pragma once

#include <shrefract/result.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace shrefract::bake {

// A homogeneous transparent medium.
struct Medium {
  std::string name;
  float ior = 1.0f;
  // Weight per unit length for the optical depth tau accumulated inside this medium (0 = clear).
  float absorption = 0.0f;
  // Colour of the light transmitted into this medium through a front surface (linear RGB), applied
  // with exp(-tau * k) in every render mode (docs/scenes.md, "Colour model").
  glm::vec3 color{1.0f};
};

// An interface between two media. Its normals and its winding (counter-clockwise seen from the
// normal side) point toward `outerMedium`; `innerMedium` is the side behind the surface.
struct Surface {
  std::string name;
  std::vector<glm::vec3> positions;  // world space
  std::vector<glm::vec3> normals;    // per vertex, unit length
  std::vector<glm::vec2> uvs;        // optional TEXCOORD_0: empty or one per vertex
  std::vector<uint32_t> indices;     // triangle list
  uint32_t innerMedium = 1;
  uint32_t outerMedium = 0;
};

struct Scene {
  std::string name;
  std::vector<Medium> media;      // media[0] is the surrounding medium (air, ior 1)
  std::vector<Surface> surfaces;  // world space
};

// Axis-aligned box around every position of every surface. A scene without positions gives
// min = max = (0,0,0).
struct Bounds {
  glm::vec3 min{0.0f};
  glm::vec3 max{0.0f};
};
Bounds bounds(const Scene& scene);

// Checks the structural contract of a scene: at least one medium and one surface; every surface
// has at least one triangle, as many normals as positions, no UVs or one per vertex, indices in
// range, finite positions and UVs, unit normals (|length - 1| <= 1e-3), media indices in range and
// innerMedium != outerMedium; every medium has a finite ior > 0, a finite absorption >= 0 and a
// finite, non-negative colour. Errors are InvalidArgument and name the surface or medium.
// Topology (closedness) is checked separately, by checkMediumClosure.
Result<void> validateScene(const Scene& scene);

// Edge statistics of a triangle set whose vertices are welded by exact position (+0 and -0 weld),
// so meshes with per-face normals (duplicated vertices) count as connected.
struct TopologyReport {
  size_t triangles = 0;            // triangles examined
  // Triangles with two corners at the same (welded) point (their edges are skipped) or zero area
  // (collinear corners; their edges still count).
  size_t degenerateTriangles = 0;
  size_t openEdges = 0;            // undirected edges used by exactly one triangle
  size_t inconsistentEdges = 0;    // edges used by two triangles in the same direction (winding flips)
  size_t nonManifoldEdges = 0;     // edges used by more than two triangles
  // True when there is at least one triangle and no open, inconsistent or non-manifold edge.
  bool closed() const;
};

// Topology of one surface as stored (its own winding).
TopologyReport checkSurface(const Surface& surface);

// Topology of the boundary of `medium`: every triangle of every surface that has `medium` on one
// side, oriented so that its normal points away from the medium (triangles of surfaces whose
// outerMedium is `medium` are flipped). A medium that is a properly bounded volume reports
// closed(). Precondition: validateScene(scene) succeeded.
TopologyReport checkMediumClosure(const Scene& scene, uint32_t medium);

// Signed volume enclosed by the boundary of `medium` (the same oriented triangle set as
// checkMediumClosure), by the divergence theorem, accumulated in double. Positive when the
// boundary is closed and its normals point away from the medium. Precondition: validateScene.
double signedVolume(const Scene& scene, uint32_t medium);

// --- Built-in scenes ---------------------------------------------------------------------------
//
// "sphere"         glass (ior 1.5), unit radius at the origin: subdivided icosahedron, normals equal
//                  the (unit) positions.
// "cube"           glass (ior 1.5), edge 2 centred at the origin, flat normals: every face has its
//                  own vertices, so the mesh is closed by position, not by index.
// "torus"          glass (ior 1.5), major radius 1, minor radius 0.35, around the y axis.
// "glass-of-water" air, glass (ior 1.5) and water (ior 1.33): a cylindrical cup (y up, base at
//                  y = -1, rim at y = 1) partly filled with water. See docs/scenes.md.
//
// Media: media[0] is air in every built-in scene and media[1] is the glass.

// Tessellation levels accepted by makeBuiltinScene; each level roughly quadruples the triangles.
inline constexpr int kMinTessellation = 0;
inline constexpr int kMaxTessellation = 7;

struct BuiltinSceneOptions {
  // kMinTessellation (coarsest) .. kMaxTessellation. Triangle counts at level L:
  // sphere 20 * 4^L, cube 12 * 4^L, torus 2 * (8 * 2^L) * (4 * 2^L), glass-of-water grows as 4^L.
  int tessellation = 3;
  // Replaces the ior of media[1] (the glass). Must be finite and > 0.
  std::optional<float> iorOverride;
  // Replaces the absorption of every medium except air (media[0]). Must be finite and >= 0.
  std::optional<float> absorptionOverride;
};

// Names accepted by makeBuiltinScene, in a stable order.
std::vector<std::string> builtinSceneNames();

// The scene the tools use when none is named: "sphere".
std::string_view defaultBuiltinScene();

// Builds a built-in scene. Errors (InvalidArgument): an unknown name (the message lists the valid
// names), a tessellation level out of range, an override that is not finite or out of range.
Result<Scene> makeBuiltinScene(std::string_view name, const BuiltinSceneOptions& options = {});

}  // namespace shrefract::bake
