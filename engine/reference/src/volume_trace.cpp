// A Volume field's decode on the CPU (field_decode.h traceVolumeSample): each sample's path traced
// through the object's signed distance grid for the eye. decompress_volume.comp mirrors these operations
// (float, same order); the bake measures its volume with them and the CPU reference builds on them
// through evaluateSample.
#include <shrefract/cpu_reference.h>
#include <shrefract/field.h>
#include <shrefract/field_decode.h>
#include <shrefract/gpu_layout.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "field/unit_or_z.h"

#include <algorithm>
#include <cmath>

namespace shrefract {

namespace {

using V3 = glm::vec3;
using glm::dot;


// The 8 voxels around grid point g (voxel units, voxel centres at integers), clamped to the grid,
// and their trilinear weights. As the engine reads them (gpu_layout.h kVolumeApronWords): through
// the brick of the cell's first corner, whose far word stands for all 8 where that brick lies
// beyond the band.
struct Corners {
  uint32_t words[8];  // corner k is (x0, y0, z0) + (k & 1, (k >> 1) & 1, k >> 2)
  float weight[8];
  uint32_t brick[3];  // the brick read through, and its index among the bricks (for farSkip)
  size_t brickIndex;
};

Corners cornersAt(const FieldVolume& v, V3 g) {
  const uint32_t n = v.size;
  const float hi = float(n - 1);
  g = {std::clamp(g.x, 0.0f, hi), std::clamp(g.y, 0.0f, hi), std::clamp(g.z, 0.0f, hi)};
  const uint32_t x0 = std::min(uint32_t(g.x), n - 2), y0 = std::min(uint32_t(g.y), n - 2),
                 z0 = std::min(uint32_t(g.z), n - 2);
  const float fx = g.x - float(x0), fy = g.y - float(y0), fz = g.z - float(z0);
  Corners c{};
  const uint32_t per = volumeBricksPerSide(n), s = kVolumeBrickSide;
  c.brick[0] = x0 / s;
  c.brick[1] = y0 / s;
  c.brick[2] = z0 / s;
  c.brickIndex = (size_t(c.brick[2]) * per + c.brick[1]) * per + c.brick[0];
  const uint32_t entry = v.bricks[c.brickIndex];
  for (uint32_t k = 0; k < 8; ++k) {
    const uint32_t dx = k & 1u, dy = (k >> 1) & 1u, dz = (k >> 2) & 1u;
    c.weight[k] = (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy) * (dz ? fz : 1.0f - fz);
    c.words[k] = entry >= kVolumeBrickInside ? volumeFarWord(entry == kVolumeBrickInside)
                                             : volumeVoxel(v, x0 + dx, y0 + dy, z0 + dz);
  }
  return c;
}

float voxelDistance(uint32_t word) {
  return (float(word & gpu::kVolumeDistanceMask) - float(gpu::kVolumeDistanceZero)) * (kVolumeBandVoxels / float(gpu::kVolumeDistanceZero));
}

// The trilinear distance at g; `read` (optional) receives the corners it was read from.
float distanceAt(const FieldVolume& v, V3 g, Corners* read = nullptr) {
  const Corners c = cornersAt(v, g);
  if (read) *read = c;
  float d = 0.0f;
  for (uint32_t k = 0; k < 8; ++k) d += c.weight[k] * voxelDistance(c.words[k]);
  return d;
}

// The trilinear normal of the corners that face the way the nearest corner (the largest weight,
// the first of equals) faces: across an edge of the surface (a cube's) the voxels on either side
// hold the normals of different faces, whose blend would round the edge off.
V3 normalAt(const FieldVolume& v, V3 g) {
  const Corners c = cornersAt(v, g);
  V3 u[8];
  uint32_t nearest = 0;
  for (uint32_t k = 0; k < 8; ++k) {
    const std::array<float, 3> a = unpackVolumeNormal(c.words[k]);
    u[k] = {a[0], a[1], a[2]};
    if (c.weight[k] > c.weight[nearest]) nearest = k;
  }
  V3 n(0.0f);
  for (uint32_t k = 0; k < 8; ++k)
    if (dot(u[k], u[nearest]) >= gpu::kVolumeNormalBlendCos) n = n + c.weight[k] * u[k];
  return unitOrZ(n);
}

// How far along d from grid point g the cube of far bricks around g's brick (as distanceAt read
// it into `c`) reaches (FieldVolume::farReach): no interface lies inside it, so the march may
// cross it in one step. 0 in a stored brick or off the grid.
float farSkip(const FieldVolume& v, V3 g, V3 d, const Corners& c) {
  const uint32_t n = v.size, s = kVolumeBrickSide;
  const float hi = float(n - 1);
  const uint32_t reach = volumeFarReach(v, c.brickIndex);
  if (reach == 0 || std::min({g.x, g.y, g.z}) < 0.0f || std::max({g.x, g.y, g.z}) > hi) return 0.0f;
  const uint32_t bx = c.brick[0], by = c.brick[1], bz = c.brick[2];
  const V3 lo(float((bx + 1 - reach) * s), float((by + 1 - reach) * s), float((bz + 1 - reach) * s));
  const V3 up(float((bx + reach) * s), float((by + reach) * s), float((bz + reach) * s));
  float t = 4.0f * float(n);
  for (int k = 0; k < 3; ++k)
    if (d[k] != 0.0f) t = std::min(t, ((d[k] > 0.0f ? up[k] : lo[k]) - g[k]) / d[k]);
  return t;
}

// The distance along d (unit) from g to where the grid's distance changes sign: turns positive
// inside the medium, negative `outside` it (a path re-entering the object: the torus's hole):
// marched by 0.9 of the distance, at
// least kVolumeMinStep, then bisected. Negative when the march leaves the grid (or runs
// kVolumeMaxSteps) without crossing; outside, the march stops as soon as it leaves the grid's box,
// which a straight ray does not enter again. The march must have seen its own side before a
// crossing counts, so that the interpolation's slack around the start point is not taken for the
// next interface. (Outside, the distance is negated: exactly, so the inside march is unchanged.)
float crossing(const FieldVolume& v, V3 g, V3 d, bool outside, uint32_t& steps) {
  const float m = outside ? -1.0f : 1.0f;
  const float limit = 2.0f * float(v.size), hi = float(v.size - 1);
  float t = gpu::kVolumeStartStep, previous = 0.0f, before = 0.0f;
  bool seen = false;
  for (uint32_t step = 0; step < gpu::kVolumeMaxSteps && t < limit; ++step) {
    const V3 q = g + t * d;
    if (outside && (std::min({q.x, q.y, q.z}) < 0.0f || std::max({q.x, q.y, q.z}) > hi)) return -1.0f;
    Corners read;
    const float s = m * distanceAt(v, q, &read);
    ++steps;
    if (s < 0.0f) {
      seen = true;
    } else if (seen) {
      // Bisected a few times, then the zero of the line through the last interval's ends: the
      // trilinear distance is nearly linear over a fraction of a voxel.
      float lo = previous, up = t, below = before, above = s;
      for (uint32_t k = 0; k < gpu::kVolumeBisections; ++k) {
        const float mid = 0.5f * (lo + up);
        const float at = m * distanceAt(v, g + mid * d);
        if (at > 0.0f) {
          up = mid;
          above = at;
        } else {
          lo = mid;
          below = at;
        }
      }
      steps += gpu::kVolumeBisections;
      const float span = below - above;
      return span < 0.0f ? lo + (up - lo) * (below / span) : 0.5f * (lo + up);
    }
    previous = t;
    before = s;
    t += std::max(std::max(gpu::kVolumeStepScale * std::fabs(s), gpu::kVolumeMinStep), farSkip(v, q, d, read));
  }
  return -1.0f;
}

// Refraction of unit d at unit n facing it (dot(d, n) <= 0), eta = n_from / n_to; false on total
// internal reflection.
bool refracted(V3 d, V3 n, float eta, V3& out) {
  const float cosI = std::clamp(-dot(d, n), 0.0f, 1.0f);
  const float k = 1.0f - eta * eta * (1.0f - cosI * cosI);
  if (k < 0.0f) return false;
  out = unitOrZ(eta * d + (eta * cosI - std::sqrt(k)) * n);
  return true;
}

V3 reflected(V3 d, V3 n) { return d - (2.0f * dot(d, n)) * n; }

}  // namespace

float volumeDistance(const FieldVolume& volume, const std::array<float, 3>& objectPoint) {
  const float inv = 1.0f / volume.spacing;
  const V3 g{(objectPoint[0] - volume.origin[0]) * inv, (objectPoint[1] - volume.origin[1]) * inv,
             (objectPoint[2] - volume.origin[2]) * inv};
  return distanceAt(volume, g) * volume.spacing;
}

VolumePath traceVolumePath(const Field& field, const std::array<float, 3>& point, const std::array<float, 3>& normalIn,
                           const std::array<float, 3>& view) {
  const FieldVolume& v = field.volume;
  const V3 p{point[0], point[1], point[2]}, normal{normalIn[0], normalIn[1], normalIn[2]};
  V3 d{view[0], view[1], view[2]};
  const float outside = field.media[0].ior, inside = field.media[1].ior;
  const float absorption = field.media[1].absorption;
  const bool highestEnergy = field.settings.pathRule == PathRule::HighestEnergy;
  float tau = 0.0f, energy = 1.0f;
  uint32_t steps = 0;
  V3 exit = reflected(d, normal);  // total internal reflection at the entry: the path never enters
  V3 into(0.0f);
  if (refracted(d, normal, outside / inside, into)) {
    d = into;
    exit = d;  // a trapped path leaves along its direction of travel
    const float inv = 1.0f / v.spacing;
    V3 g = inv * (p - V3{v.origin[0], v.origin[1], v.origin[2]});
    bool outsideNow = false;  // between leaving the object and meeting it again
    for (uint32_t bounce = 0; bounce < field.settings.maxBounces; ++bounce) {
      const float t = crossing(v, g, d, outsideNow, steps);
      if (t < 0.0f) break;  // out of the grid without a crossing: leaves as it travels
      g = g + t * d;
      if (!outsideNow) tau += t * v.spacing * absorption;
      const V3 n = normalAt(v, g);  // outward
      // The tracer's rule (tracer.cpp) at either side: refract unless the rule picks the reflection.
      const float from = outsideNow ? outside : inside, to = outsideNow ? inside : outside;
      const V3 facing = outsideNow ? n : -1.0f * n;  // against the arriving ray
      const float R = reference::fresnelDielectric(-dot(d, facing), from / to);
      V3 across(0.0f);
      const bool canRefract = R < 1.0f && refracted(d, facing, from / to, across);
      if (canRefract && !(highestEnergy && R >= 0.5f)) {
        energy *= 1.0f - R;
        d = across;
        outsideNow = !outsideNow;
      } else {
        energy *= canRefract ? R : 1.0f;
        d = unitOrZ(reflected(d, n));
      }
      exit = d;
      if (outsideNow && v.convex) break;  // no way out of a convex object meets it again
    }
  }
  return VolumePath{{exit.x, exit.y, exit.z}, tau, energy, steps};
}

VolumePath traceVolumeSample(const Field& field, const float* m, const std::array<float, 3>& w, float* out) {
  // The sample's point and normal from its frame's rows (M_s = [R | -R p]).
  const V3 ax{m[0], m[1], m[2]}, ay{m[4], m[5], m[6]}, az{m[8], m[9], m[10]};
  const V3 p = -1.0f * (m[3] * ax + m[7] * ay + m[11] * az);
  const V3 normal = unitOrZ(az);
  const bool facesAway = w[2] < 0.0f;  // no fragment reads it
  const V3 local = unitOrZ(V3{w[0], w[1], w[2]});
  const V3 d = -1.0f * (local.x * ax + local.y * ay + local.z * az);
  const VolumePath path = facesAway ? VolumePath{{d.x, d.y, d.z}, 0.0f, 1.0f, 0, false}
                                    : traceVolumePath(field, {p.x, p.y, p.z}, {normal.x, normal.y, normal.z},
                                                      {d.x, d.y, d.z});
  out[0] = path.exit[0];
  out[1] = path.exit[1];
  out[2] = path.exit[2];
  if (field.hasOpticalDepth()) out[3] = path.opticalDepth;
  if (field.throughput) out[field.throughputChannel()] = path.throughput;
  return path;
}

}  // namespace shrefract
