// glTF import: mesh repair (weld, degenerate, duplicated and internal-wall triangles), closure
// checks, outward orientation and normals of each volume (docs/scenes.md, "Repairs").
#include "import/gltf_importer.h"

namespace shrefract::bake::gltf_detail {
namespace {

glm::dvec3 boundsDiagonal(const std::vector<glm::vec3>& positions) {
  glm::dvec3 lo(positions.front()), hi(positions.front());
  for (const glm::vec3& p : positions) {
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  return hi - lo;
}

// Welds positions closer than `tolerance` (a spatial hash with cells of the tolerance; the first
// vertex of a cluster is kept): every vertex gets its representative's id and position. Vertices
// stay separate (their normals and uvs may differ), only positions are shared, as closure needs.
std::vector<uint32_t> weldPositions(std::vector<glm::vec3>& positions, double tolerance, size_t& moved) {
  std::vector<uint32_t> representative(positions.size());
  std::map<std::array<int64_t, 3>, std::vector<uint32_t>> cells;
  const double cell = tolerance > 0.0 ? tolerance : 1.0;
  auto cellOf = [cell](const glm::vec3& p) {
    // Clamped: a far-away vertex of a tiny mesh must not overflow the cell index.
    const glm::dvec3 c = glm::clamp(glm::floor(glm::dvec3(p) / cell), -4e18, 4e18);
    return std::array<int64_t, 3>{static_cast<int64_t>(c.x), static_cast<int64_t>(c.y), static_cast<int64_t>(c.z)};
  };
  auto find = [&](const glm::vec3& p) -> std::optional<uint32_t> {
    const auto c = cellOf(p);
    for (int64_t dx = -1; dx <= 1; ++dx)
      for (int64_t dy = -1; dy <= 1; ++dy)
        for (int64_t dz = -1; dz <= 1; ++dz) {
          const auto it = cells.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == cells.end()) continue;
          for (uint32_t r : it->second)
            if (glm::length(glm::dvec3(positions[r]) - glm::dvec3(p)) <= tolerance) return r;
        }
    return std::nullopt;
  };
  moved = 0;
  for (uint32_t i = 0; i < positions.size(); ++i) {
    const auto r = find(positions[i]);
    if (!r) {
      representative[i] = i;
      cells[cellOf(positions[i])].push_back(i);
      continue;
    }
    representative[i] = *r;
    if (positions[i] != positions[*r]) ++moved;
    positions[i] = positions[*r];
  }
  return representative;
}

// The corners of a triangle as welded ids, rotated so the smallest comes first (winding kept).
std::array<uint32_t, 3> canonical(uint32_t a, uint32_t b, uint32_t c) {
  if (b < a && b < c) return {b, c, a};
  if (c < a && c < b) return {c, a, b};
  return {a, b, c};
}

// Meshes as exporters write them: welds positions within the tolerance, drops triangles whose
// corners coincide once welded (counted in volume.degenerate), keeps one of every set of
// duplicated triangles, and drops both triangles of a pair with the same corners and opposite
// windings (an internal wall between two parts of one volume, e.g. two boxes joined face to face).
Repairs repairVolume(Volume& volume) {
  Repairs repairs;
  if (volume.positions.empty()) return repairs;
  repairs.tolerance = kWeldTolerance * glm::length(boundsDiagonal(volume.positions));
  const std::vector<uint32_t> id = weldPositions(volume.positions, repairs.tolerance, repairs.welded);
  std::map<std::array<uint32_t, 3>, size_t> kept;  // canonical corners -> triangle in `out`
  std::vector<std::array<uint32_t, 3>> out;
  std::vector<uint8_t> dropped;
  for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
    const uint32_t a = volume.indices[t], b = volume.indices[t + 1], c = volume.indices[t + 2];
    if (id[a] == id[b] || id[b] == id[c] || id[c] == id[a]) {
      ++volume.degenerate;
      continue;
    }
    const auto key = canonical(id[a], id[b], id[c]);
    if (kept.count(key) != 0) {
      ++repairs.duplicated;
      continue;
    }
    if (auto opposite = kept.find(canonical(id[a], id[c], id[b])); opposite != kept.end()) {
      dropped[opposite->second] = 1;
      kept.erase(opposite);
      repairs.internal += 2;
      continue;
    }
    kept.emplace(key, out.size());
    out.push_back({a, b, c});
    dropped.push_back(0);
  }
  volume.indices.clear();
  for (size_t t = 0; t < out.size(); ++t)
    if (dropped[t] == 0) volume.indices.insert(volume.indices.end(), out[t].begin(), out[t].end());
  return repairs;
}

double totalArea(const Volume& volume) {
  const size_t triangleCount = volume.indices.size() / 3;
  double area = 0.0;
  for (size_t t = 0; t < triangleCount; ++t) {
    const glm::dvec3 a(volume.positions[volume.indices[3 * t]]);
    const glm::dvec3 b(volume.positions[volume.indices[3 * t + 1]]);
    const glm::dvec3 c(volume.positions[volume.indices[3 * t + 2]]);
    area += glm::length(glm::cross(b - a, c - a));
  }
  return area;
}

// Keep only the vertices that triangles use, in the order they are first used.
void compactVertices(Volume& volume) {
  std::vector<uint32_t> remap(volume.positions.size(), std::numeric_limits<uint32_t>::max());
  Volume compact;
  for (uint32_t& index : volume.indices) {
    if (remap[index] == std::numeric_limits<uint32_t>::max()) {
      remap[index] = static_cast<uint32_t>(compact.positions.size());
      compact.positions.push_back(volume.positions[index]);
      compact.normals.push_back(volume.normals[index]);
      compact.normalFromFile.push_back(volume.normalFromFile[index]);
      compact.uvs.push_back(volume.uvs[index]);
    }
    index = remap[index];
  }
  volume.positions = std::move(compact.positions);
  volume.normals = std::move(compact.normals);
  volume.normalFromFile = std::move(compact.normalFromFile);
  volume.uvs = std::move(compact.uvs);
}

// Signed volume (divergence theorem): positive when the winding is outward.
double enclosedVolume(const Volume& volume) {
  double sum = 0.0;
  for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
    sum += glm::dot(glm::dvec3(volume.positions[volume.indices[t]]),
                    glm::cross(glm::dvec3(volume.positions[volume.indices[t + 1]]),
                               glm::dvec3(volume.positions[volume.indices[t + 2]])));
  }
  return sum / 6.0;
}

