// Scene validation and topology checks (welded by exact position).
#include <shrefract/assets/scene.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

namespace shrefract::bake {
namespace {

// Tolerance on |normal| - 1: normals are stored as float and come from files (glTF stores them
// as float too); 1e-3 admits quantized or renormalized data and rejects unnormalized normals.
constexpr float kUnitNormalTolerance = 1e-3f;

bool isFinite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool isFinite(glm::vec2 v) { return std::isfinite(v.x) && std::isfinite(v.y); }

std::string describe(const Surface& surface, size_t index) {
  return "surface " + std::to_string(index) + " ('" + surface.name + "')";
}

// A triangle as three corner positions, already oriented.
using Triangle = std::array<glm::vec3, 3>;

struct PositionKey {
  uint32_t x, y, z;
  bool operator==(const PositionKey&) const = default;
};

struct PositionKeyHash {
  size_t operator()(const PositionKey& k) const {
    uint64_t h = k.x;
    h = h * 0x9E3779B97F4A7C15ull ^ k.y;
    h = h * 0x9E3779B97F4A7C15ull ^ k.z;
    return static_cast<size_t>(h ^ (h >> 29));
  }
};

PositionKey keyOf(glm::vec3 p) {
  // Adding +0 turns -0 into +0, so positions that compare equal weld together.
  return PositionKey{std::bit_cast<uint32_t>(p.x + 0.0f), std::bit_cast<uint32_t>(p.y + 0.0f),
                     std::bit_cast<uint32_t>(p.z + 0.0f)};
}

TopologyReport analyze(const std::vector<Triangle>& triangles) {
  TopologyReport report;
  report.triangles = triangles.size();

  std::unordered_map<PositionKey, uint32_t, PositionKeyHash> weld;
  auto weldedIndex = [&weld](glm::vec3 p) {
    auto [it, inserted] = weld.try_emplace(keyOf(p), static_cast<uint32_t>(weld.size()));
    return it->second;
  };

  // Per undirected edge (lo, hi): how often it is used lo->hi and hi->lo.
  struct EdgeUse {
    uint32_t forward = 0;
    uint32_t backward = 0;
  };
  std::unordered_map<uint64_t, EdgeUse> edges;
  edges.reserve(triangles.size() * 2);

  for (const Triangle& t : triangles) {
    const std::array<uint32_t, 3> v{weldedIndex(t[0]), weldedIndex(t[1]), weldedIndex(t[2])};
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) {
      ++report.degenerateTriangles;
      continue;
    }
    const glm::dvec3 a(t[0]), b(t[1]), c(t[2]);
    if (glm::dot(glm::cross(b - a, c - a), glm::cross(b - a, c - a)) == 0.0) {
      ++report.degenerateTriangles;  // collinear: still counted in the edge structure
    }
    for (int e = 0; e < 3; ++e) {
      const uint32_t from = v[static_cast<size_t>(e)];
      const uint32_t to = v[static_cast<size_t>((e + 1) % 3)];
      const uint32_t lo = from < to ? from : to;
      const uint32_t hi = from < to ? to : from;
      EdgeUse& use = edges[(static_cast<uint64_t>(lo) << 32) | hi];
      if (from == lo) {
        ++use.forward;
      } else {
        ++use.backward;
      }
    }
  }

  for (const auto& [key, use] : edges) {
    const uint32_t total = use.forward + use.backward;
    if (total > 2) {
      ++report.nonManifoldEdges;
    } else if (total == 1) {
      ++report.openEdges;
    } else if (use.forward != 1) {  // total == 2, both in the same direction
      ++report.inconsistentEdges;
    }
  }
  return report;
}

// Every triangle bounding `medium`, oriented with its normal pointing away from the medium.
std::vector<Triangle> mediumBoundary(const Scene& scene, uint32_t medium) {
  std::vector<Triangle> triangles;
  for (const Surface& surface : scene.surfaces) {
    const bool inner = surface.innerMedium == medium;
    const bool outer = surface.outerMedium == medium;
    if (inner == outer) {
      continue;  // not adjacent (or invalid inner == outer, rejected by validateScene)
    }
    for (size_t i = 0; i + 2 < surface.indices.size(); i += 3) {
      const glm::vec3 a = surface.positions[surface.indices[i]];
      const glm::vec3 b = surface.positions[surface.indices[i + 1]];
      const glm::vec3 c = surface.positions[surface.indices[i + 2]];
      // Surface normals point toward the outer medium, i.e. away from the inner one.
      triangles.push_back(inner ? Triangle{a, b, c} : Triangle{a, c, b});
    }
  }
  return triangles;
}

}  // namespace

bool TopologyReport::closed() const {
  return triangles > 0 && openEdges == 0 && inconsistentEdges == 0 && nonManifoldEdges == 0;
}

Bounds bounds(const Scene& scene) {
  Bounds b;
  bool any = false;
  for (const Surface& surface : scene.surfaces) {
    for (const glm::vec3& p : surface.positions) {
      if (!any) {
        b.min = b.max = p;
        any = true;
      } else {
        b.min = glm::min(b.min, p);
        b.max = glm::max(b.max, p);
      }
    }
  }
  return b;
}

