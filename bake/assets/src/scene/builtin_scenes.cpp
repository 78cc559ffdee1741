// Built-in scenes: analytic shapes whose volumes and normals the tests can check, and a glass of
// water for nested media. Dimensions and media are documented in docs/scenes.md.
#include <shrefract/assets/scene.h>

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace shrefract::bake {
namespace {

constexpr const char* kSphere = "sphere";
constexpr const char* kCube = "cube";
constexpr const char* kTorus = "torus";
constexpr const char* kGlassOfWater = "glass-of-water";

Medium air() { return Medium{"air", 1.0f, 0.0f, glm::vec3(1.0f)}; }
// Slightly green, like soda-lime glass seen through its edge.
// Absorption per unit length in natural units (exp(-tau)): 0.1 ln 2 and 0.3 ln 2, which keep the
// look the scenes had when the renderer used exp2 (0.1 and 0.3 then).
Medium glass() { return Medium{"glass", 1.5f, 0.1f * std::numbers::ln2_v<float>, glm::vec3(0.92f, 0.97f, 0.95f)}; }
Medium water() { return Medium{"water", 1.33f, 0.3f * std::numbers::ln2_v<float>, glm::vec3(0.70f, 0.90f, 0.95f)}; }

// Appends vertices and triangles to one surface.
class SurfaceBuilder {
 public:
  explicit SurfaceBuilder(Surface& surface) : surface_(surface) {}

  uint32_t vertex(glm::vec3 position, glm::vec3 normal) {
    surface_.positions.push_back(position);
    surface_.normals.push_back(normal);
    return static_cast<uint32_t>(surface_.positions.size() - 1);
  }
  // Corners counter-clockwise seen from the side the surface normal points to.
  void triangle(uint32_t a, uint32_t b, uint32_t c) {
    surface_.indices.insert(surface_.indices.end(), {a, b, c});
  }
  // Triangle whose corners are counter-clockwise when `flip` is false, clockwise when true.
  void triangle(uint32_t a, uint32_t b, uint32_t c, bool flip) {
    if (flip) {
      triangle(a, c, b);
    } else {
      triangle(a, b, c);
    }
  }

 private:
  Surface& surface_;
};

// An empty surface between two media (indices into Scene::media).
Surface surfaceBetween(std::string name, uint32_t innerMedium, uint32_t outerMedium) {
  Surface surface;
  surface.name = std::move(name);
  surface.innerMedium = innerMedium;
  surface.outerMedium = outerMedium;
  return surface;
}

// t-th of n steps from a to b, returning a and b exactly at the ends so that vertices shared
// between surfaces (or between the parts of one surface) are bitwise identical.
float lerpExact(float a, float b, int t, int n) {
  if (t <= 0) return a;
  if (t >= n) return b;
  return a + (b - a) * (static_cast<float>(t) / static_cast<float>(n));
}

// --- sphere: subdivided icosahedron --------------------------------------------------------------

Surface makeSphereSurface(int level) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  std::vector<glm::vec3> positions = {
      {-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
      {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (glm::vec3& p : positions) {
    p = glm::normalize(p);
  }
  std::vector<uint32_t> indices = {0, 11, 5, 0, 5,  1,  0,  1,  7,  0,  7,  10, 0, 10, 11,
                                   1, 5,  9, 5, 11, 4,  11, 10, 2,  10, 7,  6,  7, 1,  8,
                                   3, 9,  4, 3, 4,  2,  3,  2,  6,  3,  6,  8,  3, 8,  9,
                                   4, 9,  5, 2, 4,  11, 6,  2,  10, 8,  6,  7,  9, 8,  1};
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoints;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      auto [it, inserted] = midpoints.try_emplace(key, static_cast<uint32_t>(positions.size()));
      if (inserted) {
        positions.push_back(glm::normalize(positions[a] + positions[b]));
      }
      return it->second;
    };
    std::vector<uint32_t> next;
    next.reserve(indices.size() * 4);
    for (size_t i = 0; i < indices.size(); i += 3) {
      const uint32_t a = indices[i], b = indices[i + 1], c = indices[i + 2];
      const uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      next.insert(next.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    indices = std::move(next);
  }
  Surface surface = surfaceBetween("sphere", 1, 0);
  surface.normals = positions;  // unit sphere: the normal is the position
  surface.positions = std::move(positions);
  surface.indices = std::move(indices);
  return surface;
}

// --- cube: six faces, each with its own vertices ---------------------------------------------------

Surface makeCubeSurface(int level) {
  const int n = 1 << level;  // quads per edge; a power of two, so every coordinate is exact
  struct Face {
    glm::vec3 normal, u, v;  // u x v = normal, so (u, v) is counter-clockwise seen from outside
  };
  const std::array<Face, 6> faces = {{
      {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
      {{-1, 0, 0}, {0, 0, 1}, {0, 1, 0}},
      {{0, 1, 0}, {0, 0, 1}, {1, 0, 0}},
      {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}},
      {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}},
      {{0, 0, -1}, {0, 1, 0}, {1, 0, 0}},
  }};
  Surface surface = surfaceBetween("cube", 1, 0);
  SurfaceBuilder builder(surface);
  for (const Face& face : faces) {
    const uint32_t first = static_cast<uint32_t>(surface.positions.size());
    for (int j = 0; j <= n; ++j) {
      for (int i = 0; i <= n; ++i) {
        const float a = lerpExact(-1.0f, 1.0f, i, n);
        const float b = lerpExact(-1.0f, 1.0f, j, n);
        builder.vertex(face.normal + a * face.u + b * face.v, face.normal);
      }
    }
    const auto at = [&](int i, int j) { return first + static_cast<uint32_t>(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        builder.triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1));
        builder.triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1));
      }
    }
  }
  return surface;
}

