// Path tracing through the media of a scene with Embree 3. Rules and their reasons: docs/tracing.md.
#include <shrefract/bake/tracer.h>

#include <embree3/rtcore.h>

#include <glm/ext/vector_double3.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
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
  glm::dvec3 direction{0.0, 0.0, 1.0};  // unit
  double weight = 0.0;                  // Fresnel factor: R, or 1 - R
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
// Finally each branch is kept kMinLeaveCos away from the plane, on its own side.
Split splitAt(glm::dvec3 d, glm::dvec3 ngFacing, glm::dvec3 nsFacing, double eta) {
  std::optional<Split> split;
  if (-glm::dot(d, nsFacing) >= kGrazingCos && glm::dot(nsFacing, ngFacing) > 0.0) {
    split = evaluate(d, nsFacing, eta);
    const bool consistent = glm::dot(split->reflected.direction, ngFacing) > 0.0 &&
                            (!split->refracted || glm::dot(split->refracted->direction, ngFacing) < 0.0);
    if (!consistent) split.reset();
  }
  if (!split) {
    split = evaluate(leavePlane(d, -ngFacing, kGrazingCos), ngFacing, eta);
  }
  const auto finish = [](glm::dvec3 v, glm::dvec3 side) {
    return leavePlane(normalizeOr(v, side), side, kMinLeaveCos);
  };
  split->reflected.direction = finish(split->reflected.direction, ngFacing);
  if (split->refracted) split->refracted->direction = finish(split->refracted->direction, -ngFacing);
  return *split;
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

struct SurfaceData {
  // Positions plus one padding element: Embree reads each vertex with a 16-byte load.
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;
  std::vector<uint32_t> indices;
  std::vector<glm::vec3> faceNormals;  // unit, toward the outer medium (the winding's side)
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

PathResult invalidInput() {
  PathResult result;
  result.trapped = true;
  return result;
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

  glm::dvec3 corner(const SurfaceData& s, uint32_t triangle, uint32_t k) const {
    return glm::dvec3(s.positions[s.indices[3 * static_cast<size_t>(triangle) + k]]);
  }

  // Distance new rays start off the plane at p; `triangle` may be out of range (then only p counts).
  double offsetAt(uint32_t surface, uint32_t triangle, glm::dvec3 p) const {
    double magnitude = std::max(maxAbs(p), minMagnitude);
    double size = 0.0;
    const SurfaceData& s = surfaces[surface];
    if (triangle < s.faceNormals.size()) {
      const glm::dvec3 c0 = corner(s, triangle, 0), c1 = corner(s, triangle, 1), c2 = corner(s, triangle, 2);
      magnitude = std::max({magnitude, maxAbs(c0), maxAbs(c1), maxAbs(c2)});
      size = std::max({maxAbs(c1 - c0), maxAbs(c2 - c1), maxAbs(c0 - c2)});
    }
    return kOffsetOfMagnitude * magnitude + kOffsetOfSize * size;
  }

  // Closest hit along the ray (origin, unit direction) with tnear = 0.
  std::optional<Hit> intersect(glm::vec3 origin, glm::dvec3 direction) const {
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
    if (query.hit.geomID == RTC_INVALID_GEOMETRY_ID || query.hit.geomID >= surfaces.size()) {
      return std::nullopt;
    }

    const SurfaceData& s = surfaces[query.hit.geomID];
    const uint32_t triangle = query.hit.primID;
    // Barycentrics clamped into the triangle (Embree's may stray by rounding).
    double u = std::clamp(static_cast<double>(query.hit.u), 0.0, 1.0);
    double v = std::clamp(static_cast<double>(query.hit.v), 0.0, 1.0);
    if (u + v > 1.0) {
      const double sum = u + v;
      u /= sum;
      v /= sum;
    }
    const double w = 1.0 - u - v;
    const size_t base = 3 * static_cast<size_t>(triangle);
    const uint32_t i0 = s.indices[base], i1 = s.indices[base + 1], i2 = s.indices[base + 2];

    Hit hit;
    hit.surface = query.hit.geomID;
    hit.triangle = triangle;
    hit.position = w * glm::dvec3(s.positions[i0]) + u * glm::dvec3(s.positions[i1]) +
                   v * glm::dvec3(s.positions[i2]);
    hit.geometricNormal = glm::dvec3(s.faceNormals[triangle]);
    hit.shadingNormal = normalizeOr(w * glm::dvec3(s.normals[i0]) + u * glm::dvec3(s.normals[i1]) +
                                        v * glm::dvec3(s.normals[i2]),
                                    hit.geometricNormal);
    hit.offset = offsetAt(hit.surface, triangle, hit.position);
    return hit;
  }

  // Traces the current segment of `state`. Returns the interface it ends on; or nothing when the
  // path ends there (escaped, or stopped by the cap), with `result` set.
  std::optional<Step> advance(PathState& state, uint32_t cap, PathResult& result) const {
    ++state.rays;
    const std::optional<Hit> hit = intersect(state.origin, state.direction);
    if (!hit) {
      // Escaping from anything but the surrounding medium means an open or mislabelled mesh.
      if (state.medium != 0) ++state.labelConflicts;
      result = resultOf(state, /*trapped=*/false);
      return std::nullopt;
    }
    // The side comes from the geometric normal; the media from the surface's labels, which win
    // over the medium the path believes it is in (overlapping or mislabelled volumes).
    const SurfaceData& s = surfaces[hit->surface];
    const bool front = glm::dot(state.direction, hit->geometricNormal) < 0.0;
    Step step;
    step.hit = *hit;
    step.from = front ? s.outerMedium : s.innerMedium;
    step.to = front ? s.innerMedium : s.outerMedium;
    if (step.from != state.medium) ++state.labelConflicts;
    state.opticalDepth += glm::distance(state.position, hit->position) * media[step.from].absorption;
    if (state.interactions >= cap) {
      result = resultOf(state, /*trapped=*/true);
      return std::nullopt;
    }
    ++state.interactions;
    step.ngFacing = front ? hit->geometricNormal : -hit->geometricNormal;
    const glm::dvec3 nsFacing = front ? hit->shadingNormal : -hit->shadingNormal;
    step.split = splitAt(state.direction, step.ngFacing, nsFacing, media[step.from].ior / media[step.to].ior);
    return step;
  }

  // Continues `state` along one branch of `step`.
  static void take(PathState& state, const Step& step, bool refract, bool countWeight) {
    const Branch& branch = refract ? *step.split.refracted : step.split.reflected;
    if (countWeight) state.energy *= branch.weight;
    state.medium = refract ? step.to : step.from;
    state.position = step.hit.position;
    state.direction = branch.direction;
    const glm::dvec3 side = refract ? -step.ngFacing : step.ngFacing;
    state.origin = glm::vec3(step.hit.position + step.hit.offset * side);
  }

  static bool refractionWins(const Split& split, PathRule rule) {
    if (!split.refracted.has_value()) return false;  // total internal reflection: no choice
    return rule == PathRule::FirstRefraction || split.reflected.weight < 0.5;
  }

  PathResult follow(PathState state, const TraceSettings& settings) const {
    PathResult result;
    while (const std::optional<Step> step = advance(state, settings.maxBounces, result)) {
      take(state, *step, refractionWins(step->split, settings.pathRule), /*countWeight=*/true);
    }
    return result;
  }

  void tree(PathState state, uint32_t depth, std::vector<PathResult>& out) const {
    PathResult result;
    const std::optional<Step> step = advance(state, depth, result);
    if (!step) {
      out.push_back(result);
      return;
    }
    if (step->split.reflected.weight > 0.0) {
      PathState reflected = state;
      take(reflected, *step, /*refract=*/false, /*countWeight=*/true);
      tree(reflected, depth, out);
    }
    if (step->split.refracted && step->split.refracted->weight > 0.0) {
      take(state, *step, /*refract=*/true, /*countWeight=*/true);
      tree(state, depth, out);
    }
  }

  // The entry of traceFromSurface / traceTree: the ray arrives from the surface's outer side and
  // refracts into its inner medium (reflects on total internal reflection). The entry's Fresnel
  // factor is not counted in the energy.
  std::optional<PathState> enter(const SurfacePoint& point, glm::vec3 incident) const {
    if (point.surface >= surfaces.size() || !isFinite(incident) || !isFinite(point.position)) {
      return std::nullopt;
    }
    if (!normalizable(glm::dvec3(incident))) return std::nullopt;
    const glm::dvec3 d = glm::normalize(glm::dvec3(incident));
    const SurfaceData& s = surfaces[point.surface];
    const bool triangleValid = point.triangle < s.faceNormals.size();

    Hit hit;
    hit.surface = point.surface;
    hit.triangle = triangleValid ? point.triangle : 0;
    hit.position = glm::dvec3(point.position);
    const glm::dvec3 shading =
        isFinite(point.shadingNormal) ? glm::dvec3(point.shadingNormal) : glm::dvec3(0.0);
    glm::dvec3 geometric(0.0);
    if (triangleValid) {
      geometric = glm::dvec3(s.faceNormals[point.triangle]);
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
      const glm::dvec3 c0 = corner(s, point.triangle, 0);
      hit.position -= glm::dot(hit.position - c0, hit.geometricNormal) * hit.geometricNormal;
    }
    hit.offset = offsetAt(point.surface, point.triangle, hit.position);

    Step step;
    step.hit = hit;
    step.from = s.outerMedium;
    step.to = s.innerMedium;
    step.ngFacing = hit.geometricNormal;
    step.split = splitAt(d, hit.geometricNormal, hit.shadingNormal,
                         media[step.from].ior / media[step.to].ior);

    PathState state;
    take(state, step, /*refract=*/step.split.refracted.has_value(), /*countWeight=*/false);
    return state;
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
    out.normals = in.normals;
    out.indices = in.indices;
    out.innerMedium = in.innerMedium;
    out.outerMedium = in.outerMedium;
    const size_t triangles = in.indices.size() / 3;
    out.faceNormals.resize(triangles);
    for (size_t t = 0; t < triangles; ++t) {
      const uint32_t a = in.indices[3 * t], b = in.indices[3 * t + 1], c = in.indices[3 * t + 2];
      const glm::dvec3 p0(in.positions[a]), p1(in.positions[b]), p2(in.positions[c]);
      // Counter-clockwise seen from the outer side (the Surface contract), so this faces outward.
      // A degenerate triangle (never reported by Embree) gets its mean vertex normal, or +z.
      const glm::dvec3 normalSum =
          glm::dvec3(in.normals[a]) + glm::dvec3(in.normals[b]) + glm::dvec3(in.normals[c]);
      const glm::dvec3 mean = normalizeOr(normalSum, glm::dvec3(0.0, 0.0, 1.0));
      out.faceNormals[t] = glm::vec3(normalizeOr(glm::cross(p1 - p0, p2 - p0), mean));
    }
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
  const std::optional<PathState> state = impl_->enter(point, incident);
  if (!state) return invalidInput();
  return impl_->follow(*state, settings);
}

void Tracer::traceTree(const SurfacePoint& point, glm::vec3 incident, uint32_t depth,
                       std::vector<PathResult>& out) const {
  const std::optional<PathState> state = impl_->enter(point, incident);
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
  const std::optional<Step> step = impl_->advance(eye, 1, unused);
  if (!step) return result;

  result.hit = true;
  result.position = glm::vec3(step->hit.position);
  result.shadingNormal = glm::vec3(step->split.normal);
  result.surface = step->hit.surface;
  result.triangle = step->hit.triangle;
  result.frontFresnel = static_cast<float>(step->split.reflected.weight);
  result.reflectedDirection = glm::vec3(step->split.reflected.direction);
  if (!step->split.refracted) {
    result.transmitted.energy = 0.0f;
    result.transmitted.exitDirection = result.reflectedDirection;
    result.transmitted.labelConflicts = eye.labelConflicts;
    return result;
  }
  PathState transmitted;
  transmitted.labelConflicts = eye.labelConflicts;
  Impl::take(transmitted, *step, /*refract=*/true, /*countWeight=*/false);
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
