// The Volume encoding's path trace (shrefract/field_decode.h traceVolumePath): a path refracted into the
// object at a surface point and followed through its signed distance grid, marched along the
// trilinear distance until it changes sign (out of the object, or back into it where the way out
// meets it again), the crossing bisected, the interface's normal the
// trilinear normal there, the branch the field's path rule picks, up to the bounce cap. Used by
// decompress_volume.comp (at each sample, in texture space) and object_volume_body.glsl (at each
// fragment). The includer declares the grid: `head` (gpu_layout.h VolumeHeader) and
// `uint volumeWord(uint index)`, the words after the header (the brick entries, then the stored
// bricks), and includes shrefract/environment.glsl (fresnelDielectric).

// The unit vector along a, or +z for the zero vector (volume_trace.cpp normalized).
vec3 unitOr(vec3 a) {
  float len2 = dot(a, a);
  return len2 > 0.0 ? (1.0 / sqrt(len2)) * a : vec3(0.0, 0.0, 1.0);
}

// The far word (field.h volumeFarWord): the band's end on the `inside` side, the normal's levels at 0.
uint volumeFarWord(bool inside) {
  return (inside ? 0u : 2u * kVolumeDistanceZero) | (kVolumeNormalZero << kVolumeNormalShiftX) |
         (kVolumeNormalZero << kVolumeNormalShiftY);
}

// The 8 voxels around grid point g (voxel units), clamped to the grid, as volume_trace.cpp cornersAt:
// corner k is c0 + (k & 1, (k >> 1) & 1, k >> 2), read through c0's brick (gpu_layout.h: a stored
// brick holds its cells' far corners too; a brick beyond the band reads its far word at all 8).
// Returns c0's brick entry, and the brick in `brick`.
uint corners(vec3 g, out uint words[8], out float weight[8], out uvec3 brick) {
  uint n = head.grid.x;
  float hi = float(n - 1u);
  g = clamp(g, vec3(0.0), vec3(hi));
  uvec3 c0 = min(uvec3(g), uvec3(n - 2u));
  vec3 f = g - vec3(c0);
  for (uint k = 0u; k < 8u; ++k) {
    uvec3 dk = uvec3(k & 1u, (k >> 1u) & 1u, (k >> 2u) & 1u);
    weight[k] = (dk.x != 0u ? f.x : 1.0 - f.x) * (dk.y != 0u ? f.y : 1.0 - f.y) * (dk.z != 0u ? f.z : 1.0 - f.z);
  }
  uint per = (n + kVolumeBrickSide - 1u) / kVolumeBrickSide;
  uvec3 b = c0 / kVolumeBrickSide, l = c0 % kVolumeBrickSide;
  uint entry = volumeWord((b.z * per + b.y) * per + b.x);
  brick = b;
  uint far = volumeFarWord((entry & 1u) == 0u);
  for (uint k = 0u; k < 8u; ++k) words[k] = far;
  if (entry < kVolumeBrickFar) {
    uint base = per * per * per + entry * kVolumeApronWords + (l.z * kVolumeApronSide + l.y) * kVolumeApronSide + l.x;
    for (uint k = 0u; k < 8u; ++k)
      words[k] = volumeWord(base + (k & 1u) + ((k >> 1u) & 1u) * kVolumeApronSide +
                            (k >> 2u) * (kVolumeApronSide * kVolumeApronSide));
  }
  return entry;
}

float voxelDistance(uint word) {
  return (float(word & kVolumeDistanceMask) - float(kVolumeDistanceZero)) * (kVolumeBandVoxels / float(kVolumeDistanceZero));
}

// The trilinear distance at g, with the brick read and its entry (for farSkip).
float distanceAt(vec3 g, out uvec3 brick, out uint entry) {
  uint words[8];
  float weight[8];
  entry = corners(g, words, weight, brick);
  float d = 0.0;
  for (uint k = 0u; k < 8u; ++k) d += weight[k] * voxelDistance(words[k]);
  return d;
}

float distanceAt(vec3 g) {
  uvec3 brick;
  uint entry;
  return distanceAt(g, brick, entry);
}

vec3 unpackNormal(uint word) {
  float nzero = float(kVolumeNormalZero);
  float px = min((float((word >> kVolumeNormalShiftX) & kVolumeNormalMask) - nzero) / nzero, 1.0);
  float py = min((float((word >> kVolumeNormalShiftY) & kVolumeNormalMask) - nzero) / nzero, 1.0);
  vec3 n = vec3(px, py, 1.0 - abs(px) - abs(py));
  if (n.z < 0.0) {
    float x = n.x;
    n.x = (1.0 - abs(n.y)) * (x >= 0.0 ? 1.0 : -1.0);
    n.y = (1.0 - abs(x)) * (n.y >= 0.0 ? 1.0 : -1.0);
  }
  return unitOr(n);
}

// As volume_trace.cpp normalAt: the corners facing the nearest corner's way, blended.
vec3 normalAt(vec3 g) {
  uint words[8];
  float weight[8];
  uvec3 brick;
  corners(g, words, weight, brick);
  vec3 u[8];
  uint nearest = 0u;
  for (uint k = 0u; k < 8u; ++k) {
    u[k] = unpackNormal(words[k]);
    if (weight[k] > weight[nearest]) nearest = k;
  }
  vec3 n = vec3(0.0);
  for (uint k = 0u; k < 8u; ++k)
    if (dot(u[k], u[nearest]) >= kVolumeNormalBlendCos) n = n + weight[k] * u[k];
  return unitOr(n);
}

