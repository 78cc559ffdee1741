// The Volume encoding's grid (distance_volume.h).
#include <shrefract/bake/distance_volume.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "parallel.h"

namespace shrefract::bake {

namespace {

// The point of triangle abc nearest p, as barycentric weights (Ericson, Real-Time Collision
// Detection, 5.1.5: the Voronoi region of p among the vertices, edges and face).
glm::vec3 nearestBarycentric(glm::vec3 p, glm::vec3 a, glm::vec3 b, glm::vec3 c) {
  const glm::vec3 ab = b - a, ac = c - a, ap = p - a;
  const float d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0.0f && d2 <= 0.0f) return {1, 0, 0};
  const glm::vec3 bp = p - b;
  const float d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0.0f && d4 <= d3) return {0, 1, 0};
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) {
    const float v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const glm::vec3 cp = p - c;
  const float d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0.0f && d5 <= d6) return {0, 0, 1};
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) {
    const float w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0.0f && (d4 - d3) >= 0.0f && (d5 - d6) >= 0.0f) {
    const float w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const float den = 1.0f / (va + vb + vc);
  const float v = vb * den, w = vc * den;
  return {1 - v - w, v, w};
}

struct Grid {
  uint32_t n = 0;
  glm::vec3 origin{0.0f};
  float spacing = 1.0f;
  glm::vec3 centre(uint32_t x, uint32_t y, uint32_t z) const { return origin + spacing * glm::vec3(x, y, z); }
  size_t index(uint32_t x, uint32_t y, uint32_t z) const { return (size_t(z) * n + y) * n + x; }
};

Grid gridOver(const Scene& scene, uint32_t n) {
  const Bounds b = bounds(scene);
  const glm::vec3 extent = b.max - b.min;
  const float side = std::max({extent.x, extent.y, extent.z, 1e-30f});
  Grid g;
  g.n = n;
  g.spacing = side / float(n - 1 - 2 * kVolumePaddingVoxels);
  g.origin = 0.5f * (b.min + b.max) - 0.5f * float(n - 1) * g.spacing * glm::vec3(1.0f);
  return g;
}

// The band: per voxel the distance to the nearest triangle (in voxels) and the normal there;
// +inf beyond the band. One z slice at a time per task, every triangle tested against the voxels
// of the slice within the band of its box, in triangle order (a tie keeps the first).
struct Band {
  std::vector<float> distance;
  std::vector<glm::vec3> normal;
};

Band nearestInBand(const Scene& scene, const Grid& g, uint32_t threads) {
  Band band;
  const size_t voxels = size_t(g.n) * g.n * g.n;
  band.distance.assign(voxels, std::numeric_limits<float>::infinity());
  band.normal.assign(voxels, glm::vec3(0.0f));
  const float reach = kVolumeBandVoxels * g.spacing;
  auto cell = [&](float v, float o) { return (v - o) / g.spacing; };
  parallelFor(g.n, threads, [&](size_t zi) {
    const uint32_t z = uint32_t(zi);
    const float zc = g.origin.z + g.spacing * float(z);
    for (const Surface& s : scene.surfaces)
      for (size_t t = 0; t + 2 < s.indices.size(); t += 3) {
        const uint32_t i0 = s.indices[t], i1 = s.indices[t + 1], i2 = s.indices[t + 2];
        const glm::vec3 a = s.positions[i0], b = s.positions[i1], c = s.positions[i2];
        const glm::vec3 lo = glm::min(a, glm::min(b, c)) - reach, hi = glm::max(a, glm::max(b, c)) + reach;
        if (zc < lo.z || zc > hi.z) continue;
        const int x0 = std::max(0, int(std::ceil(cell(lo.x, g.origin.x)))), x1 = std::min(int(g.n) - 1, int(std::floor(cell(hi.x, g.origin.x))));
        const int y0 = std::max(0, int(std::ceil(cell(lo.y, g.origin.y)))), y1 = std::min(int(g.n) - 1, int(std::floor(cell(hi.y, g.origin.y))));
        for (int y = y0; y <= y1; ++y)
          for (int x = x0; x <= x1; ++x) {
            const glm::vec3 p = g.centre(uint32_t(x), uint32_t(y), z);
            const glm::vec3 w = nearestBarycentric(p, a, b, c);
            const float d = glm::length(p - (w.x * a + w.y * b + w.z * c)) / g.spacing;
            const size_t i = g.index(uint32_t(x), uint32_t(y), z);
            if (d > kVolumeBandVoxels || !(d < band.distance[i])) continue;
            band.distance[i] = d;
            const glm::vec3 nrm = w.x * s.normals[i0] + w.y * s.normals[i1] + w.z * s.normals[i2];
            band.normal[i] = glm::dot(nrm, nrm) > 0.0f ? glm::normalize(nrm) : glm::vec3(0.0f);
          }
      }
  });
  return band;
}

