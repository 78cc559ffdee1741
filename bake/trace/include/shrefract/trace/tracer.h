// Light paths through the media of a Scene: the pruned Fresnel tree of the technique (at every
// interface, follow the branch of higher energy), the exact per-pixel eye ray for the reference
// renderer, and the full Fresnel tree for measuring what the pruning costs. The rules (media
// labels, the cap, self-intersection offsets, determinism) are in docs/technique.md.
//
// Thread safety: a Tracer is immutable after create(); every const method may be called from any
// number of threads at once. Results depend only on the arguments (bit-identical from any thread),
// provided the calling threads share one floating-point environment (the default one, or
// flush-to-zero / denormals-are-zero set the same way everywhere).
#pragma once

#include <shrefract/assets/scene.h>
#include <shrefract/trace/surface_point.h>
#include <shrefract/field.h>
#include <shrefract/result.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace shrefract::bake {

struct TraceSettings {
  // Interfaces a path may meet after its first refraction. A path that would meet one more is
  // stopped and marked trapped (see PathResult).
  uint32_t maxBounces = 16;
  // Which branch a single path follows at every interface (field.h PathRule; docs/technique.md).
  PathRule pathRule = PathRule::HighestEnergy;
};

// Outcome of one light path, from its first refraction into the object to its escape.
struct PathResult {
  // World-space unit direction in which the path leaves toward the environment. For a trapped
  // path: the unit direction of travel when it was stopped.
  glm::vec3 exitDirection{0.0f, 0.0f, 1.0f};
  // Sum over the segments after the first refraction of length * absorption of the segment's
  // medium. For a trapped path it includes the segment to the interface it was stopped at.
  float opticalDepth = 0.0f;
  // Product of the Fresnel factors (R or 1 - R) of the branches taken after the first refraction.
  // The entry interface's own factor is the caller's (1 - frontFresnel for an eye ray).
  float energy = 1.0f;
  uint32_t interactions = 0;    // interfaces met after the first refraction
  uint32_t rays = 0;            // ray queries issued (the final, missing query included)
  uint32_t labelConflicts = 0;  // interfaces whose media labels disagreed with the path's medium
  bool trapped = false;         // stopped by TraceSettings::maxBounces (or invalid input)
};

struct EyeRayResult {
  bool hit = false;  // false: the eye ray misses everything; the other fields keep their defaults
  glm::vec3 position{0.0f};
  // Unit normal used at the front interface for Snell and Fresnel, facing the eye: the shading
  // normal, or the geometric one where the shading normal is not trusted (docs/technique.md).
  glm::vec3 shadingNormal{0.0f, 0.0f, 1.0f};
  uint32_t surface = 0;
  uint32_t triangle = 0;
  float frontFresnel = 0.0f;  // unpolarized Fresnel reflectance at the front interface (1 on TIR)
  glm::vec3 reflectedDirection{0.0f, 0.0f, 1.0f};  // unit, world space
  // The refracted path from the front interface (labelConflicts includes one for the front
  // interface when its label on the eye's side is not media[0]). On total internal reflection at
  // the front there is none: energy = 0, exitDirection = reflectedDirection, the rest at defaults.
  PathResult transmitted;
  uint32_t rays = 0;  // every query, the primary one included
};

class Tracer {
 public:
  // Validates the scene (validateScene) and builds Embree's acceleration structure. The tracer
  // copies what it needs: `scene` may be destroyed afterwards. Open or mislabelled meshes are
  // accepted (their paths report labelConflicts). Errors: InvalidArgument from validateScene or
  // from Embree's argument checks, MissingFeature when Embree does not support the CPU,
  // Unsupported for any other Embree failure (out of memory, ...).
  static Result<std::unique_ptr<Tracer>> create(const Scene& scene);
  ~Tracer();
  Tracer(const Tracer&) = delete;
  Tracer& operator=(const Tracer&) = delete;

  // A ray arriving at `point` from the outer side of its surface, travelling along `incident`
  // (world space, pointing into the surface: dot(incident, point.shadingNormal) < 0). It refracts
  // into the surface's innerMedium (reflects on total internal reflection) and then follows, at
  // every interface, the branch settings.pathRule picks (the higher energy by default) until it
  // escapes or hits settings.maxBounces.
  // point.surface must index the scene's surfaces. When point.triangle is in range, the geometric
  // normal is that triangle's and the position is projected onto its plane; otherwise
  // point.geometricNormal and point.position are used as given. A non-finite or zero incident, or
  // a surface out of range, gives a default PathResult with trapped = true.
  PathResult traceFromSurface(const SurfacePoint& point, glm::vec3 incident,
                              const TraceSettings& settings) const;
  // The same for many incident directions at one point: out[i] is traceFromSurface(point,
  // incidents[i], settings), bit for bit (out.size() must equal incidents.size()). Faster per path:
  // several paths are traced in turn, so that fetching one path's hit data from memory overlaps
  // another's ray query.
  void traceFromSurface(const SurfacePoint& point, std::span<const glm::vec3> incidents,
                        const TraceSettings& settings, std::span<PathResult> out) const;

  // A ray from the eye, starting in media[0] (direction need not be unit). Finds the first hit,
  // computes the front Fresnel reflectance and reflected direction there, and traces the
  // transmitted path as traceFromSurface does.
  EyeRayResult traceEyeRay(glm::vec3 origin, glm::vec3 direction,
                           const TraceSettings& settings) const;

  // The full Fresnel tree below the entry at `point` (same entry rule as traceFromSurface):
  // appends one PathResult per leaf to `out`, its energy being the weight of that leaf. Leaves
  // that would need more than `depth` interactions are cut there, marked trapped. Energies of
  // the leaves sum to 1; the highest-energy path of traceFromSurface with maxBounces = depth is
  // one of the leaves, bit for bit. Costs up to 2^(depth+1) - 1 ray queries. Leaves come in
  // depth-first order, reflection before refraction.
  void traceTree(const SurfacePoint& point, glm::vec3 incident, uint32_t depth,
                 std::vector<PathResult>& out) const;

  // The first surface point along a ray (direction need not be unit), or nothing on a miss.
  // Normals point toward the surface's outer medium (not flipped toward the ray).
  std::optional<SurfacePoint> firstHit(glm::vec3 origin, glm::vec3 direction) const;

  // Centre of the scene's bounding box, and the length of its diagonal.
  glm::vec3 sceneCenter() const;
  float sceneExtent() const;

 private:
  struct Impl;
  explicit Tracer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace shrefract::bake
