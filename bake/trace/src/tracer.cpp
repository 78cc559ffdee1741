// Path tracing through the media of a scene with Embree 3. Rules and their reasons: docs/technique.md.
#include <shrefract/trace/tracer.h>

#include <embree3/rtcore.h>

#include <glm/ext/vector_double3.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace shrefract::bake {
namespace {

// Self-intersection: a new ray starts from its surface point pushed off the triangle's plane, to
// the side the ray travels, by
//   kOffsetOfMagnitude * (largest |coordinate| of the point and the triangle's corners)
//   + kOffsetOfSize * (largest coordinate extent of the triangle's edges),
// and tnear = 0. The first term is 4 to 8 float ulps of the coordinates: the point lies on the
// triangle's plane in double (interpolated from the corners, or projected onto the plane for a
// caller's point) and is rounded to float once, which moves it off the plane by at most 0.87 ulp.
// The second term covers Embree's watertight test, which subtracts the origin from the corners
// (exactly, for nearby floats) and then resolves the plane distance to a few ulps of the
// triangle's size; 2^-18 of the size is 16 times that. Measured (tracer_test, NoSelfIntersection):
// offsets of 2^-24 of the magnitude fail, 2^-23 pass. The push is about 5e-7 of the coordinates,
// so shells down to about 1e-5 of the object's size are crossed properly, and an object far from
// the origin moves by a few ulps of its position, not by a fraction of its size.
constexpr double kOffsetOfMagnitude = 0x1p-21;
constexpr double kOffsetOfSize = 0x1p-18;
// Floor of the magnitude above, relative to the scene's extent (only matters at the origin).
constexpr double kMinMagnitudeOfExtent = 1e-6;
// Below this cosine between the direction and the shading normal (facing the ray), the shading
// normal is not trusted: the ray grazes the smooth surface or arrives from behind it.
constexpr double kGrazingCos = 1e-6;
// Every outgoing ray leaves the triangle's plane at a cosine of at least this (2^-16): far above
// the rounding of Embree's float plane test, so the new ray never starts "parallel" to its plane.
constexpr double kMinLeaveCos = 0x1p-16;
// Paths the batch traceFromSurface keeps in flight (followAll): from 1 to 4 the tracer's time
// over a bare Embree loop on the bunny fell from 1.53 to 1.28; 8 and 16 were no better, 32 worse
// (docs/performance.md, "Bake").
constexpr size_t kPathsInFlight = 4;

bool isFinite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

double maxAbs(glm::dvec3 v) { return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}); }

// v / |v|, or `fallback` when v is zero or not finite.
glm::dvec3 normalizeOr(glm::dvec3 v, glm::dvec3 fallback) {
  const double length = glm::length(v);
  if (!(length > 0.0) || !std::isfinite(length)) return fallback;
  return v / length;
}

// Whether normalizeOr(v, ...) normalizes v.
bool normalizable(glm::dvec3 v) {
  const double length = glm::length(v);
  return length > 0.0 && std::isfinite(length);
}

// `d` (unit) turned, if needed, so that dot(d, m) >= minCos for the unit normal m: its component
// along m is raised to minCos and its tangential part kept in direction. A finite unit result.
glm::dvec3 leavePlane(glm::dvec3 d, glm::dvec3 m, double minCos) {
  const double c = glm::dot(d, m);
  if (c >= minCos) return d;
  const glm::dvec3 tangential = d - c * m;
  const double length = glm::length(tangential);
  if (!(length > 1e-12)) return m;
  return tangential * (std::sqrt(1.0 - minCos * minCos) / length) + minCos * m;
}

// Exact unpolarized dielectric Fresnel reflectance for cos(incidence) and eta = n_from / n_to.
struct Fresnel {
  double reflectance = 1.0;
  double cosT = 0.0;  // cosine of the refraction angle; meaningless on total internal reflection
  bool total = true;  // total internal reflection
};

