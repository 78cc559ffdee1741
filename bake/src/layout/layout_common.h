// Private helpers shared by the split and charts layouts: the laid-out triangles with their welded
// vertices, the sample target from the options, and small geometry utilities.
#pragma once

#include <shrefract/bake/layout.h>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace shrefract::bake::layout_detail {

// Atlas sides above this would overflow 32-bit texel indices; larger maxAtlasSize values act as it.
inline constexpr uint32_t kLargestAtlas = 65535;

// A triangle of a surface with outerMedium == 0.
struct FrontTriangle {
  uint32_t surface = 0;
  uint32_t triangle = 0;             // index within the surface
  std::array<uint32_t, 3> vertex{};  // surface vertex indices
  std::array<uint32_t, 3> weld{};    // welded vertex ids (FrontMesh::weldPositions)
};

// Welded ids are assigned in order of first appearance (surface, triangle, corner), so they are
// deterministic. Vertices weld when they belong to the same surface and have bitwise equal
// position and normal (+0 and -0 weld).
struct FrontMesh {
  std::vector<FrontTriangle> triangles;
  std::vector<glm::vec3> weldPositions;  // position of the first vertex of each welded id
  std::vector<glm::vec3> weldNormals;    // its normal, normalized
  double area = 0.0;                     // world-space area of all front triangles
};

inline glm::vec3 normalizeOr(glm::vec3 v, glm::vec3 fallback) {
  const float length = glm::length(v);
  return length > 0.0f && std::isfinite(length) ? v / length : fallback;
}

// Unit normal of the triangle (counter-clockwise side); `fallback` for a degenerate triangle.
inline glm::vec3 triangleNormal(glm::vec3 p0, glm::vec3 p1, glm::vec3 p2, glm::vec3 fallback) {
  return normalizeOr(glm::cross(p1 - p0, p2 - p0), fallback);
}

inline double triangleArea(glm::vec3 p0, glm::vec3 p1, glm::vec3 p2) {
  const glm::dvec3 a = glm::dvec3(p1) - glm::dvec3(p0);
  const glm::dvec3 b = glm::dvec3(p2) - glm::dvec3(p0);
  return 0.5 * glm::length(glm::cross(a, b));
}

inline Result<FrontMesh> collectFront(const Scene& scene) {
  if (Result<void> valid = validateScene(scene); !valid) {
    return valid.error();
  }
  FrontMesh mesh;
  std::map<std::array<uint32_t, 7>, uint32_t> welds;
  const auto bits = [](float f) { return std::bit_cast<uint32_t>(f + 0.0f); };  // -0 -> +0
  for (uint32_t s = 0; s < scene.surfaces.size(); ++s) {
    const Surface& surface = scene.surfaces[s];
    if (surface.outerMedium != 0) {
      continue;
    }
    for (uint32_t t = 0; t < surface.indices.size() / 3; ++t) {
      FrontTriangle triangle;
      triangle.surface = s;
      triangle.triangle = t;
      for (uint32_t c = 0; c < 3; ++c) {
        const uint32_t v = surface.indices[3 * t + c];
        const glm::vec3 p = surface.positions[v];
        const glm::vec3 n = surface.normals[v];
        const std::array<uint32_t, 7> key = {s,       bits(p.x), bits(p.y), bits(p.z),
                                             bits(n.x), bits(n.y), bits(n.z)};
        const auto [it, inserted] = welds.try_emplace(key, static_cast<uint32_t>(mesh.weldPositions.size()));
        if (inserted) {
          mesh.weldPositions.push_back(p);
          mesh.weldNormals.push_back(normalizeOr(n, glm::vec3(0.0f, 0.0f, 1.0f)));
        }
        triangle.vertex[c] = v;
        triangle.weld[c] = it->second;
      }
      mesh.area += triangleArea(surface.positions[triangle.vertex[0]],
                                surface.positions[triangle.vertex[1]],
                                surface.positions[triangle.vertex[2]]);
      mesh.triangles.push_back(triangle);
    }
  }
  if (mesh.triangles.empty()) {
    return makeError(ErrorCode::InvalidArgument,
                     "scene '" + scene.name + "' has no surface facing the surrounding medium "
                     "(outerMedium == 0): nothing to lay out");
  }
  return mesh;
}

// Number of unique samples the options ask for, given the laid-out area.
inline Result<double> sampleTarget(const LayoutOptions& options, double area) {
  if (options.maxAtlasSize == 0) {
    return makeError(ErrorCode::InvalidArgument, "layout maxAtlasSize must be > 0");
  }
  if (!(std::isfinite(options.samplesPerUnitArea) && options.samplesPerUnitArea >= 0.0f)) {
    return makeError(ErrorCode::InvalidArgument, "layout samplesPerUnitArea " +
                                                     std::to_string(options.samplesPerUnitArea) +
                                                     " must be finite and >= 0");
  }
  if (options.sampleBudget > 0 && options.samplesPerUnitArea > 0.0f) {
    return makeError(ErrorCode::InvalidArgument,
                     "layout options name both a sample budget and a density: give one");
  }
  if (options.samplesPerUnitArea > 0.0f) {
    return std::max(1.0, static_cast<double>(options.samplesPerUnitArea) * area);
  }
  return static_cast<double>(options.sampleBudget > 0 ? options.sampleBudget : kDefaultSampleBudget);
}