namespace {

// `what` names the medium or surface in the message.
Result<void> validateMedium(const Medium& medium, const std::string& what) {
  if (!std::isfinite(medium.ior) || medium.ior <= 0.0f) {
    return makeError(ErrorCode::InvalidArgument, what + "has ior " + std::to_string(medium.ior));
  }
  if (!std::isfinite(medium.absorption) || medium.absorption < 0.0f) {
    return makeError(ErrorCode::InvalidArgument,
                     what + "has absorption " + std::to_string(medium.absorption));
  }
  if (!isFinite(medium.color) || medium.color.x < 0.0f || medium.color.y < 0.0f ||
      medium.color.z < 0.0f) {
    return makeError(ErrorCode::InvalidArgument, what + "has a negative or non-finite colour");
  }
  return {};
}

// The surface's array sizes and media, before any element is read.
Result<void> validateSurfaceShape(const Surface& surface, size_t mediaCount, const std::string& what) {
  if (surface.indices.empty() || surface.indices.size() % 3 != 0) {
    return makeError(ErrorCode::InvalidArgument,
                     what + "has " + std::to_string(surface.indices.size()) +
                         " indices (need a non-empty multiple of 3)");
  }
  if (surface.normals.size() != surface.positions.size()) {
    return makeError(ErrorCode::InvalidArgument,
                     what + "has " + std::to_string(surface.normals.size()) + " normals for " +
                         std::to_string(surface.positions.size()) + " positions");
  }
  if (!surface.uvs.empty() && surface.uvs.size() != surface.positions.size()) {
    return makeError(ErrorCode::InvalidArgument,
                     what + "has " + std::to_string(surface.uvs.size()) + " uvs for " +
                         std::to_string(surface.positions.size()) + " positions");
  }
  if (surface.innerMedium >= mediaCount || surface.outerMedium >= mediaCount) {
    return makeError(ErrorCode::InvalidArgument,
                     what + "refers to medium " +
                         std::to_string(std::max(surface.innerMedium, surface.outerMedium)) +
                         " of " + std::to_string(mediaCount));
  }
  if (surface.innerMedium == surface.outerMedium) {
    return makeError(ErrorCode::InvalidArgument,
                     what + "has the same medium on both sides (" +
                         std::to_string(surface.innerMedium) + ")");
  }
  return {};
}

// Indices in range; positions, unit normals and uvs finite.
Result<void> validateSurfaceData(const Surface& surface, const std::string& what) {
  for (size_t i = 0; i < surface.indices.size(); ++i) {
    if (surface.indices[i] >= surface.positions.size()) {
      return makeError(ErrorCode::InvalidArgument,
                       what + "index " + std::to_string(i) + " is " +
                           std::to_string(surface.indices[i]) + ", out of range (" +
                           std::to_string(surface.positions.size()) + " vertices)");
    }
  }
  for (size_t v = 0; v < surface.positions.size(); ++v) {
    if (!isFinite(surface.positions[v])) {
      return makeError(ErrorCode::InvalidArgument,
                       what + "vertex " + std::to_string(v) + " has a non-finite position");
    }
    const glm::vec3 n = surface.normals[v];
    if (!isFinite(n) || std::fabs(glm::length(n) - 1.0f) > kUnitNormalTolerance) {
      return makeError(ErrorCode::InvalidArgument,
                       what + "vertex " + std::to_string(v) + " has a normal that is not unit");
    }
    if (!surface.uvs.empty() && !isFinite(surface.uvs[v])) {
      return makeError(ErrorCode::InvalidArgument,
                       what + "vertex " + std::to_string(v) + " has a non-finite uv");
    }
  }
  return {};
}

}  // namespace

Result<void> validateScene(const Scene& scene) {
  const std::string where = "scene '" + scene.name + "': ";
  if (scene.media.empty()) {
    return makeError(ErrorCode::InvalidArgument, where + "no media");
  }
  if (scene.surfaces.empty()) {
    return makeError(ErrorCode::InvalidArgument, where + "no surfaces");
  }
  for (size_t m = 0; m < scene.media.size(); ++m) {
    const Medium& medium = scene.media[m];
    if (auto r = validateMedium(medium, where + "medium " + std::to_string(m) + " ('" + medium.name + "') "); !r) {
      return r;
    }
  }
  for (size_t s = 0; s < scene.surfaces.size(); ++s) {
    const Surface& surface = scene.surfaces[s];
    const std::string what = where + describe(surface, s) + " ";
    if (auto r = validateSurfaceShape(surface, scene.media.size(), what); !r) {
      return r;
    }
    if (auto r = validateSurfaceData(surface, what); !r) {
      return r;
    }
  }
  return {};
}

TopologyReport checkSurface(const Surface& surface) {
  std::vector<Triangle> triangles;
  triangles.reserve(surface.indices.size() / 3);
  for (size_t i = 0; i + 2 < surface.indices.size(); i += 3) {
    triangles.push_back(Triangle{surface.positions[surface.indices[i]],
                                 surface.positions[surface.indices[i + 1]],
                                 surface.positions[surface.indices[i + 2]]});
  }
  return analyze(triangles);
}

TopologyReport checkMediumClosure(const Scene& scene, uint32_t medium) {
  return analyze(mediumBoundary(scene, medium));
}

double signedVolume(const Scene& scene, uint32_t medium) {
  double volume = 0.0;
  for (const Triangle& t : mediumBoundary(scene, medium)) {
    volume += glm::dot(glm::dvec3(t[0]), glm::cross(glm::dvec3(t[1]), glm::dvec3(t[2])));
  }
  return volume / 6.0;
}

}  // namespace shrefract::bake