Fresnel fresnel(double cosI, double eta) {
  const double sin2T = eta * eta * std::max(0.0, 1.0 - cosI * cosI);
  if (sin2T >= 1.0) return {};
  const double cosT = std::sqrt(1.0 - sin2T);
  // Divided through by n_to. Both denominators vanish only when cosI = cosT = 0, i.e. sin2T = 1.
  const double rs = (eta * cosI - cosT) / (eta * cosI + cosT);
  const double rp = (cosI - eta * cosT) / (cosI + eta * cosT);
  return {std::clamp(0.5 * (rs * rs + rp * rp), 0.0, 1.0), cosT, false};
}

struct Branch {
  // Not yet unit nor kept off the plane: see finishedDirection.
  glm::dvec3 direction{0.0, 0.0, 1.0};
  double weight = 0.0;  // Fresnel factor: R, or 1 - R
};

// Both branches at one interface.
struct Split {
  glm::dvec3 normal{0.0, 0.0, 1.0};  // unit normal used for Snell and Fresnel, facing the ray
  Branch reflected;                  // weight R (1 on total internal reflection)
  std::optional<Branch> refracted;   // absent on total internal reflection; weight 1 - R
};

Split evaluate(glm::dvec3 d, glm::dvec3 n, double eta) {
  const double cosI = std::clamp(-glm::dot(d, n), 0.0, 1.0);
  const Fresnel f = fresnel(cosI, eta);
  Split split;
  split.normal = n;
  split.reflected = {d + 2.0 * cosI * n, f.reflectance};
  if (!f.total) {
    split.refracted = Branch{eta * d + (eta * cosI - f.cosT) * n, 1.0 - f.reflectance};
  }
  return split;
}

// The interface rule. `d` is the unit direction of the arriving ray, ngFacing the unit geometric
// normal and nsFacing the unit shading normal, both flipped to the side the ray comes from.
// The shading normal is used unless the ray grazes or crosses it (cosine below kGrazingCos), it
// lies in the other hemisphere than the geometric normal, or it would send a branch to the wrong
// side of the triangle's plane (reflection behind it, refraction in front of it): then the
// geometric normal is used for both branches, after lifting a grazing `d` to cosine kGrazingCos.
// Each branch is then kept kMinLeaveCos away from the plane, on its own side (finishedDirection).
Split splitAt(glm::dvec3 d, glm::dvec3 ngFacing, glm::dvec3 nsFacing, double eta) {
  if (-glm::dot(d, nsFacing) >= kGrazingCos && glm::dot(nsFacing, ngFacing) > 0.0) {
    const Split split = evaluate(d, nsFacing, eta);
    const bool consistent = glm::dot(split.reflected.direction, ngFacing) > 0.0 &&
                            (!split.refracted || glm::dot(split.refracted->direction, ngFacing) < 0.0);
    if (consistent) return split;
  }
  return evaluate(leavePlane(d, -ngFacing, kGrazingCos), ngFacing, eta);
}

// The unit direction of one branch of a split at a plane of facing normal ngFacing, at least
// kMinLeaveCos off the plane on its own side. Done only for the branch a path takes (both in
// traceTree), which saves a square root and three divisions per interface.
glm::dvec3 finishedDirection(const Split& split, bool refract, glm::dvec3 ngFacing) {
  const glm::dvec3 side = refract ? -ngFacing : ngFacing;
  const glm::dvec3 v = refract ? split.refracted->direction : split.reflected.direction;
  return leavePlane(normalizeOr(v, side), side, kMinLeaveCos);
}

// First error reported by Embree through the device's error callback.
struct ErrorSink {
  std::mutex mutex;
  std::optional<Error> first;
};

void recordEmbreeError(void* user, RTCError code, const char* message) {
  auto* sink = static_cast<ErrorSink*>(user);
  ErrorCode ours = ErrorCode::Unsupported;
  const char* name = "error";
  switch (code) {
    case RTC_ERROR_NONE: return;
    case RTC_ERROR_INVALID_ARGUMENT: ours = ErrorCode::InvalidArgument; name = "invalid argument"; break;
    case RTC_ERROR_INVALID_OPERATION: ours = ErrorCode::InvalidArgument; name = "invalid operation"; break;
    case RTC_ERROR_UNSUPPORTED_CPU: ours = ErrorCode::MissingFeature; name = "unsupported CPU"; break;
    case RTC_ERROR_OUT_OF_MEMORY: name = "out of memory"; break;
    case RTC_ERROR_CANCELLED: name = "cancelled"; break;
    case RTC_ERROR_UNKNOWN: name = "unknown error"; break;
  }
  std::lock_guard lock(sink->mutex);
  if (!sink->first) {
    sink->first = makeError(ours, std::string("Embree: ") + name + ": " + (message ? message : ""));
  }
}