// Per vertex, the sum of its triangles' area-weighted face normals; `agreement`, the sum over
// corners with a normal from the file of that normal's dot product with its face's.
std::vector<glm::dvec3> accumulateFaceNormals(const Volume& volume, double& agreement) {
  std::vector<glm::dvec3> accumulated(volume.positions.size(), glm::dvec3(0.0));
  agreement = 0.0;
  for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
    const uint32_t ia = volume.indices[t];
    const uint32_t ib = volume.indices[t + 1];
    const uint32_t ic = volume.indices[t + 2];
    const glm::dvec3 a(volume.positions[ia]);
    const glm::dvec3 b(volume.positions[ib]);
    const glm::dvec3 c(volume.positions[ic]);
    const glm::dvec3 face = glm::cross(b - a, c - a);  // length = twice the area
    for (uint32_t i : {ia, ib, ic}) {
      accumulated[i] += face;
      if (volume.normalFromFile[i] != 0) {
        agreement += glm::dot(face, glm::dvec3(volume.normals[i]));
      }
    }
  }
  return accumulated;
}

}  // namespace

void Importer::reportRepairs(const Volume& volume, const Repairs& repairs) {
  char tolerance[32];
  std::snprintf(tolerance, sizeof tolerance, "%.3g", repairs.tolerance);
  if (repairs.welded > 0) {
    warn(volume.label + ": welded " + std::to_string(repairs.welded) + " vertex(es) onto another within " +
         tolerance);
  }
  if (volume.degenerate > 0) {
    warn(volume.label + ": dropped " + std::to_string(volume.degenerate) +
         " degenerate triangle(s) (two corners at one position)");
  }
  if (repairs.duplicated > 0) {
    warn(volume.label + ": dropped " + std::to_string(repairs.duplicated) + " duplicated triangle(s)");
  }
  if (repairs.internal > 0) {
    warn(volume.label + ": dropped " + std::to_string(repairs.internal) +
         " triangle(s) in coincident pairs of opposite winding (internal walls)");
  }
}

