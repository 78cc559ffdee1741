// glTF import: which volume contains which (parity rays), overlaps, and the medium stack that
// gives every surface its inner and outer media.
#include "import/gltf_importer.h"

namespace shrefract::bake::gltf_detail {
namespace {

// Möller-Trumbore; returns the ray parameter of the hit, or a negative value for none. Hits on
// edges count (both triangles sharing an edge may report it; the parity test votes over rays).
double intersect(const glm::dvec3& origin, const glm::dvec3& direction, const glm::dvec3& a,
                 const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 e1 = b - a;
  const glm::dvec3 e2 = c - a;
  const glm::dvec3 p = glm::cross(direction, e2);
  const double det = glm::dot(e1, p);
  if (det == 0.0) {
    return -1.0;
  }
  const double inv = 1.0 / det;
  const glm::dvec3 s = origin - a;
  const double u = glm::dot(s, p) * inv;
  if (u < 0.0 || u > 1.0) {
    return -1.0;
  }
  const glm::dvec3 q = glm::cross(s, e1);
  const double v = glm::dot(direction, q) * inv;
  if (v < 0.0 || u + v > 1.0) {
    return -1.0;
  }
  return glm::dot(e2, q) * inv;
}

}  // namespace

// A point inside `volume`: halfway between its largest triangle and the opposite wall, found by a
// ray from that triangle's centroid against the inward normal.
glm::dvec3 Importer::interiorPoint(const Volume& volume) const {
  size_t best = 0;
  double bestArea = -1.0;
  for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
    const glm::dvec3 a(volume.positions[volume.indices[t]]);
    const glm::dvec3 b(volume.positions[volume.indices[t + 1]]);
    const glm::dvec3 c(volume.positions[volume.indices[t + 2]]);
    const double area = glm::length(glm::cross(b - a, c - a));
    if (area > bestArea) {
      bestArea = area;
      best = t;
    }
  }
  const glm::dvec3 a(volume.positions[volume.indices[best]]);
  const glm::dvec3 b(volume.positions[volume.indices[best + 1]]);
  const glm::dvec3 c(volume.positions[volume.indices[best + 2]]);
  const glm::dvec3 centroid = (a + b + c) / 3.0;
  const glm::dvec3 inward = -glm::normalize(glm::cross(b - a, c - a));
  double nearest = std::numeric_limits<double>::infinity();
  for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
    if (t == best) {
      continue;
    }
    const double hit = intersect(centroid, inward, glm::dvec3(volume.positions[volume.indices[t]]),
                                 glm::dvec3(volume.positions[volume.indices[t + 1]]),
                                 glm::dvec3(volume.positions[volume.indices[t + 2]]));
    if (hit > 0.0 && hit < nearest) {
      nearest = hit;
    }
  }
  if (!std::isfinite(nearest)) {
    nearest = 2.0 * kInteriorOffset * glm::length(volume.boundsMax - volume.boundsMin);
  }
  return centroid + inward * (0.5 * nearest);
}

// Ray parity against a closed volume, majority over three directions.
bool Importer::contains(const Volume& container, const glm::dvec3& point) const {
  if (glm::any(glm::lessThan(point, container.boundsMin)) ||
      glm::any(glm::greaterThan(point, container.boundsMax))) {
    return false;
  }
  int votes = 0;
  for (const glm::dvec3& direction : kParityDirections) {
    size_t crossings = 0;
    for (size_t t = 0; t + 2 < container.indices.size(); t += 3) {
      const double hit =
          intersect(point, direction, glm::dvec3(container.positions[container.indices[t]]),
                    glm::dvec3(container.positions[container.indices[t + 1]]),
                    glm::dvec3(container.positions[container.indices[t + 2]]));
      if (hit > 0.0) {
        ++crossings;
      }
    }
    votes += static_cast<int>(crossings % 2);
  }
  return votes >= 2;
}

// How many of up to kOverlapProbes vertices of `probed` (each pulled slightly toward its centre)
// lie inside the closed volume `container`.
std::pair<size_t, size_t> Importer::probesInside(const Volume& probed, const Volume& container) const {
  const size_t n = probed.positions.size();
  const size_t step = std::max<size_t>(1, (n + kOverlapProbes - 1) / kOverlapProbes);
  const glm::dvec3 centre = 0.5 * (probed.boundsMin + probed.boundsMax);
  const double inset = kOverlapInset * glm::length(probed.boundsMax - probed.boundsMin);
  size_t inside = 0;
  size_t tested = 0;
  for (size_t i = 0; i < n; i += step, ++tested) {
    const glm::dvec3 p(probed.positions[i]);
    const glm::dvec3 toCentre = centre - p;
    const double length = glm::length(toCentre);
    const glm::dvec3 probe = length > inset ? p + toCentre * (inset / length) : centre;
    inside += contains(container, probe) ? 1 : 0;
  }
  return {inside, tested};
}

// Pairs (u < v) of closed volumes that overlap (neither inside the other, nor apart), each named
// in a warning. Overlapping volumes are siblings: neither is the other's container, and the
// tracer takes each crossed surface's media as labelled (docs/scenes.md, "Overlapping volumes").
// Detected when a probe vertex of one lies inside the other; volumes that cross without a vertex
// inside the other (two long bars in a cross) are not detected.
std::set<std::pair<size_t, size_t>> Importer::findOverlaps() {
  std::set<std::pair<size_t, size_t>> overlaps;
  for (size_t u = 0; u < volumes_.size(); ++u) {
    for (size_t v = u + 1; v < volumes_.size(); ++v) {
      const Volume& a = volumes_[u];
      const Volume& b = volumes_[v];
      if (!a.closed || !b.closed || glm::any(glm::lessThan(a.boundsMax, b.boundsMin)) ||
          glm::any(glm::lessThan(b.boundsMax, a.boundsMin))) {
        continue;
      }
      const auto [aInB, aProbes] = probesInside(a, b);
      const auto [bInA, bProbes] = probesInside(b, a);
      const bool apart = aInB == 0 && bInA == 0;
      const bool aNested = aInB >= aProbes && bInA == 0;
      const bool bNested = bInA >= bProbes && aInB == 0;
      if (apart || aNested || bNested) {
        continue;
      }
      overlaps.emplace(u, v);
      warn(a.label + " and " + b.label +
           " overlap (neither contains the other); in the overlap a path is in the medium of the "
           "volume whose surface it crossed last (docs/scenes.md)");
    }
  }
  return overlaps;
}