// Everything a hit on one triangle reads, in one 96-byte record: looking a hit up through the
// index buffer into the position and normal buffers was a chain of dependent cache misses, about
// 40% of Tracer::traceFromSurface's own perf samples on the bunny (docs/performance.md, "Bake").
struct TriangleData {
  std::array<glm::vec3, 3> corners{};
  std::array<glm::vec3, 3> normals{};  // the corners' vertex normals
  glm::vec3 faceNormal{0.0f, 0.0f, 1.0f};  // unit, toward the outer medium (the winding's side)
  float cornerMagnitude = 0.0f;  // largest |coordinate| of the corners
  double sizeOffset = 0.0;       // kOffsetOfSize * (largest coordinate extent of the edges)
};

struct SurfaceData {
  // Embree's buffers: positions plus one padding element (Embree reads each vertex with a 16-byte
  // load), and indices.
  std::vector<glm::vec3> positions;
  std::vector<uint32_t> indices;
  std::vector<TriangleData> triangles;
  uint32_t innerMedium = 1;
  uint32_t outerMedium = 0;
};

struct MediumData {
  double ior = 1.0;
  double absorption = 0.0;
};

// An interface hit, with everything computed in double from the stored triangle.
struct Hit {
  glm::dvec3 position{0.0};
  glm::dvec3 geometricNormal{0.0, 0.0, 1.0};  // unit, toward the outer medium
  glm::dvec3 shadingNormal{0.0, 0.0, 1.0};    // unit, toward the outer medium
  uint32_t surface = 0;
  uint32_t triangle = 0;
  double offset = 0.0;  // distance new rays start off the plane
};

// What Embree reports of a hit (geomID RTC_INVALID_GEOMETRY_ID on a miss).
struct RawHit {
  unsigned geomID = RTC_INVALID_GEOMETRY_ID;
  unsigned primID = 0;
  float u = 0.0f, v = 0.0f;
};

// The state of a path between two interfaces.
struct PathState {
  glm::dvec3 position{0.0};  // start of the current segment, on a surface
  glm::vec3 origin{0.0f};    // the ray origin: position pushed off the surface toward the ray
  glm::dvec3 direction{0.0, 0.0, 1.0};  // unit
  uint32_t medium = 0;
  double energy = 1.0;
  double opticalDepth = 0.0;
  uint32_t interactions = 0;
  uint32_t rays = 0;
  uint32_t labelConflicts = 0;
};

// An interface met by a path, with the media on both sides as the surface's labels say.
struct Step {
  Hit hit;
  uint32_t from = 0;  // medium the ray arrives from
  uint32_t to = 0;    // medium behind the interface
  glm::dvec3 ngFacing{0.0, 0.0, 1.0};  // geometric normal on the side the ray comes from
  Split split;
};

PathResult resultOf(const PathState& state, bool trapped) {
  PathResult result;
  result.exitDirection = glm::vec3(state.direction);
  result.opticalDepth = static_cast<float>(state.opticalDepth);
  result.energy = static_cast<float>(state.energy);
  result.interactions = state.interactions;
  result.rays = state.rays;
  result.labelConflicts = state.labelConflicts;
  result.trapped = trapped;
  return result;
}

// Starts fetching a hit's triangle record (both of its cache lines) into the cache.
void prefetch(const TriangleData* record) {
  if (!record) return;
  __builtin_prefetch(record);
  __builtin_prefetch(reinterpret_cast<const char*>(record) + sizeof(TriangleData) - 1);
}

PathResult invalidInput() {
  PathResult result;
  result.trapped = true;
  return result;
}

