// Triangle edge records for polygon silhouette coverage (shrefract/object.h TriangleEdges): what
// the field's object pass reads per fragment and the CPU reference mirrors. No Vulkan calls (the
// fuzz targets link it with the CPU reference).
#include <shrefract/object.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/type_ptr.hpp>

namespace shrefract {

namespace {

// Scales v to unit length; false (v unchanged) where it has none or is not finite.
bool unit(glm::vec3& v) {
  const float n = glm::length(v);
  if (!(n > 0.0f) || !std::isfinite(n)) return false;
  v /= n;
  return true;
}

// Welded vertex ids: positions within kWeldTolerance of the mesh's extent (on every axis) share
// one, so that a seam whose two sides were computed apart (sin 2 pi is not 0) still joins.
constexpr float kWeldTolerance = 1e-5f;

std::vector<uint32_t> weld(const float* positions, uint32_t vertexCount) {
  float extent = 0.0f;
  for (uint32_t v = 1; v < vertexCount; ++v)
    for (uint32_t c = 0; c < 3; ++c) extent = std::max(extent, std::fabs(positions[3 * v + c] - positions[c]));
  const float tolerance = std::max(kWeldTolerance * extent, std::numeric_limits<float>::min());
  // Grid cells of the tolerance's size: a match lies in one of the 27 cells around a position.
  // A coordinate that is not finite, or too far for an int64 cell, goes to cell 0 (the reference
  // mirrors unvalidated meshes; such a vertex joins only what it equals within the tolerance).
  auto cellOf = [&](float x) {
    const double cell = std::floor(double(x) / double(tolerance));
    return std::fabs(cell) < 4e18 ? static_cast<int64_t>(cell) : int64_t{0};
  };
  std::map<std::array<int64_t, 3>, std::vector<uint32_t>> cells;  // cell -> representatives
  std::vector<uint32_t> out(vertexCount), representative;
  for (uint32_t v = 0; v < vertexCount; ++v) {
    const float* p = &positions[3 * v];
    const std::array<int64_t, 3> cell{cellOf(p[0]), cellOf(p[1]), cellOf(p[2])};
    uint32_t found = UINT32_MAX;
    for (int64_t dz = -1; dz <= 1 && found == UINT32_MAX; ++dz)
      for (int64_t dy = -1; dy <= 1 && found == UINT32_MAX; ++dy)
        for (int64_t dx = -1; dx <= 1 && found == UINT32_MAX; ++dx) {
          const auto it = cells.find({cell[0] + dx, cell[1] + dy, cell[2] + dz});
          if (it == cells.end()) continue;
          for (uint32_t id : it->second) {
            const float* q = &positions[3 * representative[id]];
            if (std::fabs(p[0] - q[0]) <= tolerance && std::fabs(p[1] - q[1]) <= tolerance &&
                std::fabs(p[2] - q[2]) <= tolerance) {
              found = id;
              break;
            }
          }
        }
    if (found == UINT32_MAX) {
      found = static_cast<uint32_t>(representative.size());
      representative.push_back(v);
      cells[cell].push_back(found);
    }
    out[v] = found;
  }
  return out;
}

glm::vec3 corner(const float* positions, uint32_t vertex) { return glm::make_vec3(&positions[3 * vertex]); }

}  // namespace

std::vector<TriangleEdges> triangleEdges(const float* positions, uint32_t vertexCount, const uint32_t* indices,
                                         uint32_t indexCount) {
  const uint32_t triangles = indexCount / 3;
  const std::vector<uint32_t> welded = weld(positions, vertexCount);
  // Directed welded edge (a, b) -> the first triangle that runs along it, and the unit normals.
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> edgeOwner;
  std::vector<glm::vec3> normals(triangles);
  std::vector<bool> valid(triangles);
  for (uint32_t t = 0; t < triangles; ++t) {
    const glm::vec3 p0 = corner(positions, indices[3 * t]), p1 = corner(positions, indices[3 * t + 1]),
                    p2 = corner(positions, indices[3 * t + 2]);
    normals[t] = glm::cross(p1 - p0, p2 - p0);
    valid[t] = unit(normals[t]);
    if (!valid[t]) continue;
    for (uint32_t k = 0; k < 3; ++k)
      edgeOwner.emplace(std::pair{welded[indices[3 * t + k]], welded[indices[3 * t + (k + 1) % 3]]}, t);
  }
  std::vector<TriangleEdges> out(triangles);
  for (uint32_t t = 0; t < triangles; ++t) {
    TriangleEdges& r = out[t];
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t ia = indices[3 * t + k], ib = indices[3 * t + (k + 1) % 3];
      if (!valid[t]) {
        r.neighbour[k] = {0.0f, 0.0f, 0.0f, -1.0f};
        continue;
      }
      const glm::vec3 a = corner(positions, ia), b = corner(positions, ib);
      glm::vec3 m = glm::cross(normals[t], b - a);
      if (!unit(m)) {
        r.neighbour[k] = {0.0f, 0.0f, 0.0f, -1.0f};
        continue;
      }
      r.edge[k] = {m.x, m.y, m.z, glm::dot(m, a)};
      const auto across = edgeOwner.find({welded[ib], welded[ia]});
      if (across == edgeOwner.end()) {
        r.neighbour[k] = {0.0f, 0.0f, 0.0f, 1.0f};
        continue;
      }
      const glm::vec3& n = normals[across->second];
      r.neighbour[k] = {n.x, n.y, n.z, glm::dot(n, a)};
    }
  }
  return out;
}

}  // namespace shrefract
