// A Volume field's grid words (field.h FieldVolume): packing a voxel, its normal, the bricks, and
// whether a mesh bounds one convex body. What reading a field needs; the
// trace through the grid is the CPU mirror's (engine/reference, volume_trace.cpp).
#include <shrefract/field.h>
#include <shrefract/gpu_layout.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "field/unit_or_z.h"

#include <algorithm>
#include <cmath>

namespace shrefract {

static_assert(kVolumeBandVoxels == gpu::kVolumeBandVoxels, "field.h and gpu_layout.h must agree on the band");
static_assert(kVolumeBrickSide == gpu::kVolumeBrickSide && kVolumeBrickWords == gpu::kVolumeBrickWords &&
                  kVolumeBrickInside == gpu::kVolumeBrickInside && kVolumeBrickOutside == gpu::kVolumeBrickOutside,
              "field.h and gpu_layout.h must agree on the bricks");
static_assert(gpu::kVolumeDistanceZero == 127u && gpu::kVolumeNormalZero == 2047u && gpu::kVolumeNormalShiftX == 8u &&
                  gpu::kVolumeNormalShiftY == 20u,
              "volumeFarWord's levels");

namespace {

using V3 = glm::vec3;
using glm::dot;


}  // namespace

uint32_t packVolumeVoxel(float distanceVoxels, const std::array<float, 3>& normal) {
  const float d = std::clamp(distanceVoxels, -kVolumeBandVoxels, kVolumeBandVoxels);
  float x = normal[0], y = normal[1], z = normal[2];
  const float l1 = std::fabs(x) + std::fabs(y) + std::fabs(z);
  float px = l1 > 0.0f ? x / l1 : 0.0f, py = l1 > 0.0f ? y / l1 : 0.0f;
  if (l1 > 0.0f && z < 0.0f) {  // the lower half folded over the diagonals
    const float fx = (1.0f - std::fabs(py)) * (px >= 0.0f ? 1.0f : -1.0f);
    const float fy = (1.0f - std::fabs(px)) * (py >= 0.0f ? 1.0f : -1.0f);
    px = fx;
    py = fy;
  }
  // Odd level counts (2 zero + 1), so that 0 and the band's ends, and 0 and +-1 of a normal's
  // coordinates (the axes: a box's faces), are levels exactly.
  const float zero = float(gpu::kVolumeDistanceZero), nzero = float(gpu::kVolumeNormalZero);
  const uint32_t q = uint32_t(std::lround(d / kVolumeBandVoxels * zero + zero));
  auto level = [&](float p) { return uint32_t(std::lround(std::clamp(p * nzero + nzero, 0.0f, 2.0f * nzero))); };
  return q | (level(px) << gpu::kVolumeNormalShiftX) | (level(py) << gpu::kVolumeNormalShiftY);
}

namespace {

// The unit normal of octahedral coordinates (px, py), each in [-1, 1].
V3 unfoldOctahedral(float px, float py) {
  V3 n{px, py, 1.0f - std::fabs(px) - std::fabs(py)};
  if (n.z < 0.0f) {
    const float x = n.x;
    n.x = (1.0f - std::fabs(n.y)) * (x >= 0.0f ? 1.0f : -1.0f);
    n.y = (1.0f - std::fabs(x)) * (n.y >= 0.0f ? 1.0f : -1.0f);
  }
  return unitOrZ(n);
}

}  // namespace

std::array<float, 3> unpackVolumeNormal(uint32_t word) {
  const float nzero = float(gpu::kVolumeNormalZero);
  const float px = std::min((float((word >> gpu::kVolumeNormalShiftX) & gpu::kVolumeNormalMask) - nzero) / nzero, 1.0f);
  const float py = std::min((float((word >> gpu::kVolumeNormalShiftY) & gpu::kVolumeNormalMask) - nzero) / nzero, 1.0f);
  const V3 n = unfoldOctahedral(px, py);
  return {n.x, n.y, n.z};
}

void setVolumeVoxels(FieldVolume& v, const std::vector<uint32_t>& dense) {
  const uint32_t n = v.size, per = volumeBricksPerSide(n), s = kVolumeBrickSide;
  v.bricks.assign(size_t(per) * per * per, 0u);
  v.brickVoxels.clear();
  std::vector<uint32_t> words(kVolumeBrickWords);
  for (uint32_t c = 0; c < per; ++c)
    for (uint32_t b = 0; b < per; ++b)
      for (uint32_t a = 0; a < per; ++a) {
        // Voxels beyond the grid (a partial brick's) read as the brick's first voxel, so they
        // neither keep a far brick from being an entry nor are ever read.
        const uint32_t first = dense[(size_t(c * s) * n + b * s) * n + a * s];
        for (uint32_t k = 0; k < kVolumeBrickWords; ++k) {
          const uint32_t x = a * s + k % s, y = b * s + (k / s) % s, z = c * s + k / (s * s);
          words[k] = x < n && y < n && z < n ? dense[(size_t(z) * n + y) * n + x] : first;
        }
        const bool uniform = std::all_of(words.begin(), words.end(), [&](uint32_t w) { return w == first; });
        uint32_t& entry = v.bricks[(size_t(c) * per + b) * per + a];
        if (uniform && first == volumeFarWord(true)) entry = kVolumeBrickInside;
        else if (uniform && first == volumeFarWord(false)) entry = kVolumeBrickOutside;
        else {
          entry = uint32_t(v.brickVoxels.size() / kVolumeBrickWords);
          v.brickVoxels.insert(v.brickVoxels.end(), words.begin(), words.end());
        }
      }
  setVolumeFarReach(v);
}

// The cube of bricks around a far brick holds only far bricks of its side out to farReach - 1:
// eroded one brick at a time by its 26 neighbours (none beyond the grid), a brick's reach is the
// number of erosions it survives.
void setVolumeFarReach(FieldVolume& v) {
  const int per = int(volumeBricksPerSide(v.size));
  const auto at = [per](int a, int b, int c) { return (size_t(c) * per + b) * per + a; };
  v.farReach.resize(v.bricks.size());
  for (size_t i = 0; i < v.bricks.size(); ++i) v.farReach[i] = v.bricks[i] >= kVolumeBrickInside ? 1 : 0;
  std::vector<uint8_t> next = v.farReach;
  for (uint32_t reach = 1; reach < 255; ++reach) {
    bool grew = false;
    for (int c = 0; c < per; ++c)
      for (int b = 0; b < per; ++b)
        for (int a = 0; a < per; ++a) {
          const size_t i = at(a, b, c);
          if (v.farReach[i] != reach) continue;
          bool keeps = true;
          for (int k = 0; k < 27 && keeps; ++k) {
            const int x = a + k % 3 - 1, y = b + (k / 3) % 3 - 1, z = c + k / 9 - 1;
            keeps = x >= 0 && y >= 0 && z >= 0 && x < per && y < per && z < per &&
                    v.farReach[at(x, y, z)] >= reach && v.bricks[at(x, y, z)] == v.bricks[i];
          }
          if (keeps) next[i] = uint8_t(reach + 1);
          grew = grew || keeps;
        }
    v.farReach = next;
    if (!grew) break;
  }
}

bool meshIsConvex(const FieldMesh& mesh) {
  const size_t vertices = mesh.positions.size() / 3;
  if (vertices < 4 || mesh.indices.size() < 12 || mesh.normals.size() != mesh.positions.size()) return false;
  auto at = [&](const std::vector<float>& a, uint32_t i) { return V3{a[3 * i], a[3 * i + 1], a[3 * i + 2]}; };
  V3 lo = at(mesh.positions, 0), hi = lo;
  for (size_t i = 1; i < vertices; ++i) {
    lo = glm::min(lo, at(mesh.positions, uint32_t(i)));
    hi = glm::max(hi, at(mesh.positions, uint32_t(i)));
  }
  const float tolerance = 1e-5f * glm::length(hi - lo);
  uint64_t pairs = 0;
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const uint32_t a = mesh.indices[t], b = mesh.indices[t + 1], c = mesh.indices[t + 2];
    const V3 pa = at(mesh.positions, a);
    V3 n = glm::cross(at(mesh.positions, b) - pa, at(mesh.positions, c) - pa);
    const float len = glm::length(n);
    if (!(len > 0.0f)) continue;  // a degenerate triangle has no plane
    n = (1.0f / len) * n;
    // The winding may be either way: the plane faces where the triangle's vertex normals point.
    if (dot(n, at(mesh.normals, a) + at(mesh.normals, b) + at(mesh.normals, c)) < 0.0f) n = -1.0f * n;
    const float offset = dot(n, pa);
    pairs += vertices;
    if (pairs > kConvexTestPairs) return false;
    for (size_t i = 0; i < vertices; ++i)
      if (dot(n, at(mesh.positions, uint32_t(i))) - offset > tolerance) return false;
  }
  return true;
}

}  // namespace shrefract