TriangleData triangleData(const Surface& surface, size_t triangle) {
  TriangleData t;
  for (size_t k = 0; k < 3; ++k) {
    const uint32_t vertex = surface.indices[3 * triangle + k];
    t.corners[k] = surface.positions[vertex];
    t.normals[k] = surface.normals[vertex];
  }
  const glm::dvec3 p0(t.corners[0]), p1(t.corners[1]), p2(t.corners[2]);
  // Counter-clockwise seen from the outer side (the Surface contract), so this faces outward.
  // A degenerate triangle (never reported by Embree) gets its mean vertex normal, or +z.
  const glm::dvec3 normalSum = glm::dvec3(t.normals[0]) + glm::dvec3(t.normals[1]) + glm::dvec3(t.normals[2]);
  const glm::dvec3 mean = normalizeOr(normalSum, glm::dvec3(0.0, 0.0, 1.0));
  t.faceNormal = glm::vec3(normalizeOr(glm::cross(p1 - p0, p2 - p0), mean));
  // Exact: the largest |coordinate| of floats is one of them.
  t.cornerMagnitude = static_cast<float>(std::max({maxAbs(p0), maxAbs(p1), maxAbs(p2)}));
  t.sizeOffset = kOffsetOfSize * std::max({maxAbs(p1 - p0), maxAbs(p2 - p1), maxAbs(p0 - p2)});
  return t;
}

}  // namespace

