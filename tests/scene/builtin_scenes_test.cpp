// Built-in scenes: structure, closed and outward-oriented media, analytic volumes, normals, options.
#include <shrefract/assets/scene.h>

#include <glm/geometric.hpp>
#include <glm/gtc/constants.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>
#include <tuple>

namespace shrefract::bake {
namespace {

Scene build(const std::string& name, const BuiltinSceneOptions& options = {}) {
  Result<Scene> scene = makeBuiltinScene(name, options);
  EXPECT_TRUE(scene.ok()) << name << ": " << (scene.ok() ? "" : scene.error().message);
  return scene.ok() ? std::move(scene).value() : Scene{};
}

size_t triangleCount(const Scene& scene) {
  size_t n = 0;
  for (const Surface& s : scene.surfaces) n += s.indices.size() / 3;
  return n;
}

std::string sceneTestName(const ::testing::TestParamInfo<std::tuple<std::string, int>>& p) {
  std::string n = std::get<0>(p.param);
  for (char& ch : n) {
    if (ch == '-') ch = '_';
  }
  return n + "_level" + std::to_string(std::get<1>(p.param));
}

class EveryBuiltinScene : public ::testing::TestWithParam<std::tuple<std::string, int>> {};

TEST_P(EveryBuiltinScene, Validates) {
  const auto& [name, level] = GetParam();
  const Scene scene = build(name, {.tessellation = level});
  const Result<void> valid = validateScene(scene);
  EXPECT_TRUE(valid.ok()) << (valid.ok() ? "" : valid.error().message);
  EXPECT_EQ(scene.name, name);
  ASSERT_GE(scene.media.size(), 2u);
  EXPECT_EQ(scene.media[0].name, "air");
  EXPECT_EQ(scene.media[0].ior, 1.0f);
}

TEST_P(EveryBuiltinScene, EveryMediumButAirIsClosedWithoutDegenerateTriangles) {
  const auto& [name, level] = GetParam();
  const Scene scene = build(name, {.tessellation = level});
  for (uint32_t m = 1; m < scene.media.size(); ++m) {
    const TopologyReport report = checkMediumClosure(scene, m);
    SCOPED_TRACE(name + " medium " + scene.media[m].name);
    EXPECT_GT(report.triangles, 0u);
    EXPECT_EQ(report.degenerateTriangles, 0u);
    EXPECT_EQ(report.openEdges, 0u);
    EXPECT_EQ(report.inconsistentEdges, 0u);
    EXPECT_EQ(report.nonManifoldEdges, 0u);
    EXPECT_TRUE(report.closed());
  }
}

TEST_P(EveryBuiltinScene, EveryMediumButAirHasPositiveVolume) {
  const auto& [name, level] = GetParam();
  const Scene scene = build(name, {.tessellation = level});
  for (uint32_t m = 1; m < scene.media.size(); ++m) {
    EXPECT_GT(signedVolume(scene, m), 0.0) << name << " medium " << scene.media[m].name;
  }
}

TEST_P(EveryBuiltinScene, VertexNormalsAreUnitAndAgreeWithFaceNormals) {
  const auto& [name, level] = GetParam();
  const Scene scene = build(name, {.tessellation = level});
  for (const Surface& s : scene.surfaces) {
    for (const glm::vec3& n : s.normals) {
      ASSERT_NEAR(glm::length(n), 1.0f, 1e-5f) << s.name;
    }
    for (size_t i = 0; i < s.indices.size(); i += 3) {
      const glm::vec3 a = s.positions[s.indices[i]], b = s.positions[s.indices[i + 1]],
                      c = s.positions[s.indices[i + 2]];
      const glm::vec3 face = glm::normalize(glm::cross(b - a, c - a));
      for (size_t k = 0; k < 3; ++k) {
        // Smooth normals of a tessellated curve lean away from the face normal by at most about
        // one segment angle (45 degrees at the coarsest level); 0.5 leaves room and still catches
        // flipped triangles, which give a dot product near -1.
        ASSERT_GT(glm::dot(face, s.normals[s.indices[i + k]]), 0.5f)
            << s.name << " triangle " << i / 3 << " corner " << k;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(BuiltinScenes, EveryBuiltinScene,
                         ::testing::Combine(::testing::Values("sphere", "cube", "torus",
                                                              "glass-of-water"),
                                            ::testing::Values(0, 1, 3)),
                         sceneTestName);

TEST(BuiltinScenes, NamesAreTheFourScenesAndDefaultIsSphere) {
  const std::vector<std::string> names = builtinSceneNames();
  EXPECT_EQ(std::set<std::string>(names.begin(), names.end()),
            (std::set<std::string>{"sphere", "cube", "torus", "glass-of-water"}));
  EXPECT_EQ(defaultBuiltinScene(), "sphere");
  EXPECT_TRUE(makeBuiltinScene(defaultBuiltinScene()).ok());
}

TEST(BuiltinScenes, SphereVolumeApproachesFourThirdsPi) {
  const double exact = 4.0 / 3.0 * glm::pi<double>();
  double previousError = 1.0;
  for (int level = 2; level <= 5; ++level) {
    const double volume = signedVolume(build("sphere", {.tessellation = level}), 1);
    const double error = std::abs(volume - exact) / exact;
    // Inscribed polyhedron: always a little smaller, the error falls ~4x per level
    // (measured: 3.4% at level 2, 0.86% at 3, 0.054% at 5, i.e. about 0.55 / 4^level).
    EXPECT_LT(volume, exact);
    EXPECT_LT(error, 0.6 / std::pow(4.0, level)) << "level " << level;
    EXPECT_LT(error, previousError);
    previousError = error;
  }
}

TEST(BuiltinScenes, CubeVolumeIsExactlyEight) {
  for (int level : {0, 2, 4}) {
    // Every coordinate is a multiple of a power of two: the double sum is exact.
    EXPECT_DOUBLE_EQ(signedVolume(build("cube", {.tessellation = level}), 1), 8.0);
  }
}

TEST(BuiltinScenes, TorusVolumeApproachesTwoPiSquaredRrSquared) {
  const double R = 1.0, r = 0.35;
  const double exact = 2.0 * glm::pi<double>() * glm::pi<double>() * R * r * r;
  // Inscribed polygons in both directions: relative error ~ (pi/minor)^2/6 + (pi/major)^2/6.
  const double volume3 = signedVolume(build("torus", {.tessellation = 3}), 1);
  EXPECT_NEAR(volume3, exact, 0.01 * exact);
  const double volume5 = signedVolume(build("torus", {.tessellation = 5}), 1);
  EXPECT_NEAR(volume5, exact, 0.001 * exact);
}

TEST(BuiltinScenes, GlassOfWaterVolumesMatchTheDocumentedCup) {
  // docs/scenes.md: outer radius 0.75, inner 0.68, base -1, rim 1, cavity floor -0.85, water 0.35.
  const double pi = glm::pi<double>();
  const double glass = pi * 0.75 * 0.75 * 2.0 - pi * 0.68 * 0.68 * (1.0 + 0.85);
  const double water = pi * 0.68 * 0.68 * (0.35 + 0.85);
  const Scene scene = build("glass-of-water", {.tessellation = 4});
  ASSERT_EQ(scene.media.size(), 3u);
  EXPECT_EQ(scene.media[1].name, "glass");
  EXPECT_EQ(scene.media[2].name, "water");
  EXPECT_FLOAT_EQ(scene.media[1].ior, 1.5f);
  EXPECT_FLOAT_EQ(scene.media[2].ior, 1.33f);
  EXPECT_GT(scene.media[1].absorption, 0.0f);
  EXPECT_GT(scene.media[2].absorption, 0.0f);
  // Water tint: blue-green passes more than red.
  EXPECT_LT(scene.media[2].color.r, scene.media[2].color.g);
  EXPECT_LT(scene.media[2].color.r, scene.media[2].color.b);
  // 128 segments around: inscribed-polygon area error (2 pi / 128)^2 / 6 = 0.04%; the glass wall
  // is thin, so its volume carries the error of both radii (~0.5% of the glass volume).
  EXPECT_NEAR(signedVolume(scene, 1), glass, 0.01 * glass);
  EXPECT_NEAR(signedVolume(scene, 2), water, 0.002 * water);

  const Bounds b = bounds(scene);
  EXPECT_FLOAT_EQ(b.min.y, -1.0f);
  EXPECT_FLOAT_EQ(b.max.y, 1.0f);
  EXPECT_NEAR(b.max.x, 0.75f, 1e-6f);
}

TEST(BuiltinScenes, GlassOfWaterSurfacesShareTheWaterLineExactly) {
  const Scene scene = build("glass-of-water");
  ASSERT_EQ(scene.surfaces.size(), 4u);
  // Each surface is an open piece by itself; together they close the two media.
  for (const Surface& s : scene.surfaces) {
    EXPECT_GT(checkSurface(s).openEdges, 0u) << s.name;
  }
  // The water-line circle: the same bitwise positions in the three surfaces that meet there.
  auto waterLine = [](const Surface& s) {
    std::set<std::tuple<float, float, float>> points;
    for (const glm::vec3& p : s.positions) {
      if (p.y == 0.35f && glm::length(glm::vec2(p.x, p.z)) > 0.67f) points.insert({p.x, p.y, p.z});
    }
    return points;
  };
  const Surface* dry = nullptr;
  const Surface* wet = nullptr;
  const Surface* top = nullptr;
  for (const Surface& s : scene.surfaces) {
    if (s.name == "glass-inner-dry") dry = &s;
    if (s.name == "glass-inner-wet") wet = &s;
    if (s.name == "water-surface") top = &s;
  }
  ASSERT_TRUE(dry && wet && top);
  EXPECT_EQ(dry->innerMedium, 1u);
  EXPECT_EQ(dry->outerMedium, 0u);
  EXPECT_EQ(wet->innerMedium, 1u);
  EXPECT_EQ(wet->outerMedium, 2u);
  EXPECT_EQ(top->innerMedium, 2u);
  EXPECT_EQ(top->outerMedium, 0u);
  const auto circle = waterLine(*top);
  EXPECT_EQ(circle.size(), 64u);  // default tessellation 3: 8 << 3 points around
  EXPECT_EQ(waterLine(*dry), circle);
  EXPECT_EQ(waterLine(*wet), circle);
  for (const glm::vec3& n : top->normals) {
    EXPECT_EQ(n, glm::vec3(0.0f, 1.0f, 0.0f));
  }
}

TEST(BuiltinScenes, SphereNormalsAreItsNormalizedPositions) {
  const Scene scene = build("sphere");
  ASSERT_EQ(scene.surfaces.size(), 1u);
  const Surface& s = scene.surfaces[0];
  for (size_t v = 0; v < s.positions.size(); ++v) {
    EXPECT_NEAR(glm::length(s.positions[v]), 1.0f, 1e-6f);
    EXPECT_LT(glm::length(s.normals[v] - glm::normalize(s.positions[v])), 1e-6f);
  }
}

TEST(BuiltinScenes, CubeIsClosedByPositionButNotByIndex) {
  const Scene scene = build("cube", {.tessellation = 1});
  const Surface& s = scene.surfaces[0];
  EXPECT_TRUE(checkSurface(s).closed());
  // Flat normals: all six face normals, and corners duplicated once per face.
  std::set<std::tuple<float, float, float>> normals;
  for (const glm::vec3& n : s.normals) normals.insert({n.x, n.y, n.z});
  EXPECT_EQ(normals.size(), 6u);
  EXPECT_EQ(s.positions.size(), 6u * 9u);
  const Bounds b = bounds(scene);
  EXPECT_EQ(b.min, glm::vec3(-1.0f));
  EXPECT_EQ(b.max, glm::vec3(1.0f));
}

TEST(BuiltinScenes, TessellationChangesTriangleCounts) {
  for (const std::string& name : builtinSceneNames()) {
    const size_t coarse = triangleCount(build(name, {.tessellation = 1}));
    const size_t fine = triangleCount(build(name, {.tessellation = 3}));
    EXPECT_GT(fine, 8 * coarse) << name;  // about 4x per level
  }
  EXPECT_EQ(triangleCount(build("sphere", {.tessellation = 2})), 20u * 16u);
  EXPECT_EQ(triangleCount(build("cube", {.tessellation = 2})), 12u * 16u);
  EXPECT_EQ(triangleCount(build("torus", {.tessellation = 2})), 2u * 32u * 16u);
}

TEST(BuiltinScenes, UnknownNameListsTheValidNames) {
  const Result<Scene> scene = makeBuiltinScene("teapot");
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(scene.error().message.find("teapot"), std::string::npos);
  for (const std::string& name : builtinSceneNames()) {
    EXPECT_NE(scene.error().message.find(name), std::string::npos) << scene.error().message;
  }
}

TEST(BuiltinScenes, BadOptionsAreRejected) {
  EXPECT_FALSE(makeBuiltinScene("sphere", {.tessellation = -1}).ok());
  EXPECT_FALSE(makeBuiltinScene("sphere", {.tessellation = kMaxTessellation + 1}).ok());
  EXPECT_FALSE(makeBuiltinScene("sphere", {.iorOverride = 0.0f}).ok());
  EXPECT_FALSE(makeBuiltinScene("sphere", {.iorOverride = NAN}).ok());
  EXPECT_FALSE(makeBuiltinScene("sphere", {.absorptionOverride = -1.0f}).ok());
}

TEST(BuiltinScenes, OverridesAreApplied) {
  const Scene sphere = build("sphere", {.iorOverride = 1.7f, .absorptionOverride = 0.0f});
  EXPECT_EQ(sphere.media[1].ior, 1.7f);
  EXPECT_EQ(sphere.media[1].absorption, 0.0f);
  EXPECT_EQ(sphere.media[0].ior, 1.0f);
  EXPECT_EQ(sphere.media[0].absorption, 0.0f);

  const Scene cup = build("glass-of-water", {.iorOverride = 1.9f, .absorptionOverride = 2.0f});
  EXPECT_EQ(cup.media[1].ior, 1.9f);   // the glass
  EXPECT_EQ(cup.media[2].ior, 1.33f);  // water keeps its ior
  EXPECT_EQ(cup.media[1].absorption, 2.0f);
  EXPECT_EQ(cup.media[2].absorption, 2.0f);
  EXPECT_EQ(cup.media[0].absorption, 0.0f);
}

TEST(SceneValidation, RejectsBrokenScenes) {
  const Scene good = build("cube", {.tessellation = 0});
  ASSERT_TRUE(validateScene(good).ok());

  auto expectInvalid = [](const Scene& s, const std::string& fragment) {
    const Result<void> r = validateScene(s);
    ASSERT_FALSE(r.ok()) << fragment;
    EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument);
    EXPECT_NE(r.error().message.find(fragment), std::string::npos) << r.error().message;
  };
  Scene s = good;
  s.surfaces[0].indices[4] = 100000;
  expectInvalid(s, "out of range");
  s = good;
  s.surfaces[0].positions[3].y = INFINITY;
  expectInvalid(s, "non-finite position");
  s = good;
  s.surfaces[0].normals[2] *= 2.0f;
  expectInvalid(s, "not unit");
  s = good;
  s.surfaces[0].outerMedium = 7;
  expectInvalid(s, "medium 7");
  s = good;
  s.surfaces[0].outerMedium = 1;
  expectInvalid(s, "same medium");
  s = good;
  s.surfaces[0].indices.clear();
  expectInvalid(s, "indices");
  s = good;
  s.surfaces.clear();
  expectInvalid(s, "no surfaces");
  s = good;
  s.surfaces[0].normals.pop_back();
  expectInvalid(s, "normals");
  s = good;
  s.surfaces[0].uvs.resize(3);
  expectInvalid(s, "uvs");
  s = good;
  s.media[1].ior = -1.0f;
  expectInvalid(s, "ior");
}

TEST(Topology, DetectsOpenInconsistentAndNonManifoldEdges) {
  Surface tetra;
  tetra.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  tetra.normals.assign(4, glm::vec3(0, 0, 1));
  // Outward-facing tetrahedron.
  tetra.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  EXPECT_TRUE(checkSurface(tetra).closed());

  Surface open = tetra;
  open.indices.resize(9);
  TopologyReport r = checkSurface(open);
  EXPECT_EQ(r.openEdges, 3u);
  EXPECT_FALSE(r.closed());

  Surface flipped = tetra;
  std::swap(flipped.indices[10], flipped.indices[11]);
  r = checkSurface(flipped);
  EXPECT_EQ(r.openEdges, 0u);
  EXPECT_EQ(r.inconsistentEdges, 3u);
  EXPECT_FALSE(r.closed());

  Surface fin = tetra;
  fin.positions.push_back({1, 1, 1});
  fin.normals.push_back({0, 0, 1});
  fin.indices.insert(fin.indices.end(), {1, 2, 4, 2, 1, 4});  // two extra faces on edge 1-2
  r = checkSurface(fin);
  EXPECT_EQ(r.nonManifoldEdges, 1u);
  EXPECT_FALSE(r.closed());

  Surface degenerate = tetra;
  degenerate.positions.push_back({0, 0, 0});  // duplicate of vertex 0 by position
  degenerate.normals.push_back({0, 0, 1});
  degenerate.indices.insert(degenerate.indices.end(), {0, 4, 1});
  r = checkSurface(degenerate);
  EXPECT_EQ(r.degenerateTriangles, 1u);
  EXPECT_TRUE(r.closed());

  // Signed volume of the tetrahedron as a scene: 1/6, negative when the medium is outside.
  Scene scene;
  scene.media = {Medium{"air"}, Medium{"glass", 1.5f}};
  scene.surfaces = {tetra};
  EXPECT_NEAR(signedVolume(scene, 1), 1.0 / 6.0, 1e-12);
  EXPECT_NEAR(signedVolume(scene, 0), -1.0 / 6.0, 1e-12);
  EXPECT_TRUE(checkMediumClosure(scene, 0).closed());
}

}  // namespace
}  // namespace shrefract::bake