Result<void> Importer::finalize(Volume& volume) {
  reportRepairs(volume, repairVolume(volume));
  if (!(totalArea(volume) > 0.0)) {
    return fail(ErrorCode::InvalidArgument,
                volume.label + " has zero area (" +
                    std::to_string(volume.indices.size() / 3 + volume.degenerate) +
                    " triangles, all degenerate)");
  }
  compactVertices(volume);
  if (auto closed = checkClosed(volume); !closed) {
    return closed.error();
  }
  orientOutward(volume);
  settleNormals(volume);

  if (!volume.anyUvs) {
    volume.uvs.clear();
  } else if (volume.missingUvs) {
    warn(volume.label + ": some primitives have no TEXCOORD_0; their uvs are (0, 0)");
  }

  volume.boundsMin = glm::dvec3(volume.positions.front());
  volume.boundsMax = volume.boundsMin;
  for (const glm::vec3& p : volume.positions) {
    volume.boundsMin = glm::min(volume.boundsMin, glm::dvec3(p));
    volume.boundsMax = glm::max(volume.boundsMax, glm::dvec3(p));
  }
  return {};
}

// Topology, with the winding as read (after mirroring): an open volume fails unless allowed.
Result<void> Importer::checkClosed(Volume& volume) {
  Surface probe;
  probe.positions = volume.positions;
  probe.indices = volume.indices;
  const TopologyReport topology = checkSurface(probe);
  volume.closed = topology.closed();
  if (!volume.closed) {
    const std::string problem =
        volume.label + " is not a closed, consistently wound volume: " +
        std::to_string(topology.openEdges) + " open, " +
        std::to_string(topology.inconsistentEdges) + " inconsistently wound and " +
        std::to_string(topology.nonManifoldEdges) + " non-manifold edge(s)";
    if (!options_.allowOpenMeshes) {
      return fail(ErrorCode::InvalidArgument,
                  problem + " after the repairs (allowOpenMeshes, the tool's --allow-open, accepts it)");
    }
    warn(problem + "; kept as is");
  }
  return {};
}

// A closed volume that is inside out is turned outward.
void Importer::orientOutward(Volume& volume) {
  volume.volume = enclosedVolume(volume);
  if (volume.closed && volume.volume < 0.0) {
    for (size_t t = 0; t + 2 < volume.indices.size(); t += 3) {
      std::swap(volume.indices[t + 1], volume.indices[t + 2]);
    }
    volume.volume = -volume.volume;
    warn(volume.label + " is wound inside out (clockwise seen from outside); winding reversed");
  }
}

// Area-weighted face normals: computed normals for vertices without a usable one, and the
// check that the file's normals agree with the (now outward) winding.
void Importer::settleNormals(Volume& volume) {
  double agreement = 0.0;
  const std::vector<glm::dvec3> accumulated = accumulateFaceNormals(volume, agreement);
  if (agreement < 0.0) {
    for (size_t i = 0; i < volume.normals.size(); ++i) {
      if (volume.normalFromFile[i] != 0) {
        volume.normals[i] = -volume.normals[i];
      }
    }
    warn(volume.label + ": its normals point against its winding; normals reversed");
  }
  size_t fallback = 0;
  for (size_t i = 0; i < volume.normals.size(); ++i) {
    if (volume.normalFromFile[i] != 0) {
      continue;
    }
    ++volume.computedNormals;
    const double length = glm::length(accumulated[i]);
    if (length > 0.0) {
      volume.normals[i] = glm::vec3(accumulated[i] / length);
    } else {
      volume.normals[i] = glm::vec3(0.0f, 0.0f, 1.0f);  // only on zero-area triangles
      ++fallback;
    }
  }
  if (volume.computedNormals > 0) {
    warn(volume.label + ": no usable NORMAL for " + std::to_string(volume.computedNormals) +
         " vertex(es); area-weighted smooth normals computed" +
         (fallback > 0 ? " (" + std::to_string(fallback) + " on zero-area triangles only)"
                       : std::string()));
  }
}

}  // namespace shrefract::bake::gltf_detail