struct Tracer::Impl {
  std::vector<MediumData> media;
  std::vector<SurfaceData> surfaces;
  glm::vec3 center{0.0f};
  float extent = 0.0f;
  double minMagnitude = 0.0;
  std::unique_ptr<ErrorSink> errors = std::make_unique<ErrorSink>();
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;

  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }

  std::optional<Error> firstError() const {
    std::lock_guard lock(errors->mutex);
    return errors->first;
  }

  // Distance new rays start off the plane at p; `triangle` may be out of range (then only p counts).
  double offsetAt(const SurfaceData& s, uint32_t triangle, glm::dvec3 p) const {
    const double magnitude = std::max(maxAbs(p), minMagnitude);
    if (triangle >= s.triangles.size()) return kOffsetOfMagnitude * magnitude;
    const TriangleData& t = s.triangles[triangle];
    return kOffsetOfMagnitude * std::max(magnitude, static_cast<double>(t.cornerMagnitude)) + t.sizeOffset;
  }

  // Closest hit along the ray (origin, unit direction) with tnear = 0.
  std::optional<Hit> intersect(glm::vec3 origin, glm::dvec3 direction) const {
    Hit hit;
    if (!hitOf(query(origin, direction), hit)) return std::nullopt;
    return hit;
  }

  // Embree's closest hit along the ray (origin, unit direction) with tnear = 0.
  RawHit query(glm::vec3 origin, glm::dvec3 direction) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    const glm::vec3 dir(direction);
    RTCRayHit query{};
    query.ray.org_x = origin.x;
    query.ray.org_y = origin.y;
    query.ray.org_z = origin.z;
    query.ray.tnear = 0.0f;
    query.ray.dir_x = dir.x;
    query.ray.dir_y = dir.y;
    query.ray.dir_z = dir.z;
    query.ray.time = 0.0f;
    query.ray.tfar = std::numeric_limits<float>::infinity();
    query.ray.mask = ~0u;
    query.ray.id = 0;
    query.ray.flags = 0;
    query.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    query.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &context, &query);
    return {query.hit.geomID, query.hit.primID, query.hit.u, query.hit.v};
  }

  // The record a hit will read, or null on a miss.
  const TriangleData* recordOf(const RawHit& raw) const {
    if (raw.geomID == RTC_INVALID_GEOMETRY_ID || raw.geomID >= surfaces.size()) return nullptr;
    const SurfaceData& s = surfaces[raw.geomID];
    return raw.primID < s.triangles.size() ? &s.triangles[raw.primID] : nullptr;
  }

  // The hit Embree reported, computed in double from the stored triangle, into `hit` (false on a
  // miss). Here and in land the result goes into the caller's object: returning it in a
  // std::optional copied the Hit and then the Step on every ray.
  bool hitOf(const RawHit& raw, Hit& hit) const {
    if (!recordOf(raw)) return false;
    const SurfaceData& s = surfaces[raw.geomID];
    const uint32_t triangle = raw.primID;
    // Barycentrics clamped into the triangle (Embree's may stray by rounding).
    double u = std::clamp(static_cast<double>(raw.u), 0.0, 1.0);
    double v = std::clamp(static_cast<double>(raw.v), 0.0, 1.0);
    if (u + v > 1.0) {
      const double sum = u + v;
      u /= sum;
      v /= sum;
    }
    const double w = 1.0 - u - v;
    const TriangleData& t = s.triangles[triangle];

    hit.surface = raw.geomID;
    hit.triangle = triangle;
    hit.position = w * glm::dvec3(t.corners[0]) + u * glm::dvec3(t.corners[1]) + v * glm::dvec3(t.corners[2]);
    hit.geometricNormal = glm::dvec3(t.faceNormal);
    hit.shadingNormal = normalizeOr(w * glm::dvec3(t.normals[0]) + u * glm::dvec3(t.normals[1]) +
                                        v * glm::dvec3(t.normals[2]),
                                    hit.geometricNormal);
    hit.offset = offsetAt(s, triangle, hit.position);
    return true;
  }

  // Traces the current segment of `state`. Returns true with the interface it ends on in `step`;
  // false when the path ends there (escaped, or stopped by the cap), with `result` set.
  bool advance(PathState& state, uint32_t cap, PathResult& result, Step& step) const {
    ++state.rays;
    return land(state, query(state.origin, state.direction), cap, result, step);
  }

  // The second half of advance: the interface at the end of the segment Embree traced (`raw`).
  bool land(PathState& state, const RawHit& raw, uint32_t cap, PathResult& result, Step& step) const {
    Hit& hit = step.hit;
    if (!hitOf(raw, hit)) {
      // Escaping from anything but the surrounding medium means an open or mislabelled mesh.
      if (state.medium != 0) ++state.labelConflicts;
      result = resultOf(state, /*trapped=*/false);
      return false;
    }
    // The side comes from the geometric normal; the media from the surface's labels, which win
    // over the medium the path believes it is in (overlapping or mislabelled volumes).
    const SurfaceData& s = surfaces[hit.surface];
    const bool front = glm::dot(state.direction, hit.geometricNormal) < 0.0;
    step.from = front ? s.outerMedium : s.innerMedium;
    step.to = front ? s.innerMedium : s.outerMedium;
    if (step.from != state.medium) ++state.labelConflicts;
    // Adding length * 0 changes nothing: the square root is skipped in clear media.
    if (const double absorption = media[step.from].absorption; absorption != 0.0) {
      state.opticalDepth += glm::distance(state.position, hit.position) * absorption;
    }
    if (state.interactions >= cap) {
      result = resultOf(state, /*trapped=*/true);
      return false;
    }
    ++state.interactions;
    step.ngFacing = front ? hit.geometricNormal : -hit.geometricNormal;
    const glm::dvec3 nsFacing = front ? hit.shadingNormal : -hit.shadingNormal;
    step.split = splitAt(state.direction, step.ngFacing, nsFacing, media[step.from].ior / media[step.to].ior);
    return true;
  }

  // Continues `state` along one branch of `step`.
  static void take(PathState& state, const Step& step, bool refract, bool countWeight) {
    const Branch& branch = refract ? *step.split.refracted : step.split.reflected;
    if (countWeight) state.energy *= branch.weight;
    state.medium = refract ? step.to : step.from;
    state.position = step.hit.position;
    state.direction = finishedDirection(step.split, refract, step.ngFacing);
    const glm::dvec3 side = refract ? -step.ngFacing : step.ngFacing;
    state.origin = glm::vec3(step.hit.position + step.hit.offset * side);
  }

  static bool refractionWins(const Split& split, PathRule rule) {
    if (!split.refracted.has_value()) return false;  // total internal reflection: no choice
    return rule == PathRule::FirstRefraction || split.reflected.weight < 0.5;
  }

  PathResult follow(PathState state, const TraceSettings& settings) const {
    PathResult result;
    Step step;
    while (advance(state, settings.maxBounces, result, step)) {
      take(state, step, refractionWins(step.split, settings.pathRule), /*countWeight=*/true);
    }
    return result;
  }

  void tree(PathState state, uint32_t depth, std::vector<PathResult>& out) const {
    PathResult result;
    Step step;
    if (!advance(state, depth, result, step)) {
      out.push_back(result);
      return;
    }
    if (step.split.reflected.weight > 0.0) {
      PathState reflected = state;
      take(reflected, step, /*refract=*/false, /*countWeight=*/true);
      tree(reflected, depth, out);
    }
    if (step.split.refracted && step.split.refracted->weight > 0.0) {
      take(state, step, /*refract=*/true, /*countWeight=*/true);
      tree(state, depth, out);
    }
  }

  // The entry interface of traceFromSurface / traceTree at a caller's point, the same for every
  // incident direction there; nothing for an invalid point.
  std::optional<Hit> entryHit(const SurfacePoint& point) const {
    if (point.surface >= surfaces.size() || !isFinite(point.position)) return std::nullopt;
    const SurfaceData& s = surfaces[point.surface];
    const bool triangleValid = point.triangle < s.triangles.size();

    Hit hit;
    hit.surface = point.surface;
    hit.triangle = triangleValid ? point.triangle : 0;
    hit.position = glm::dvec3(point.position);
    const glm::dvec3 shading =
        isFinite(point.shadingNormal) ? glm::dvec3(point.shadingNormal) : glm::dvec3(0.0);
    glm::dvec3 geometric(0.0);
    if (triangleValid) {
      geometric = glm::dvec3(s.triangles[point.triangle].faceNormal);
    } else if (isFinite(point.geometricNormal)) {
      geometric = glm::dvec3(point.geometricNormal);
    }
    if (!normalizable(geometric)) geometric = shading;
    if (!normalizable(geometric)) return std::nullopt;
    hit.geometricNormal = glm::normalize(geometric);
    hit.shadingNormal = normalizeOr(shading, hit.geometricNormal);
    if (triangleValid) {
      // Onto the triangle's plane, in double: a point interpolated in float may be several ulps off
      // it, which the self-intersection offset does not budget for.
      const glm::dvec3 c0(s.triangles[point.triangle].corners[0]);
      hit.position -= glm::dot(hit.position - c0, hit.geometricNormal) * hit.geometricNormal;
    }
    hit.offset = offsetAt(s, point.triangle, hit.position);
    return hit;
  }

  // The ray arrives at `entry` from the surface's outer side and refracts into its inner medium
  // (reflects on total internal reflection). The entry's Fresnel factor is not counted in the
  // energy. Nothing for an invalid incident direction.
  std::optional<PathState> enter(const Hit& entry, glm::vec3 incident) const {
    if (!isFinite(incident) || !normalizable(glm::dvec3(incident))) return std::nullopt;
    const glm::dvec3 d = glm::normalize(glm::dvec3(incident));
    const SurfaceData& s = surfaces[entry.surface];
    Step step;
    step.hit = entry;
    step.from = s.outerMedium;
    step.to = s.innerMedium;
    step.ngFacing = entry.geometricNormal;
    step.split = splitAt(d, entry.geometricNormal, entry.shadingNormal, media[step.from].ior / media[step.to].ior);

    PathState state;
    take(state, step, /*refract=*/step.split.refracted.has_value(), /*countWeight=*/false);
    return state;
  }

  // The paths from `entry` along every incident direction, out[i] for incidents[i], as follow
  // traces them one at a time, bit for bit. kPathsInFlight paths advance in turn: every segment's
  // triangle record is prefetched as soon as Embree names it and read only after the other paths'
  // queries, so its cache miss overlaps their tracing instead of stalling this path.
  void followAll(const Hit& entry, std::span<const glm::vec3> incidents, const TraceSettings& settings,
                 std::span<PathResult> out) const {
    struct Lane {
      PathState state;
      size_t path = 0;
      RawHit raw;
    };
    std::array<Lane, kPathsInFlight> lanes;
    size_t next = 0;
    // Puts the next path with a valid incident direction into `lane`; false when none is left.
    const auto start = [&](Lane& lane) {
      for (; next < incidents.size(); ++next) {
        if (std::optional<PathState> state = enter(entry, incidents[next])) {
          lane.state = *state;
          lane.path = next++;
          return true;
        }
        out[next] = invalidInput();
      }
      return false;
    };
    size_t active = 0;
    while (active < lanes.size() && start(lanes[active])) ++active;
    Step step;
    while (active > 0) {
      for (size_t k = 0; k < active; ++k) {
        Lane& lane = lanes[k];
        ++lane.state.rays;
        lane.raw = query(lane.state.origin, lane.state.direction);
        prefetch(recordOf(lane.raw));
      }
      for (size_t k = 0; k < active;) {
        Lane& lane = lanes[k];
        if (land(lane.state, lane.raw, settings.maxBounces, out[lane.path], step)) {
          take(lane.state, step, refractionWins(step.split, settings.pathRule), /*countWeight=*/true);
          ++k;
        } else if (start(lane)) {
          ++k;
        } else {
          lane = lanes[--active];  // the last lane, not yet landed in this round, takes its place
        }
      }
    }
  }
};