// As volume_trace.cpp farSkip: how far along d from grid point g the cube of far bricks around
// g's brick b (entry: its entry, as distanceAt read them; gpu_layout.h kVolumeBrickFar) reaches;
// 0 in a stored brick or off the grid.
float farSkip(vec3 g, vec3 d, uvec3 b, uint entry) {
  uint n = head.grid.x;
  float hi = float(n - 1u);
  if (entry < kVolumeBrickFar || min(g.x, min(g.y, g.z)) < 0.0 || max(g.x, max(g.y, g.z)) > hi) return 0.0;
  uint reach = (entry - kVolumeBrickFar) >> 1u;
  vec3 lo = vec3((b + 1u - reach) * kVolumeBrickSide), up = vec3((b + reach) * kVolumeBrickSide);
  float t = 4.0 * float(n);
  for (int k = 0; k < 3; ++k)
    if (d[k] != 0.0) t = min(t, ((d[k] > 0.0 ? up[k] : lo[k]) - g[k]) / d[k]);
  return t;
}

// As volume_trace.cpp crossing: the distance along d to the next interface (`outside`: from outside
// the object, where the march stops as it leaves the grid's box), or -1.
float crossing(vec3 g, vec3 d, bool outside) {
  float m = outside ? -1.0 : 1.0;
  float limit = 2.0 * float(head.grid.x), hi = float(head.grid.x - 1u);
  float t = kVolumeStartStep, previous = 0.0, before = 0.0;
  bool seen = false;
  for (uint step = 0u; step < kVolumeMaxSteps && t < limit; ++step) {
    vec3 q = g + t * d;
    if (outside && (min(q.x, min(q.y, q.z)) < 0.0 || max(q.x, max(q.y, q.z)) > hi)) return -1.0;
    uvec3 brick;
    uint entry;
    float s = m * distanceAt(q, brick, entry);
    if (s < 0.0) {
      seen = true;
    } else if (seen) {
      float lo = previous, up = t, below = before, above = s;
      for (uint k = 0u; k < kVolumeBisections; ++k) {
        float mid = 0.5 * (lo + up);
        float at = m * distanceAt(g + mid * d);
        if (at > 0.0) {
          up = mid;
          above = at;
        } else {
          lo = mid;
          below = at;
        }
      }
      float span = below - above;
      return span < 0.0 ? lo + (up - lo) * (below / span) : 0.5 * (lo + up);
    }
    previous = t;
    before = s;
    t += max(max(kVolumeStepScale * abs(s), kVolumeMinStep), farSkip(q, d, brick, entry));
  }
  return -1.0;
}

bool refracted(vec3 d, vec3 n, float eta, out vec3 outDir) {
  float cosI = clamp(-dot(d, n), 0.0, 1.0);
  float k = 1.0 - eta * eta * (1.0 - cosI * cosI);
  outDir = vec3(0.0);
  if (k < 0.0) return false;
  outDir = unitOr(eta * d + (eta * cosI - sqrt(k)) * n);
  return true;
}

vec3 reflected(vec3 d, vec3 n) { return d - (2.0 * dot(d, n)) * n; }

// The path of the unit view direction d that meets the surface at p (object space) with unit
// normal `normal`: refracted in, traced through the grid by the field's path rule (head.grid.z),
// up to the bounce cap. Mirrored by volume_trace.cpp traceVolumePath, the same float operations
// in the same order.
struct VolumePath {
  vec3 exit;     // unit, object space
  float tau;     // the path's length inside times the inner medium's absorption
  float energy;  // the Fresnel factors after the entry
};

VolumePath traceVolumePath(vec3 p, vec3 normal, vec3 d) {
  float tau = 0.0, energy = 1.0;
  vec3 exitDir = reflected(d, normal);  // total internal reflection at the entry
  vec3 into;
  if (refracted(d, normal, head.media.x, into)) {
    d = into;
    exitDir = d;
    float inv = 1.0 / head.origin.w;
    vec3 g = inv * (p - head.origin.xyz);
    bool outsideNow = false;  // between leaving the object and meeting it again
    for (uint bounce = 0u; bounce < head.grid.y; ++bounce) {
      float t = crossing(g, d, outsideNow);
      if (t < 0.0) break;
      g = g + t * d;
      if (!outsideNow) tau += t * head.origin.w * head.media.z;
      vec3 n = normalAt(g);
      float eta = outsideNow ? head.media.x : head.media.y;
      vec3 facing = outsideNow ? n : -1.0 * n;
      float R = fresnelDielectric(-dot(d, facing), eta);
      vec3 across;
      bool canRefract = R < 1.0 && refracted(d, facing, eta, across);
      if (canRefract && !(head.grid.z != 0u && R >= 0.5)) {
        energy *= 1.0 - R;
        d = across;
        outsideNow = !outsideNow;
      } else {
        energy *= canRefract ? R : 1.0;
        d = unitOr(reflected(d, n));
      }
      exitDir = d;
      if (outsideNow && head.grid.w != 0u) break;  // no way out of a convex object meets it again
    }
  }
  return VolumePath(exitDir, tau, energy);
}
