#include <shrefract/trace/reference_render.h>
#include <shrefract/cpu_reference.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <thread>

#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "reference/reference_common.h"

namespace shrefract::bake {

using namespace reference_detail;  // reference_common.h

namespace {

// Screen derivatives of a lookup direction across a (sub-)pixel; zero: none (level 0).
struct Derivatives {
  glm::vec3 dx{0.0f}, dy{0.0f};
};

// The filtered renderers' four probes around a sample: +x, -x, +y, -y.
constexpr float kAroundX[4] = {1.0f, -1.0f, 0.0f, 0.0f}, kAroundY[4] = {0.0f, 0.0f, 1.0f, -1.0f};

// The area of the unit box [-1/2, 1/2]^2 where dot(normal, p) > offset (Sutherland-Hodgman
// against the one half-plane, then the shoelace formula).
float boxAreaBeyond(glm::vec2 normal, float offset) {
  const glm::vec2 box[4] = {{-0.5f, -0.5f}, {0.5f, -0.5f}, {0.5f, 0.5f}, {-0.5f, 0.5f}};
  std::array<glm::vec2, 5> kept;
  size_t count = 0;
  for (size_t i = 0; i < 4; ++i) {
    const glm::vec2 a = box[i], b = box[(i + 1) % 4];
    const float fa = glm::dot(normal, a) - offset, fb = glm::dot(normal, b) - offset;
    if (fa > 0.0f) kept[count++] = a;
    if ((fa > 0.0f) != (fb > 0.0f)) kept[count++] = a + (b - a) * (fa / (fa - fb));
  }
  float twice = 0.0f;
  for (size_t i = 0; i < count; ++i) {
    const glm::vec2 a = kept[i], b = kept[(i + 1) % count];
    twice += a.x * b.y - a.y * b.x;
  }
  return 0.5f * std::abs(twice);
}

}  // namespace

std::array<float, 4> shareBeyondCrossings(const std::array<float, 4>& crossing) {
  std::array<float, 4> share{};
  const bool across[4] = {crossing[0] > 0.0f, crossing[1] > 0.0f, crossing[2] > 0.0f, crossing[3] > 0.0f};
  const int xs = int(across[0]) + int(across[1]), ys = int(across[2]) + int(across[3]);
  if (xs == 2 || ys == 2) {
    // Across on both sides of an axis: a feature thinner than the cell, or two discontinuities,
    // whose sides one probe each does not tell apart; the expected share, 1/4 per probe.
    const float beyond = 1.0f - (1.0f - 0.25f * float(xs)) * (1.0f - 0.25f * float(ys));
    for (size_t k = 0; k < 4; ++k) share[k] = across[k] ? beyond / float(xs + ys) : 0.0f;
  } else if (xs == 1 && ys == 1) {
    // One edge through (X, 0) and (0, Y): beyond it x / X + y / Y > 1.
    const size_t kx = across[0] ? 0 : 1, ky = across[2] ? 2 : 3;
    const float X = kAroundX[kx] * crossing[kx], Y = kAroundY[ky] * crossing[ky];
    share[kx] = share[ky] = 0.5f * boxAreaBeyond({1.0f / X, 1.0f / Y}, 1.0f);
  } else {
    for (size_t k = 0; k < 4; ++k)
      if (across[k]) share[k] = 0.5f - std::min(crossing[k], 0.5f);  // at right angles to its axis
  }
  return share;
}


glm::vec3 pixelDirection(const Camera& camera, uint32_t width, uint32_t height, uint32_t x, uint32_t y) {
  const auto r = reference::pixelRay(camera, width, height, x, y);  // the engine's projection
  return glm::normalize(glm::vec3(r[0], r[1], r[2]));
}

namespace {

Result<void> checkReferenceOptions(const Image& env, const ReferenceOptions& o) {
  if (auto r = checkSize("reference render", o.width, o.height, o.samplesPerAxis); !r) return r.error();
  if (env.width == 0 || env.rgba.size() != size_t(env.width) * env.height * 4)
    return makeError(ErrorCode::InvalidArgument, "reference render: empty environment");
  if (o.environmentTapsPerAxis < 1 || o.environmentTapsPerAxis > kMaxEnvironmentTapsPerAxis)
    return makeError(ErrorCode::InvalidArgument, "reference render: environmentTapsPerAxis " +
                                                     std::to_string(o.environmentTapsPerAxis) + " is outside 1.." +
                                                     std::to_string(kMaxEnvironmentTapsPerAxis));
  if (!(std::abs(o.environmentLevelBias) <= kMaxEnvironmentLevelBias))
    return makeError(ErrorCode::InvalidArgument, "reference render: environmentLevelBias " +
                                                     std::to_string(o.environmentLevelBias) + " is outside +-" +
                                                     std::to_string(kMaxEnvironmentLevelBias));
  return {};
}

// One sub-sample's trace: the eye ray along d and, in FullTree mode, its tree's leaves.
struct Traced {
  EyeRayResult hit;
  std::vector<PathResult> leaves;
};

// A traced ray and the directions it looks up: [0] the front reflection, then the transmitted
// ones (SingleInterface: the refracted ray; Exact: the path's exit; FullTree: every leaf's exit).
// keys[i]: the path's number of interfaces (the reflection: 0); a neighbour's lookup with another
// key went another way through the object, and its direction is no derivative of this one.
struct Probe {
  glm::vec3 d{0.0f};
  Traced t;
  std::vector<glm::vec3> dirs;
  std::vector<uint32_t> keys;
};

// Filtered, one sub-sample and four probes at the midpoints of its cell's edges, half a cell
// away along +-x and +-y, each traced in full (5x the rays, and the bisections below): a
// discontinuity on either side of the sample is seen (one probe per axis, toward the quad
// neighbour, missed half of them).
// Per lookup and axis, the derivative is the central difference where both probes went the same
// way for that lookup (same surface, same key; the front reflection: same surface, no crease
// between; see counterpart), the one-sided difference where one did: the
// engine's fine derivatives, measured inside the cell. Where neither did, a discontinuity lies
// inside the cell; the difference to a probe with as many lookups (the exact path's exit beyond
// it, a tree of the same size) stays the derivative, so the lookup spreads over the directions
// the cell sees, as the engine's quad derivatives do, where a point lookup would sparkle.
// A probe that went another way (a silhouette, a crease, another highest-energy branch, another
// number of interfaces) has a discontinuity between it and the sample. Where it lies is found by
// bisection (kCrossingBisections traces, to 1/16 of a cell): at distance t, the box filter over
// the cell sees the probe's side over 1/2 - t of that axis, and the probe's colour enters with
// that share (shareBeyondCrossings: where crossings on one x and one y half-axis fix a straight
// edge, the box's area beyond it; with probes across on both sides of an axis, the expected
// share 1/4 each). Without the bisection every probe across took the expected share, 1/4,
// blending a pixel the edge barely touches as much as one it halves (docs/technique.md,
// "Where the discontinuity lies").
constexpr float kProbeOffset = 0.5f;
constexpr int kCrossingBisections = 3;

// Refined sub-samples (ReferenceOptions::refine): a probe across whose colour differs from the
// sample's by more than kRefineJump, or probes whose mean differs from it by more than kRefineBend
// (colourBends), in the written image's linear colour, any channel. Measured on the four built-in
// scenes, full tree at 1 spp against the 7x7 full tree (docs/technique.md, "Refined pixels in
// the full tree"): every discontinuity refined (no jump threshold) cost the torus and the glass of
// water 1.5x and 1.8x the time for 0.19 and 0.37 dB; jumps of 0.1 left the glass of water 1.4 dB
// short; bends of 0.03 left it 0.1 dB short and 0.01 meets it by 1.0 dB.
constexpr float kRefineJump = 0.03f;
constexpr float kRefineBend = 0.01f;

float maxAbs(glm::vec3 v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); }

// A sub-sample, its probes and scratch space, reused across the sub-samples of one row.
struct Neighbourhood {
  Probe self;
  std::array<Probe, 4> around;  // +x, -x, +y, -y
  Probe between;                // scratch: a bisection's probe
  float x = 0.0f, y = 0.0f;     // the sample, in sub-pixels
  float cell = 1.0f;            // the sample's cell, in sub-pixels (probes lie half of it away)
  bool across = false;          // blendAcross: a probe went another way
  bool jumps = false;           // blendAcross: one of those shows another colour (see kRefineJump)
  bool refinable = false;       // a jump refines this sample: blendAcross stops once it finds one
  std::vector<Derivatives> derivatives;
  std::vector<Derivatives> footprints;  // scratch: a probe's, in blendAcross
};

// The sub-samples of a reference render: traces, lookups and shading for one image's options.
// Immutable after construction; sample() may be called from any thread, each with its own
// Neighbourhood.
class SubSampler {
 public:
  SubSampler(const Tracer& tracer, const Scene& scene, const Image& env, const ReferenceOptions& o)
      : tracer_(tracer), scene_(scene), env_(env), o_(o), bigWidth_(o.width * o.samplesPerAxis),
        bigHeight_(o.height * o.samplesPerAxis), dirFromClip_(directionFromClip(o.camera, bigWidth_, bigHeight_)),
        eye_(toVec(o.camera.eye)), filteredEnv_{env.width, env.height, env.rgba.data()} {
    settings_.maxBounces = o.mode == ReferenceMode::FullTree ? o.treeDepth : o.maxBounces;
    settings_.pathRule = o.pathRule;
    // Filtered lookups (o.filtered, docs/technique.md): the engine's level chain, built once.
    if (o.filtered) {
      levels_ = reference::environmentLevels(filteredEnv_);
      filteredEnv_.levels = &levels_;
      filteredEnv_.tapsPerAxis = o.environmentTapsPerAxis;
      filteredEnv_.levelBias = o.environmentLevelBias;
      oneTapEnv_ = filteredEnv_;
      oneTapEnv_.tapsPerAxis = 1;
    }
  }
  SubSampler(const SubSampler&) = delete;  // filteredEnv_ points at levels_
  SubSampler& operator=(const SubSampler&) = delete;