Tracer::Tracer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Tracer::~Tracer() = default;

Result<std::unique_ptr<Tracer>> Tracer::create(const Scene& scene) {
  if (Result<void> valid = validateScene(scene); !valid) return valid.error();

  auto impl = std::make_unique<Impl>();
  for (const Medium& m : scene.media) {
    impl->media.push_back({static_cast<double>(m.ior), static_cast<double>(m.absorption)});
  }
  const Bounds box = bounds(scene);
  impl->center = 0.5f * (box.min + box.max);
  impl->extent = glm::length(box.max - box.min);
  impl->minMagnitude = std::max(kMinMagnitudeOfExtent * static_cast<double>(impl->extent),
                                static_cast<double>(std::numeric_limits<float>::min()));

  impl->surfaces.resize(scene.surfaces.size());
  for (size_t i = 0; i < scene.surfaces.size(); ++i) {
    const Surface& in = scene.surfaces[i];
    SurfaceData& out = impl->surfaces[i];
    out.positions = in.positions;
    out.positions.push_back(glm::vec3(0.0f));  // padding for Embree's 16-byte vertex loads
    out.indices = in.indices;
    out.innerMedium = in.innerMedium;
    out.outerMedium = in.outerMedium;
    out.triangles.resize(in.indices.size() / 3);
    for (size_t t = 0; t < out.triangles.size(); ++t) out.triangles[t] = triangleData(in, t);
  }

  // No "threads=N": with TBB tasking, Embree turns it into a process-wide tbb::global_control.
  impl->device = rtcNewDevice("ignore_config_files=1");
  if (!impl->device) {
    recordEmbreeError(impl->errors.get(), rtcGetDeviceError(nullptr), "rtcNewDevice failed");
    return impl->firstError().value_or(makeError(ErrorCode::Unsupported, "Embree: rtcNewDevice failed"));
  }
  rtcSetDeviceErrorFunction(impl->device, recordEmbreeError, impl->errors.get());

  impl->scene = rtcNewScene(impl->device);
  if (!impl->scene) {
    return impl->firstError().value_or(makeError(ErrorCode::Unsupported, "Embree: rtcNewScene failed"));
  }
  rtcSetSceneFlags(impl->scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(impl->scene, RTC_BUILD_QUALITY_HIGH);
  for (size_t i = 0; i < impl->surfaces.size(); ++i) {
    SurfaceData& s = impl->surfaces[i];
    RTCGeometry geometry = rtcNewGeometry(impl->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!geometry) {
      return impl->firstError().value_or(makeError(ErrorCode::Unsupported, "Embree: rtcNewGeometry failed"));
    }
    rtcSetGeometryBuildQuality(geometry, RTC_BUILD_QUALITY_HIGH);
    rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, s.positions.data(), 0,
                               sizeof(glm::vec3), s.positions.size() - 1);
    rtcSetSharedGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, s.indices.data(), 0,
                               3 * sizeof(uint32_t), s.indices.size() / 3);
    rtcCommitGeometry(geometry);
    rtcAttachGeometryByID(impl->scene, geometry, static_cast<unsigned int>(i));  // geomID = surface
    rtcReleaseGeometry(geometry);
  }
  if (std::optional<Error> error = impl->firstError()) return *error;
  rtcCommitScene(impl->scene);
  if (std::optional<Error> error = impl->firstError()) return *error;
  return std::unique_ptr<Tracer>(new Tracer(std::move(impl)));
}