Result<void> Importer::checkOverrides() const {
  if (options_.iorOverride &&
      (!std::isfinite(*options_.iorOverride) || *options_.iorOverride <= 0.0f)) {
    return fail(ErrorCode::InvalidArgument,
                "iorOverride " + std::to_string(*options_.iorOverride) + " is not finite and > 0");
  }
  if (options_.absorptionOverride &&
      (!std::isfinite(*options_.absorptionOverride) || *options_.absorptionOverride < 0.0f)) {
    return fail(ErrorCode::InvalidArgument, "absorptionOverride " +
                                                std::to_string(*options_.absorptionOverride) +
                                                " is not finite and >= 0");
  }
  return {};
}

// Walks the default scene into volumes_, each with its triangles.
Result<void> Importer::collectVolumes() {
  if (model_.scenes.empty()) {
    return fail(ErrorCode::InvalidArgument, "no scene: the file defines no scenes");
  }
  const int sceneIndex = model_.defaultScene >= 0 ? model_.defaultScene : 0;
  if (static_cast<size_t>(sceneIndex) >= model_.scenes.size()) {
    return fail(ErrorCode::CorruptData, "default scene " + std::to_string(sceneIndex) +
                                            " does not exist (" +
                                            std::to_string(model_.scenes.size()) + " scenes)");
  }
  std::vector<uint8_t> onPath(model_.nodes.size(), 0);
  for (int root : model_.scenes[static_cast<size_t>(sceneIndex)].nodes) {
    if (Result<void> visited = visitNode(root, glm::dmat4(1.0), onPath, 0); !visited) {
      return visited.error();
    }
  }
  // Volumes whose primitives were all empty carry no triangles and no dropped ones: skip them.
  std::erase_if(volumes_,
                [](const Volume& v) { return v.indices.empty() && v.degenerate == 0; });
  if (volumes_.empty()) {
    return fail(ErrorCode::InvalidArgument,
                "empty scene: scene " + std::to_string(sceneIndex) + " has no triangles");
  }
  return {};
}

// One medium per material used (in the order the volumes first use them), after air, with the
// overrides applied; each volume's medium set.
Result<void> Importer::assignMedia(Scene& scene) {
  std::map<int, uint32_t> mediumOfMaterial;
  for (Volume& volume : volumes_) {
    auto [it, inserted] =
        mediumOfMaterial.try_emplace(volume.material, static_cast<uint32_t>(scene.media.size()));
    if (inserted) {
      Result<Medium> medium = mediumOf(volume.material);
      if (!medium) {
        return medium.error();
      }
      scene.media.push_back(std::move(medium.value()));
    }
    volume.medium = it->second;
  }
  for (size_t m = 1; m < scene.media.size(); ++m) {
    if (options_.iorOverride) {
      scene.media[m].ior = *options_.iorOverride;
    }
    if (options_.absorptionOverride) {
      scene.media[m].absorption = *options_.absorptionOverride;
    }
  }
  return {};
}

// The medium stack: each volume's outside is the innermost other closed volume containing it.
// Returns volumes_.size() for a volume that none contains.
size_t Importer::innermostContainer(size_t v,
                                    const std::set<std::pair<size_t, size_t>>& overlaps) const {
  const glm::dvec3 point = interiorPoint(volumes_[v]);
  size_t container = volumes_.size();
  for (size_t u = 0; u < volumes_.size(); ++u) {
    const bool sibling = overlaps.count({std::min(u, v), std::max(u, v)}) != 0;
    if (u == v || sibling || !volumes_[u].closed || !contains(volumes_[u], point)) {
      continue;
    }
    if (container == volumes_.size() ||
        std::fabs(volumes_[u].volume) < std::fabs(volumes_[container].volume)) {
      container = u;
    }
  }
  return container;
}

// One Surface per volume, between its medium and its container's (air when none contains it).
Result<void> Importer::addSurfaces(Scene& scene,
                                   const std::set<std::pair<size_t, size_t>>& overlaps) {
  for (size_t v = 0; v < volumes_.size(); ++v) {
    const size_t container = innermostContainer(v, overlaps);
    Surface surface;
    surface.name = volumes_[v].name;
    surface.innerMedium = volumes_[v].medium;
    surface.outerMedium = container == volumes_.size() ? 0 : volumes_[container].medium;
    if (surface.outerMedium == surface.innerMedium) {
      return fail(ErrorCode::InvalidArgument,
                  volumes_[v].label + " lies inside " + volumes_[container].label +
                      ", which has the same medium ('" + scene.media[surface.innerMedium].name +
                      "'); nested volumes need different materials");
    }
    // Copies: later volumes still test containment against this one.
    surface.positions = volumes_[v].positions;
    surface.normals = volumes_[v].normals;
    surface.uvs = volumes_[v].uvs;
    surface.indices = volumes_[v].indices;
    report_.triangles += surface.indices.size() / 3;
    scene.surfaces.push_back(std::move(surface));
  }
  return {};
}

}  // namespace shrefract::bake::gltf_detail