  // Sub-sample (bx, by) of the supersampled image; `refined` counts the ones traced again at 2x2.
  Sample sample(uint32_t bx, uint32_t by, Neighbourhood& n, uint64_t& rays, uint64_t& refined) const {
    if (o_.filtered) return refinableSample(bx, by, n, rays, refined);
    probeAt(float(bx), float(by), n.self, rays);
    n.derivatives.clear();
    return shade(n.self, n.derivatives);
  }

 private:
  glm::vec3 lookup(glm::vec3 dir, const Derivatives& dd, bool oneTap = false) const;
  void trace(glm::vec3 d, Traced& t, uint64_t& rays) const;
  void lookups(Probe& p) const;
  Sample shade(const Probe& p, const std::vector<Derivatives>& derivatives, bool oneTap = false) const;
  glm::vec3 transmitted(const Probe& p, const std::vector<Derivatives>& derivatives, Sample& sample,
                        bool oneTap) const;
  void probeAt(float bx, float by, Probe& p, uint64_t& rays) const;
  static bool sameWay(const Probe& a, const Probe& b, bool keys = true);
  static glm::vec3 axisDerivative(const Probe& self, const Probe& after, const Probe& before, size_t i);
  static const glm::vec3* counterpart(const Probe& self, const Probe& p, size_t i);
  float crossingDistance(Neighbourhood& n, size_t k, bool keys, uint64_t& rays) const;
  glm::vec3 blendAcross(Neighbourhood& n, glm::vec3 own, uint64_t& rays) const;
  glm::vec3 ownSideMean(const Neighbourhood& n, glm::vec3 own, const std::array<bool, 4>& across,
                        const std::array<float, 4>& crossing) const;
  Sample filteredSample(float x, float y, float cell, Neighbourhood& n, uint64_t& rays) const;
  bool colourBends(const Neighbourhood& n) const;
  Sample refinableSample(uint32_t bx, uint32_t by, Neighbourhood& n, uint64_t& rays, uint64_t& refined) const;