PathResult Tracer::traceFromSurface(const SurfacePoint& point, glm::vec3 incident,
                                    const TraceSettings& settings) const {
  const std::optional<Hit> entry = impl_->entryHit(point);
  const std::optional<PathState> state = entry ? impl_->enter(*entry, incident) : std::nullopt;
  if (!state) return invalidInput();
  return impl_->follow(*state, settings);
}

void Tracer::traceFromSurface(const SurfacePoint& point, std::span<const glm::vec3> incidents,
                              const TraceSettings& settings, std::span<PathResult> out) const {
  assert(out.size() == incidents.size());
  incidents = incidents.first(std::min(incidents.size(), out.size()));
  if (const std::optional<Hit> entry = impl_->entryHit(point)) {
    impl_->followAll(*entry, incidents, settings, out);
  } else {
    std::fill(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(incidents.size()), invalidInput());
  }
}

void Tracer::traceTree(const SurfacePoint& point, glm::vec3 incident, uint32_t depth,
                       std::vector<PathResult>& out) const {
  const std::optional<Hit> entry = impl_->entryHit(point);
  const std::optional<PathState> state = entry ? impl_->enter(*entry, incident) : std::nullopt;
  if (!state) {
    out.push_back(invalidInput());
    return;
  }
  impl_->tree(*state, depth, out);
}