// Inside the medium: the first surface a ray from p meets faces away from it (its normal points
// toward the outer medium, which the ray then enters). A direction off every axis and diagonal,
// so that it runs along no face of an axis-aligned box.
bool insideByRay(const Tracer& tracer, glm::vec3 p) {
  const glm::vec3 d = glm::normalize(glm::vec3(0.5377f, 0.6294f, 0.5604f));
  const std::optional<SurfacePoint> hit = tracer.firstHit(p, d);
  return hit && glm::dot(hit->geometricNormal, d) > 0.0f;
}

// Per voxel beyond the band, the connected region of such voxels it lies in (6-neighbours), and
// per region the voxel it was first reached from; kNoRegion within the band.
constexpr uint32_t kNoRegion = ~0u;
struct Regions {
  std::vector<uint32_t> of;
  std::vector<size_t> seed;
};

Regions regionsBeyondBand(const Grid& g, const Band& band) {
  Regions r;
  r.of.assign(band.distance.size(), kNoRegion);
  const int n = int(g.n);
  std::vector<size_t> stack;
  for (size_t start = 0; start < band.distance.size(); ++start) {
    if (r.of[start] != kNoRegion || std::isfinite(band.distance[start])) continue;
    const uint32_t region = uint32_t(r.seed.size());
    r.seed.push_back(start);
    r.of[start] = region;
    stack.push_back(start);
    while (!stack.empty()) {
      const size_t i = stack.back();
      stack.pop_back();
      const int x = int(i % g.n), y = int((i / g.n) % g.n), z = int(i / (size_t(g.n) * g.n));
      const int step[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
      for (const auto& o : step) {
        const int X = x + o[0], Y = y + o[1], Z = z + o[2];
        if (X < 0 || Y < 0 || Z < 0 || X >= n || Y >= n || Z >= n) continue;
        const size_t j = g.index(uint32_t(X), uint32_t(Y), uint32_t(Z));
        if (r.of[j] != kNoRegion || std::isfinite(band.distance[j])) continue;
        r.of[j] = region;
        stack.push_back(j);
      }
    }
  }
  return r;
}

}  // namespace

std::string volumeSceneProblem(const Scene& scene) {
  if (scene.media.size() != 2)
    return "the volume encoding traces one medium in the surrounding one; the scene has " +
           std::to_string(scene.media.size()) + " media";
  for (const Surface& s : scene.surfaces)
    if (s.innerMedium != 1 || s.outerMedium != 0)
      return "the volume encoding traces one medium in the surrounding one; surface '" + s.name +
             "' is not between them";
  return {};
}

Result<FieldVolume> buildDistanceVolume(const Scene& scene, const Tracer& tracer, uint32_t size, uint32_t threads) {
  if (size < kMinVolumeSize || size > kMaxVolumeSize)
    return makeError(ErrorCode::InvalidArgument, "volume size " + std::to_string(size) + " is outside " +
                                                     std::to_string(kMinVolumeSize) + ".." +
                                                     std::to_string(kMaxVolumeSize));
  if (const std::string problem = volumeSceneProblem(scene); !problem.empty())
    return makeError(ErrorCode::InvalidArgument, problem);
  const Grid g = gridOver(scene, size);
  const Band band = nearestInBand(scene, g, threads);
  // A region beyond the band is all inside or all outside. The band's own voxels and every region
  // are told by a ray: a pocket of air the band encloses (between the bunny's ears) is no part of
  // the medium, and a path that leaves the object may now cross it. Region 0 too: where the band
  // covers the padding (a box's corners lie within 4 voxels of its own), it is the inside.
  const Regions regions = regionsBeyondBand(g, band);
  std::vector<uint8_t> regionInside(regions.seed.size(), 0);
  for (size_t k = 0; k < regions.seed.size(); ++k) {
    const size_t i = regions.seed[k];
    const uint32_t x = uint32_t(i % size), y = uint32_t((i / size) % size), z = uint32_t(i / (size_t(size) * size));
    regionInside[k] = insideByRay(tracer, g.centre(x, y, z)) ? 1 : 0;
  }
  FieldVolume v;
  v.size = size;
  v.origin = {g.origin.x, g.origin.y, g.origin.z};
  v.spacing = g.spacing;
  std::vector<uint32_t> words(band.distance.size(), 0u);
  parallelFor(band.distance.size(), threads, [&](size_t i) {
    const uint32_t x = uint32_t(i % size), y = uint32_t((i / size) % size), z = uint32_t(i / (size_t(size) * size));
    const bool inBand = std::isfinite(band.distance[i]);
    const bool inside = inBand ? insideByRay(tracer, g.centre(x, y, z)) : regionInside[regions.of[i]] != 0;
    const float d = inBand ? band.distance[i] : kVolumeBandVoxels;
    const glm::vec3 n = band.normal[i];
    words[i] = packVolumeVoxel(inside ? -d : d, {n.x, n.y, n.z});  // volumeFarWord beyond the band
  });
  setVolumeVoxels(v, words);
  return v;
}

}  // namespace shrefract::bake