// --- torus around the y axis ------------------------------------------------------------------------

Surface makeTorusSurface(int level) {
  constexpr float kMajor = 1.0f;
  constexpr float kMinor = 0.35f;
  const int major = 8 << level;  // segments around the y axis
  const int minor = 4 << level;  // segments around the tube
  const float twoPi = glm::two_pi<float>();
  Surface surface = surfaceBetween("torus", 1, 0);
  SurfaceBuilder builder(surface);
  // P(theta, phi) = ((R + r cos phi) cos theta, r sin phi, (R + r cos phi) sin theta).
  for (int j = 0; j < major; ++j) {
    const float theta = twoPi * static_cast<float>(j) / static_cast<float>(major);
    for (int i = 0; i < minor; ++i) {
      const float phi = twoPi * static_cast<float>(i) / static_cast<float>(minor);
      const glm::vec3 normal = glm::normalize(glm::vec3(std::cos(phi) * std::cos(theta),
                                                        std::sin(phi),
                                                        std::cos(phi) * std::sin(theta)));
      const float ring = kMajor + kMinor * std::cos(phi);
      builder.vertex(glm::vec3(ring * std::cos(theta), kMinor * std::sin(phi), ring * std::sin(theta)),
                     normal);
    }
  }
  // dP/dphi x dP/dtheta points outward, so (phi, theta) quads are counter-clockwise from outside.
  const auto at = [&](int i, int j) {
    return static_cast<uint32_t>((j % major) * minor + (i % minor));
  };
  for (int j = 0; j < major; ++j) {
    for (int i = 0; i < minor; ++i) {
      builder.triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1));
      builder.triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1));
    }
  }
  return surface;
}

// --- glass of water: surfaces of revolution around the y axis ----------------------------------------

// Points on circles around the y axis. Every surface takes its circle points from here, so that
// circles shared between surfaces have bitwise identical positions.
class Lathe {
 public:
  explicit Lathe(int segments) : segments_(segments) {
    for (int j = 0; j < segments; ++j) {
      const float angle = glm::two_pi<float>() * static_cast<float>(j) / static_cast<float>(segments);
      cos_.push_back(std::cos(angle));
      sin_.push_back(std::sin(angle));
    }
  }
  int segments() const { return segments_; }
  // j-th of `segments()` points, angle increasing from +x toward +z.
  glm::vec3 point(float radius, float y, int j) const {
    const size_t k = static_cast<size_t>(j % segments_);
    return glm::vec3(radius * cos_[k], y, radius * sin_[k]);
  }
  glm::vec3 radial(int j) const {
    const size_t k = static_cast<size_t>(j % segments_);
    return glm::vec3(cos_[k], 0.0f, sin_[k]);
  }