EyeRayResult Tracer::traceEyeRay(glm::vec3 origin, glm::vec3 direction,
                                 const TraceSettings& settings) const {
  EyeRayResult result;
  if (!isFinite(origin) || !isFinite(direction) || !normalizable(glm::dvec3(direction))) return result;
  const glm::dvec3 d = glm::normalize(glm::dvec3(direction));
  result.rays = 1;
  PathState eye;
  eye.position = glm::dvec3(origin);
  eye.origin = origin;
  eye.direction = d;
  eye.medium = 0;
  PathResult unused;
  // The front interface is always evaluated (cap = 1) and not counted in the transmitted path.
  Step step;
  if (!impl_->advance(eye, 1, unused, step)) return result;

  result.hit = true;
  result.position = glm::vec3(step.hit.position);
  result.shadingNormal = glm::vec3(step.split.normal);
  result.surface = step.hit.surface;
  result.triangle = step.hit.triangle;
  result.frontFresnel = static_cast<float>(step.split.reflected.weight);
  result.reflectedDirection = glm::vec3(finishedDirection(step.split, /*refract=*/false, step.ngFacing));
  if (!step.split.refracted) {
    result.transmitted.energy = 0.0f;
    result.transmitted.exitDirection = result.reflectedDirection;
    result.transmitted.labelConflicts = eye.labelConflicts;
    return result;
  }
  PathState transmitted;
  transmitted.labelConflicts = eye.labelConflicts;
  Impl::take(transmitted, step, /*refract=*/true, /*countWeight=*/false);
  result.transmitted = impl_->follow(transmitted, settings);
  result.rays += result.transmitted.rays;
  return result;
}

std::optional<SurfacePoint> Tracer::firstHit(glm::vec3 origin, glm::vec3 direction) const {
  if (!isFinite(origin) || !isFinite(direction) || !normalizable(glm::dvec3(direction))) return std::nullopt;
  const std::optional<Hit> hit = impl_->intersect(origin, glm::normalize(glm::dvec3(direction)));
  if (!hit) return std::nullopt;
  SurfacePoint point;
  point.position = glm::vec3(hit->position);
  point.shadingNormal = glm::vec3(hit->shadingNormal);
  point.geometricNormal = glm::vec3(hit->geometricNormal);
  point.surface = hit->surface;
  point.triangle = hit->triangle;
  return point;
}

glm::vec3 Tracer::sceneCenter() const { return impl_->center; }
float Tracer::sceneExtent() const { return impl_->extent; }

}  // namespace shrefract::bake