  const Tracer& tracer_;
  const Scene& scene_;
  const Image& env_;
  const ReferenceOptions& o_;
  uint32_t bigWidth_, bigHeight_;
  glm::mat4 dirFromClip_;
  glm::vec3 eye_;
  TraceSettings settings_;
  std::vector<std::vector<float>> levels_;
  reference::LatLongImage filteredEnv_;
  reference::LatLongImage oneTapEnv_;  // filteredEnv_ at one tap per lookup (colourBends)
};

// Level 0 (bake::sampleLatLong) unless filtered: then averaged over the pixel as the engine does
// (at one tap where oneTap).
glm::vec3 SubSampler::lookup(glm::vec3 dir, const Derivatives& dd, bool oneTap) const {
  if (!o_.filtered) return sampleLatLong(env_, dir);
  const reference::LatLongImage& env = oneTap ? oneTapEnv_ : filteredEnv_;
  const reference::Vec3 c = reference::sampleLatLongOverPixel(env, {dir.x, dir.y, dir.z}, {dd.dx.x, dd.dx.y, dd.dx.z},
                                                               {dd.dy.x, dd.dy.y, dd.dy.z});
  return glm::vec3(c[0], c[1], c[2]);
}

void SubSampler::trace(glm::vec3 d, Traced& t, uint64_t& rays) const {
  t.hit = tracer_.traceEyeRay(eye_, d, settings_);
  rays += t.hit.rays;
  t.leaves.clear();
  if (!t.hit.hit || o_.mode != ReferenceMode::FullTree) return;
  SurfacePoint point;
  point.position = t.hit.position;
  point.shadingNormal = t.hit.shadingNormal;
  point.geometricNormal = t.hit.shadingNormal;
  point.surface = t.hit.surface;
  point.triangle = t.hit.triangle;
  tracer_.traceTree(point, d, o_.treeDepth, t.leaves);
  rays += t.leaves.size();
}

// p.dirs and p.keys from p's trace (see Probe).
void SubSampler::lookups(Probe& p) const {
  p.dirs.clear();
  p.keys.clear();
  const Traced& t = p.t;
  if (!t.hit.hit) return;
  p.dirs.push_back(t.hit.reflectedDirection);
  p.keys.push_back(0);
  if (o_.mode == ReferenceMode::SingleInterface) {
    const Surface& surface = scene_.surfaces[t.hit.surface];
    const float eta = scene_.media[surface.outerMedium].ior / scene_.media[surface.innerMedium].ior;
    glm::vec3 r = glm::refract(p.d, t.hit.shadingNormal, eta);
    if (glm::dot(r, r) == 0.0f) r = t.hit.reflectedDirection;
    p.dirs.push_back(glm::normalize(r));
    p.keys.push_back(0);
  } else if (o_.mode == ReferenceMode::Exact) {
    p.dirs.push_back(t.hit.transmitted.exitDirection);
    p.keys.push_back(t.hit.transmitted.interactions);
  } else {
    for (const PathResult& leaf : t.leaves) {
      p.dirs.push_back(leaf.exitDirection);
      p.keys.push_back(leaf.interactions);
    }
  }
}

// One sub-sample's colour: p traced and its lookups found; derivatives[i] (filtered) for lookup i.
Sample SubSampler::shade(const Probe& p, const std::vector<Derivatives>& derivatives, bool oneTap) const {
  Sample sample;
  const EyeRayResult& hit = p.t.hit;
  if (!hit.hit) {
    sample.color = sampleLatLong(env_, p.d) * o_.exposure;
    return sample;
  }
  sample.hit = true;
  const Surface& surface = scene_.surfaces[hit.surface];
  float f = hit.frontFresnel;
  if (o_.mode == ReferenceMode::SingleInterface) {
    const float eta = scene_.media[surface.outerMedium].ior / scene_.media[surface.innerMedium].ior;
    f = reference::fresnelDielectric(std::clamp(-glm::dot(p.d, hit.shadingNormal), 0.0f, 1.0f), eta);
  }
  // One colour model in every mode (docs/scenes.md): the colour of the medium behind the front
  // surface tints all the light transmitted through it.
  glm::vec3 color = (1.0f - f) * transmitted(p, derivatives, sample, oneTap) * scene_.media[surface.innerMedium].color;
  if (o_.reflection)
    color += f * lookup(hit.reflectedDirection, derivatives.empty() ? Derivatives{} : derivatives[0], oneTap);
  sample.color = color * o_.exposure;
  return sample;
}

// The light transmitted through the front surface, by mode; sets sample.direction.
glm::vec3 SubSampler::transmitted(const Probe& p, const std::vector<Derivatives>& derivatives, Sample& sample,
                                  bool oneTap) const {
  auto derivativesOf = [&](size_t i) { return i < derivatives.size() ? derivatives[i] : Derivatives{}; };
  const EyeRayResult& hit = p.t.hit;
  if (o_.mode == ReferenceMode::SingleInterface) {
    sample.direction = p.dirs[1];
    return lookup(sample.direction, derivativesOf(1), oneTap);
  }
  if (o_.mode == ReferenceMode::Exact) {
    const PathResult& path = hit.transmitted;
    sample.direction = path.exitDirection;
    glm::vec3 light =
        lookup(path.exitDirection, derivativesOf(1), oneTap) * std::exp(-path.opticalDepth * o_.absorptionScale);
    if (o_.throughput) light *= path.energy;
    return light;
  }
  glm::vec3 sum(0.0f), dirSum(0.0f);
  for (size_t i = 0; i < p.t.leaves.size(); ++i) {
    const PathResult& leaf = p.t.leaves[i];
    sum += leaf.energy * lookup(leaf.exitDirection, derivativesOf(i + 1), oneTap) *
           std::exp(-leaf.opticalDepth * o_.absorptionScale);
    dirSum += leaf.energy * leaf.exitDirection;
  }
  sample.direction = glm::dot(dirSum, dirSum) > 0.0f ? glm::normalize(dirSum) : hit.transmitted.exitDirection;
  return sum;
}

void SubSampler::probeAt(float bx, float by, Probe& p, uint64_t& rays) const {
  p.d = glm::normalize(rayAt(dirFromClip_, bigWidth_, bigHeight_, bx, by));
  trace(p.d, p.t, rays);
  lookups(p);
}

// Shading normals further apart than acos(kCreaseCosine) meet at a crease (the cube's edges): the
// reflection, and the light through the face, change there as at a path discontinuity. From 15 to
// 60 deg the four built-in scenes render within 0.01 dB of each other; half a pixel apart a smooth
// surface's normals turn that far only at its silhouette.
constexpr float kCreaseCosine = 0.8660254f;  // cos 30 deg

// Two hits on the same surface, on the same side of any crease.
bool sameFace(const EyeRayResult& a, const EyeRayResult& b) {
  return a.surface == b.surface && glm::dot(a.shadingNormal, b.shadingNormal) > kCreaseCosine;
}

// Two probes went the same way: both missed, or both hit the same face (sameFace), with the same
// lookup keys where `keys`.
bool SubSampler::sameWay(const Probe& a, const Probe& b, bool keys) {
  if (a.t.hit.hit != b.t.hit.hit || (keys && a.keys != b.keys)) return false;
  return !a.t.hit.hit || sameFace(a.t.hit, b.t.hit);
}

// Probe p's direction for the sample's lookup i, or null where p went another way for it.
// - The front reflection (lookup 0) depends on the surface alone: p's reflection where p hit the
//   same face (sameFace), whatever the paths behind do. A tree of another
//   shape left it at level 0, where it sparkled; a difference across a crease spread it over both
//   faces' reflections.
// - Any other lookup: p's lookup i where p's lookups correspond (as many) and it has the same key.
// (docs/technique.md, "Creases and the front reflection".)
const glm::vec3* SubSampler::counterpart(const Probe& self, const Probe& p, size_t i) {
  if (!p.t.hit.hit) return nullptr;
  if (i == 0) return sameFace(p.t.hit, self.t.hit) ? &p.dirs[0] : nullptr;
  return p.t.hit.surface == self.t.hit.surface && p.dirs.size() == self.dirs.size() && p.keys[i] == self.keys[i]
             ? &p.dirs[i]
             : nullptr;
}

// Lookup i's derivative along one axis from the probes half a cell before and after the sample.
glm::vec3 SubSampler::axisDerivative(const Probe& self, const Probe& after, const Probe& before, size_t i) {
  const glm::vec3* a = counterpart(self, after, i);
  const glm::vec3* b = counterpart(self, before, i);
  if (a && b) return (*a - *b) / (2.0f * kProbeOffset);
  auto alike = [&](const Probe& p) { return p.dirs.size() == self.dirs.size(); };
  if (a) return (*a - self.dirs[i]) / kProbeOffset;
  if (b) return (self.dirs[i] - *b) / kProbeOffset;
  if (alike(after)) return (after.dirs[i] - self.dirs[i]) / kProbeOffset;
  if (alike(before)) return (self.dirs[i] - before.dirs[i]) / kProbeOffset;
  return glm::vec3(0.0f);
}

// Where between the sample and probe k, which went another way, the way changes: its distance
// from the sample in cells, in (0, kProbeOffset).
float SubSampler::crossingDistance(Neighbourhood& n, size_t k, bool keys, uint64_t& rays) const {
  float inside = 0.0f, beyond = kProbeOffset;
  for (int b = 0; b < kCrossingBisections; ++b) {
    const float mid = 0.5f * (inside + beyond);
    probeAt(n.x + mid * n.cell * kAroundX[k], n.y + mid * n.cell * kAroundY[k], n.between, rays);
    (sameWay(n.self, n.between, keys) ? inside : beyond) = mid;
  }
  return 0.5f * (inside + beyond);
}

// The sample's colour with the probes across a discontinuity blended in, each shaded with this
// sample's footprints (the same pixel-scale spread; level 0 would sparkle) where their lookups
// correspond: all of them in a probe with as many lookups, else those of the same key.
glm::vec3 SubSampler::blendAcross(Neighbourhood& n, glm::vec3 own, uint64_t& rays) const {
  std::array<bool, 4> across{};
  // The blend models one straight edge per cell. Where the silhouette crosses the cell, that edge
  // is the silhouette, and in the full tree the probes that hit count as the sample's side
  // whatever their keys. Near a rim the tree's keys change within a pixel: counted as
  // discontinuities they put every probe across, each at the expected share whatever the
  // coverage (the sphere's rim read as glass at half coverage). The exact mode keeps the keys:
  // one path's colour jumps with its key there (sphere -0.57 dB without them;
  // docs/technique.md, "Silhouettes before keys").
  bool silhouette = false;
  for (const Probe& p : n.around) silhouette = silhouette || !p.t.hit.hit;
  const bool keys = !(o_.mode == ReferenceMode::FullTree && n.self.t.hit.hit && silhouette);
  for (size_t k = 0; k < n.around.size(); ++k) across[k] = !sameWay(n.self, n.around[k], keys);
  n.across = across[0] || across[1] || across[2] || across[3];
  n.jumps = false;
  // With both probes of an axis across, shareBeyondCrossings takes the expected share whatever
  // the distances: nothing to bisect.
  const bool bisect = !(across[0] && across[1]) && !(across[2] && across[3]);
  std::array<float, 4> crossing{};  // distance to the discontinuity toward probe k; 0: none
  std::array<glm::vec3, 4> colour{};
  for (size_t k = 0; k < n.around.size(); ++k) {
    if (!across[k]) continue;
    const Probe& p = n.around[k];
    n.footprints.assign(p.dirs.size(), Derivatives{});
    for (size_t i = 0; i < p.dirs.size() && i < n.self.dirs.size(); ++i)
      if (p.dirs.size() == n.self.dirs.size() || p.keys[i] == n.self.keys[i]) n.footprints[i] = n.derivatives[i];
    colour[k] = shade(p, n.footprints).color;
    n.jumps = n.jumps || p.t.hit.hit != n.self.t.hit.hit || maxAbs(colour[k] - own) > kRefineJump;
  }
  if (n.refinable && n.jumps) return own;  // the sample is traced again: its blend would be thrown away
  for (size_t k = 0; k < n.around.size(); ++k)
    if (across[k]) crossing[k] = bisect ? crossingDistance(n, k, keys, rays) : kProbeOffset;
  const std::array<float, 4> share = shareBeyondCrossings(crossing);
  if (bisect && o_.mode == ReferenceMode::FullTree) own = ownSideMean(n, own, across, crossing);
  float keep = 1.0f;
  glm::vec3 acrossSum(0.0f);
  for (size_t k = 0; k < 4; ++k) {
    keep -= share[k];
    acrossSum += share[k] * colour[k];
  }
  return keep * own + acrossSum;
}

// The mean colour of the sample's own side of the crossings, not the colour at the sample: with a
// crossing at distance t toward probe k, the own side spans [-1/2, t] along that axis and its
// centroid lies (1/2 - t) / 2 cells from the sample, away from the crossing; over a linear ramp
// through the sample and the opposite probe (half a cell the other way, on the own side), that is
// the sample's colour moved toward the opposite probe's by 1/2 - t. Near a glass rim the colour
// changes fastest where the pixel is cut (Fresnel rises toward grazing), and the sample at the
// centre stands least for its side (docs/technique.md, "The own side's colour"). FullTree
// only: its colour, a sum over every branch, is smooth on either side of a discontinuity; one
// exact path's is not (the torus's flanks speckle), and a ramp through one probe there
// extrapolates the speckle (exact mode at 1 spp: torus -0.22 dB).
glm::vec3 SubSampler::ownSideMean(const Neighbourhood& n, glm::vec3 own, const std::array<bool, 4>& across,
                                  const std::array<float, 4>& crossing) const {
  glm::vec3 mean = own;
  for (size_t k = 0; k < 4; ++k) {
    const size_t opposite = k ^ 1;  // +x <-> -x, +y <-> -y
    if (!across[k] || across[opposite]) continue;
    mean += (kProbeOffset - crossing[k]) * (shade(n.around[opposite], n.derivatives).color - own);
  }
  return mean;
}

Sample SubSampler::filteredSample(float x, float y, float cell, Neighbourhood& n, uint64_t& rays) const {
  const float h = kProbeOffset * cell;
  n.x = x;
  n.y = y;
  n.cell = cell;
  probeAt(x, y, n.self, rays);
  probeAt(x + h, y, n.around[0], rays);
  probeAt(x - h, y, n.around[1], rays);
  probeAt(x, y + h, n.around[2], rays);
  probeAt(x, y - h, n.around[3], rays);
  n.derivatives.clear();
  for (size_t i = 0; i < n.self.dirs.size(); ++i)
    n.derivatives.push_back({axisDerivative(n.self, n.around[0], n.around[1], i),
                             axisDerivative(n.self, n.around[2], n.around[3], i)});
  Sample sample = shade(n.self, n.derivatives);
  sample.color = blendAcross(n, sample.color, rays);
  return sample;
}

// The colour bends inside the cell: the mean of the probes on an axis differs from the sample's
// colour by more than kRefineBend, where the filtered lookup, which spreads over a linear
// footprint, misses a highlight or a fold of the directions (the sphere's rim, Fresnel rising toward
// grazing, which no probe sees as a discontinuity). Shaded with one tap per lookup, a sixteenth of
// the sample's own: a measure of the change, not its colour.
bool SubSampler::colourBends(const Neighbourhood& n) const {
  if (n.across || !n.self.t.hit.hit) return false;
  const glm::vec3 centre = shade(n.self, n.derivatives, true).color;
  for (size_t a = 0; a < 4; a += 2) {
    const glm::vec3 mean =
        0.5f * (shade(n.around[a], n.derivatives, true).color + shade(n.around[a + 1], n.derivatives, true).color);
    if (maxAbs(mean - centre) > kRefineBend) return true;
  }
  return false;
}

// A filtered sub-sample, and (ReferenceOptions::refine, FullTree) where its probes see the colour
// jump (kRefineJump) or bend (colourBends), the mean of four filtered samples of the quarters of
// its cell instead, each with its own probes at half the distance and its own footprints.
Sample SubSampler::refinableSample(uint32_t bx, uint32_t by, Neighbourhood& n, uint64_t& rays,
                                   uint64_t& refined) const {
  const float x = float(bx), y = float(by);
  const bool refinable = o_.refine && o_.mode == ReferenceMode::FullTree;
  n.refinable = refinable;
  Sample sample = filteredSample(x, y, 1.0f, n, rays);
  n.refinable = false;  // the quarters are not refined again
  if (!refinable || !(n.jumps || colourBends(n))) return sample;
  ++refined;
  glm::vec3 color(0.0f), direction(0.0f);
  for (const float dy : {-0.25f, 0.25f})
    for (const float dx : {-0.25f, 0.25f}) {
      const Sample quarter = filteredSample(x + dx, y + dy, 0.5f, n, rays);
      color += 0.25f * quarter.color;
      if (quarter.hit) direction += quarter.direction;
    }
  sample.color = color;  // hit stays the centre's: the mask's rule (reference_render.h)
  if (sample.hit && glm::dot(direction, direction) > 0.0f) sample.direction = glm::normalize(direction);
  return sample;
}

}  // namespace

Result<ReferenceImage> renderReference(const Tracer& tracer, const Scene& scene, const Image& env,
                                       const ReferenceOptions& o) {
  if (auto r = checkReferenceOptions(env, o); !r) return r.error();
  const auto start = Clock::now();
  ReferenceImage out = emptyImage(o.width, o.height);
  const SubSampler sampler(tracer, scene, env, o);
  const uint32_t s = o.samplesPerAxis;
  std::atomic<uint64_t> refined{0};
  out.rays = forEachRow(o.height, threadCount(o.threads), start, o.progress, [&](uint32_t y, uint64_t& rays) {
    Neighbourhood n;
    uint64_t rowRefined = 0;
    for (uint32_t x = 0; x < o.width; ++x) {
      PixelAccumulator pixel;
      for (uint32_t j = 0; j < s; ++j)
        for (uint32_t i = 0; i < s; ++i) pixel.add(sampler.sample(x * s + i, y * s + j, n, rays, rowRefined));
      pixel.store(out, size_t(y) * o.width + x, s * s);
    }
    refined.fetch_add(rowRefined);
  });
  out.refined = refined.load();
  out.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return out;
}

}  // namespace shrefract::bake