  // Band swept by the profile segment (r0, y0) -> (r1, y1), cut in `rows` along the profile.
  // The surface normal is profileNormal.x * radial + profileNormal.y * up (per vertex, normalized).
  void band(SurfaceBuilder& builder, glm::vec2 p0, glm::vec2 p1, int rows,
            glm::vec2 profileNormal) const {
    // d/dtheta x d/ds is (-dy, dr) in profile space; flip when the wanted normal is the other way.
    const glm::vec2 d = p1 - p0;
    const bool flip = glm::dot(profileNormal, glm::vec2(-d.y, d.x)) < 0.0f;
    const glm::vec2 pn = glm::normalize(profileNormal);
    std::vector<uint32_t> ids;
    for (int row = 0; row <= rows; ++row) {
      const float r = lerpExact(p0.x, p1.x, row, rows);
      const float y = lerpExact(p0.y, p1.y, row, rows);
      for (int j = 0; j < segments_; ++j) {
        ids.push_back(builder.vertex(point(r, y, j), pn.x * radial(j) + glm::vec3(0.0f, pn.y, 0.0f)));
      }
    }
    const auto at = [&](int j, int row) {
      return ids[static_cast<size_t>(row * segments_ + j % segments_)];
    };
    for (int row = 0; row < rows; ++row) {
      for (int j = 0; j < segments_; ++j) {
        builder.triangle(at(j, row), at(j + 1, row), at(j + 1, row + 1), flip);
        builder.triangle(at(j, row), at(j + 1, row + 1), at(j, row + 1), flip);
      }
    }
  }

  // Flat disk of `radius` at height y with normal +y (up) or -y. Its rim uses all `segments()`
  // points; inner rings use half as many points where that keeps triangles well shaped.
  void disk(SurfaceBuilder& builder, float radius, float y, int rings, bool up) const {
    const glm::vec3 normal(0.0f, up ? 1.0f : -1.0f, 0.0f);
    const bool flip = !up;  // the ring order below is counter-clockwise seen from +y
    const float radialStep = radius / static_cast<float>(rings);
    // Points per ring, from the rim inward; at most halved from one ring to the next.
    std::vector<int> counts(static_cast<size_t>(rings + 1), segments_);
    for (int k = rings - 1; k >= 1; --k) {
      const int outer = counts[static_cast<size_t>(k + 1)];
      const float ringRadius = lerpExact(0.0f, radius, k, rings);
      const float arc = glm::two_pi<float>() * ringRadius / static_cast<float>(outer);
      const bool halve = outer % 2 == 0 && outer / 2 >= 6 && arc < 0.7f * radialStep;
      counts[static_cast<size_t>(k)] = halve ? outer / 2 : outer;
    }
    // ids[k][j]: j-th point of ring k; ring 0 is the centre.
    std::vector<std::vector<uint32_t>> ids(static_cast<size_t>(rings + 1));
    ids[0].push_back(builder.vertex(glm::vec3(0.0f, y, 0.0f), normal));
    for (int k = 1; k <= rings; ++k) {
      const int count = counts[static_cast<size_t>(k)];
      const int stride = segments_ / count;
      const float ringRadius = lerpExact(0.0f, radius, k, rings);
      for (int j = 0; j < count; ++j) {
        ids[static_cast<size_t>(k)].push_back(builder.vertex(point(ringRadius, y, j * stride), normal));
      }
    }
    const auto ring = [&](int k, int j) {
      const auto& r = ids[static_cast<size_t>(k)];
      return r[static_cast<size_t>(j) % r.size()];
    };
    // Centre fan.
    for (int j = 0; j < counts[1]; ++j) {
      builder.triangle(ring(0, 0), ring(1, j + 1), ring(1, j), flip);
    }
    for (int k = 1; k < rings; ++k) {
      const int inner = counts[static_cast<size_t>(k)];
      const bool doubled = counts[static_cast<size_t>(k + 1)] == 2 * inner;
      for (int j = 0; j < inner; ++j) {
        if (doubled) {
          builder.triangle(ring(k, j), ring(k + 1, 2 * j + 1), ring(k + 1, 2 * j), flip);
          builder.triangle(ring(k, j), ring(k, j + 1), ring(k + 1, 2 * j + 1), flip);
          builder.triangle(ring(k, j + 1), ring(k + 1, 2 * j + 2), ring(k + 1, 2 * j + 1), flip);
        } else {
          builder.triangle(ring(k, j), ring(k, j + 1), ring(k + 1, j + 1), flip);
          builder.triangle(ring(k, j), ring(k + 1, j + 1), ring(k + 1, j), flip);
        }
      }
    }
  }

 private:
  int segments_;
  std::vector<float> cos_, sin_;
};

// Cup dimensions (docs/scenes.md).
constexpr float kCupOuterRadius = 0.75f;
constexpr float kCupInnerRadius = 0.68f;
constexpr float kCupBase = -1.0f;
constexpr float kCupRim = 1.0f;
constexpr float kCupFloor = -0.85f;  // top of the solid glass bottom
constexpr float kWaterLine = 0.35f;