// What both layouts start from: the scene's front triangles and the samples asked of their area.
struct FrontAndTarget {
  FrontMesh front;
  double target = 0.0;
};
inline Result<FrontAndTarget> frontAndTarget(const Scene& scene, const LayoutOptions& options) {
  Result<FrontMesh> front = collectFront(scene);
  if (!front) return front.error();
  Result<double> target = sampleTarget(options, front->area);
  if (!target) return target.error();
  return FrontAndTarget{std::move(front).value(), target.value()};
}

// One use of an undirected welded edge: edge e of a triangle runs from corner e to corner (e+1)%3.
struct EdgeUse {
  uint64_t key = 0;  // (lower welded id << 32) | higher welded id
  uint32_t triangle = 0;
  uint32_t edge = 0;
};

inline uint64_t edgeKey(uint32_t a, uint32_t b) {
  return (uint64_t(std::min(a, b)) << 32) | uint64_t(std::max(a, b));
}
// The welded ids of a key's edge: the lower and the higher.
inline uint32_t lowerEnd(uint64_t key) { return static_cast<uint32_t>(key >> 32); }
inline uint32_t higherEnd(uint64_t key) { return static_cast<uint32_t>(key); }

// The corner of `use`'s triangle at welded id `id`, one of the two ends of its edge.
inline uint32_t cornerAt(const FrontMesh& mesh, const EdgeUse& use, uint32_t id) {
  return mesh.triangles[use.triangle].weld[use.edge] == id ? use.edge : (use.edge + 1) % 3;
}

// Calls visit(first, end) for each welded edge, [first, end) the run of its uses in `uses`
// (sortedEdgeUses).
template <class Visit>
void forEachWeldedEdge(const std::vector<EdgeUse>& uses, Visit&& visit) {
  for (size_t first = 0; first < uses.size();) {
    size_t end = first + 1;
    while (end < uses.size() && uses[end].key == uses[first].key) ++end;
    visit(first, end);
    first = end;
  }
}

// Each welded edge's first use against every other one, at the atlas uvs of the render vertices
// vertexAt(use, welded id), into atlas.sharedEdges: every pair, or with `seamsOnly` the pairs
// whose positions differ.
template <class VertexAt>
void appendSharedEdges(const std::vector<EdgeUse>& uses, VertexAt&& vertexAt, bool seamsOnly, SampleAtlas& atlas) {
  const auto uvOf = [&](const EdgeUse& use, uint32_t id) {
    const size_t v = vertexAt(use, id);
    return std::array<float, 2>{atlas.mesh.uvs[2 * v], atlas.mesh.uvs[2 * v + 1]};
  };
  forEachWeldedEdge(uses, [&](size_t first, size_t end) {
    const uint32_t lo = lowerEnd(uses[first].key), hi = higherEnd(uses[first].key);
    for (size_t other = first + 1; other < end && lo != hi; ++other) {
      const SampleAtlas::SharedEdge edge{uvOf(uses[first], lo), uvOf(uses[first], hi), uvOf(uses[other], lo),
                                         uvOf(uses[other], hi)};
      if (!seamsOnly || edge.a0 != edge.b0 || edge.a1 != edge.b1) atlas.sharedEdges.push_back(edge);
    }
  });
}

// Every edge use, sorted by key, then triangle, then edge: uses of one edge are adjacent.
inline std::vector<EdgeUse> sortedEdgeUses(const FrontMesh& mesh) {
  std::vector<EdgeUse> uses;
  uses.reserve(mesh.triangles.size() * 3);
  for (uint32_t t = 0; t < mesh.triangles.size(); ++t) {
    const FrontTriangle& triangle = mesh.triangles[t];
    for (uint32_t e = 0; e < 3; ++e) {
      uses.push_back({edgeKey(triangle.weld[e], triangle.weld[(e + 1) % 3]), t, e});
    }
  }
  std::sort(uses.begin(), uses.end(), [](const EdgeUse& a, const EdgeUse& b) {
    if (a.key != b.key) return a.key < b.key;
    if (a.triangle != b.triangle) return a.triangle < b.triangle;
    return a.edge < b.edge;
  });
  return uses;
}

inline float frontIor(const Scene& scene, const Surface& surface) {
  return scene.media[surface.innerMedium].ior / scene.media[surface.outerMedium].ior;
}

inline void appendVertex(FieldMesh& mesh, glm::vec3 position, glm::vec3 normal, glm::vec2 uv, float ior) {
  mesh.positions.insert(mesh.positions.end(), {position.x, position.y, position.z});
  mesh.normals.insert(mesh.normals.end(), {normal.x, normal.y, normal.z});
  mesh.uvs.insert(mesh.uvs.end(), {uv.x, uv.y});
  mesh.frontIor.push_back(ior);
}

// Orders each pair, drops self-pairs, sorts and removes duplicates.
inline void canonicalizePairs(std::vector<std::array<uint32_t, 2>>& pairs) {
  std::vector<std::array<uint32_t, 2>> out;
  out.reserve(pairs.size());
  for (const auto& p : pairs) {
    if (p[0] != p[1]) {
      out.push_back({std::min(p[0], p[1]), std::max(p[0], p[1])});
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  pairs = std::move(out);
}

}  // namespace shrefract::bake::layout_detail