std::vector<Surface> makeGlassOfWaterSurfaces(int level) {
  constexpr uint32_t kAir = 0, kGlass = 1, kWater = 2;
  const Lathe lathe(8 << level);
  // Target edge length: the spacing of the points around the outer wall.
  const float edge = glm::two_pi<float>() * kCupOuterRadius / static_cast<float>(lathe.segments());
  const auto steps = [edge](float length) {
    return std::max(1, static_cast<int>(std::lround(length / edge)));
  };
  const glm::vec2 outward(1.0f, 0.0f), inward(-1.0f, 0.0f), up(0.0f, 1.0f);

  // The inner walls: above the water line (dry) normals into the cavity; the wall and floor below
  // it (wet) normals into the water.
  std::vector<Surface> surfaces = {
      surfaceBetween("glass-outer", kGlass, kAir), surfaceBetween("glass-inner-dry", kGlass, kAir),
      surfaceBetween("glass-inner-wet", kGlass, kWater), surfaceBetween("water-surface", kWater, kAir)};
  SurfaceBuilder outer(surfaces[0]), dry(surfaces[1]), wet(surfaces[2]), top(surfaces[3]);
  lathe.disk(outer, kCupOuterRadius, kCupBase, steps(kCupOuterRadius), /*up=*/false);
  lathe.band(outer, {kCupOuterRadius, kCupBase}, {kCupOuterRadius, kCupRim}, steps(kCupRim - kCupBase), outward);
  lathe.band(outer, {kCupInnerRadius, kCupRim}, {kCupOuterRadius, kCupRim}, steps(kCupOuterRadius - kCupInnerRadius),
             up);
  lathe.band(dry, {kCupInnerRadius, kWaterLine}, {kCupInnerRadius, kCupRim}, steps(kCupRim - kWaterLine), inward);
  lathe.band(wet, {kCupInnerRadius, kCupFloor}, {kCupInnerRadius, kWaterLine}, steps(kWaterLine - kCupFloor), inward);
  lathe.disk(wet, kCupInnerRadius, kCupFloor, steps(kCupInnerRadius), /*up=*/true);
  lathe.disk(top, kCupInnerRadius, kWaterLine, steps(kCupInnerRadius), /*up=*/true);
  return surfaces;
}

std::string joinedNames() {
  std::string list;
  for (const std::string& name : builtinSceneNames()) {
    list += list.empty() ? "" : ", ";
    list += name;
  }
  return list;
}

}  // namespace

std::vector<std::string> builtinSceneNames() { return {kSphere, kCube, kTorus, kGlassOfWater}; }

std::string_view defaultBuiltinScene() { return kSphere; }

Result<Scene> makeBuiltinScene(std::string_view name, const BuiltinSceneOptions& options) {
  if (options.tessellation < kMinTessellation || options.tessellation > kMaxTessellation) {
    return makeError(ErrorCode::InvalidArgument,
                     "built-in scene tessellation " + std::to_string(options.tessellation) +
                         " is outside [" + std::to_string(kMinTessellation) + ", " +
                         std::to_string(kMaxTessellation) + "]");
  }
  if (options.iorOverride && !(std::isfinite(*options.iorOverride) && *options.iorOverride > 0.0f)) {
    return makeError(ErrorCode::InvalidArgument,
                     "ior override " + std::to_string(*options.iorOverride) + " must be finite and > 0");
  }
  if (options.absorptionOverride &&
      !(std::isfinite(*options.absorptionOverride) && *options.absorptionOverride >= 0.0f)) {
    return makeError(ErrorCode::InvalidArgument,
                     "absorption override " + std::to_string(*options.absorptionOverride) +
                         " must be finite and >= 0");
  }

  const int level = options.tessellation;
  Scene scene;
  scene.name = std::string(name);
  if (name == kSphere) {
    scene.media = {air(), glass()};
    scene.surfaces.push_back(makeSphereSurface(level));
  } else if (name == kCube) {
    scene.media = {air(), glass()};
    scene.surfaces.push_back(makeCubeSurface(level));
  } else if (name == kTorus) {
    scene.media = {air(), glass()};
    scene.surfaces.push_back(makeTorusSurface(level));
  } else if (name == kGlassOfWater) {
    scene.media = {air(), glass(), water()};
    scene.surfaces = makeGlassOfWaterSurfaces(level);
  } else {
    return makeError(ErrorCode::InvalidArgument, "unknown built-in scene '" + std::string(name) +
                                                     "' (valid: " + joinedNames() + ")");
  }

  if (options.iorOverride) {
    scene.media[1].ior = *options.iorOverride;
  }
  if (options.absorptionOverride) {
    for (size_t m = 1; m < scene.media.size(); ++m) {
      scene.media[m].absorption = *options.absorptionOverride;
    }
  }
  return scene;
}

}  // namespace shrefract::bake
