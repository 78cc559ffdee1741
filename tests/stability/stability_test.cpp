// Stiff and extreme scenes, baked small and rendered through the CPU reference of the engine's
// passes: everything must stay finite (coefficients, the distortion image, the rendered image, the
// exact reference), and the error against the exact reference is measured, printed as a table row
// (docs/stability.md) and held under a loose bound. The bounds are several times the measured
// values: they catch a case that breaks (NaN turned into black, a frame flipped, a medium lost),
// not small changes in accuracy.
#include "stability/stability_support.h"

#include <shrefract/assets/scene.h>

#include <set>
#include <utility>

namespace shrefract::stability {
namespace {

bake::Scene builtin(const std::string& name, int tessellation, std::optional<float> ior = {},
                    std::optional<float> absorption = {}) {
  bake::BuiltinSceneOptions o;
  o.tessellation = tessellation;
  o.iorOverride = ior;
  o.absorptionOverride = absorption;
  auto scene = bake::makeBuiltinScene(name, o);
  EXPECT_TRUE(scene.ok()) << scene.error().message;
  return scene.ok() ? std::move(scene).value() : bake::Scene{};
}

// The unit sphere seen from slightly above, filling most of a 64x48 image.
Camera sphereCamera(glm::dvec3 center = glm::dvec3(0.0), double scale = 1.0) {
  return cameraAt(center + scale * glm::dvec3(0.4, 0.9, 3.6), center, scale);
}

StabilityResult run(StabilityCase c) {
  StabilityResult r = runCase(c);
  printRow(c.name, r);
  return r;
}

TEST(Stability, IorBarelyAboveOne) {
  // n = 1.0001: the field is almost the identity (exit = view direction); most SH layers are
  // nearly constant, which stresses the U8 scale/bias of near-zero ranges.
  StabilityCase c{"ior 1.0001 (sphere)", builtin("sphere", 2, 1.0001f, 0.0f)};
  c.camera = sphereCamera();
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_LT(r.errors.meanAngleDegrees, 1.0);
  EXPECT_GT(r.errors.psnr, 40.0);
}

TEST(Stability, WaterInGlass) {
  // The built-in glass of water: water (1.33) inside glass (1.5) inside air, three media, absorbing.
  StabilityCase c{"1.33 in 1.5 (glass-of-water)", builtin("glass-of-water", 1)};
  c.settings = smallSettings(900);
  c.camera = cameraAt({0.6, 1.2, 4.2}, {0.0, 0.0, 0.0}, 2.0);
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_EQ(r.field.media.size(), 3u);
  EXPECT_EQ(r.field.channels, 4u);
  EXPECT_LT(r.errors.meanAngleDegrees, 45.0);
  EXPECT_GT(r.errors.psnr, 12.0);
}

TEST(Stability, Diamond) {
  StabilityCase c{"ior 2.42 (sphere)", builtin("sphere", 2, 2.42f)};
  c.camera = sphereCamera();
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_LT(r.errors.meanAngleDegrees, 20.0);
  EXPECT_GT(r.errors.psnr, 15.0);
}

TEST(Stability, IorFour) {
  // n = 4: total internal reflection inside almost everywhere (critical angle 14.5 degrees).
  StabilityCase c{"ior 4.0 (sphere)", builtin("sphere", 2, 4.0f)};
  c.camera = sphereCamera();
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_LT(r.errors.meanAngleDegrees, 30.0);
  EXPECT_GT(r.errors.psnr, 15.0);
}

// The Table and Pca encodings (with the throughput channel, and the first-refraction rule) on the
// stiffest optics: nearly the identity (n = 1.0001, near-zero ranges), total internal reflection
// almost everywhere (n = 4) and three absorbing media. Everything finite; the bounds are the SH
// cases' own, except the mean angle of a 6x6 table at n = 1.0001: measured 1.19 deg, the
// hemi-octahedral creases (docs/encodings.md), bounded at 1.5. A third bake per setup stores the
// throughput with the first-refraction rule: its shading differs from the exact reference's, so
// only finiteness is checked.
TEST(Stability, TableAndPcaEncodings) {
  struct Setup {
    const char* name;
    const char* scene;
    float ior;
    double maxAngle, minPsnr;
  };
  for (const Setup& setup : {Setup{"ior 1.0001", "sphere", 1.0001f, 1.0, 40.0}, Setup{"ior 4.0", "sphere", 4.0f, 30.0, 15.0},
                             Setup{"glass of water", "glass-of-water", 0.0f, 45.0, 12.0}})
    for (int variant = 0; variant < 3; ++variant) {
      const Encoding encoding = variant == 0 ? Encoding::Table : Encoding::Pca;
      const bool throughput = variant == 2, water = std::string(setup.scene) == "glass-of-water";
      StabilityCase c{std::string(setup.name) + ", " + toString(encoding) + (throughput ? " + throughput" : ""),
                      water ? builtin(setup.scene, 1) : builtin(setup.scene, 2, setup.ior, 0.0f)};
      c.settings = smallSettings(water ? 900 : 400);
      c.settings.encoding = encoding;
      c.settings.tableSize = encoding == Encoding::Table ? 6 : 8;
      c.settings.components = encoding == Encoding::Pca ? 48 : 0;
      c.settings.throughput = throughput;
      c.settings.pathRule = throughput ? PathRule::FirstRefraction : PathRule::HighestEnergy;
      c.camera = water ? cameraAt({0.6, 1.2, 4.2}, {0.0, 0.0, 0.0}, 2.0) : sphereCamera();
      const StabilityResult r = run(c);
      expectFiniteAndSeen(c.name, r);
      EXPECT_EQ(r.field.encoding, encoding) << c.name;
      if (throughput) continue;
      const bool crease = encoding == Encoding::Table && setup.ior == 1.0001f;
      EXPECT_LT(r.errors.meanAngleDegrees, crease ? 1.5 : setup.maxAngle) << c.name;
      EXPECT_GT(r.errors.psnr, setup.minPsnr) << c.name;
    }
}

TEST(Stability, GrazingViews) {
  // The eye 1e-4 above the plane of the cube's top face, and exactly in it: the top face's samples
  // see the eye on their horizon (w.z -> 0, clamped at 0 by the decompression).
  for (double height : {1.0 + 1e-4, 1.0}) {
    StabilityCase c{height == 1.0 ? "grazing: eye in the top face's plane (cube)"
                                  : "grazing: eye 1e-4 above the top face's plane (cube)",
                    builtin("cube", 1)};
    c.camera = cameraAt({1.2, height, 5.0}, {0.0, height, 0.0}, 2.0);
    const StabilityResult r = run(c);
    expectFiniteAndSeen(c.name, r);
    EXPECT_LT(r.errors.meanAngleDegrees, 30.0);
    EXPECT_GT(r.errors.psnr, 18.0);
  }
}

TEST(Stability, EyeCloseToTheSurface) {
  // The eye 0.05 radii above a sphere with a 150-degree field of view: the whole image is a cap of a
  // few triangles, seen from 0 to 72 degrees off the normal, down to grazing at the silhouette.
  // Within one texel the direction to the eye changes by tens of degrees, which the field (one
  // sample per texel, bilinear in between) cannot follow: the error is large by construction
  // (parallax below the texel size), and must stay finite.
  StabilityCase c{"eye 0.05 radii above a sphere (parallax within a texel)", builtin("sphere", 2)};
  c.camera = cameraAt({0.0, 0.0, 1.05}, {0.0, 0.0, 0.0}, 1.0, 150.0f);
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_LT(r.errors.meanAngleDegrees, 120.0);
}

TEST(Stability, PathsTrappedAtTheCap) {
  // A cube of n = 2.42 with the cap at one interaction: paths that meet a second interface stop
  // there (trapped, direction of travel), in the bake and in the exact reference alike.
  StabilityCase c{"TIR trapped, max-bounces 1 (cube, ior 2.42)", builtin("cube", 1, 2.42f)};
  c.settings.maxBounces = 1;
  c.referenceBounces = 1;
  c.camera = cameraAt({1.5, 1.8, 4.0}, {0.0, 0.0, 0.0}, 2.0);
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_GT(r.field.statistics.trappedPaths, 0u) << "the cap must be reached";
  EXPECT_GT(r.eyeTrapped, 0u);
  EXPECT_LT(r.errors.meanAngleDegrees, 30.0);
}

TEST(Stability, ThinShell) {
  // A glass shell 1e-4 of the radius thick (two concentric spheres, air inside): parallel
  // interfaces a few float steps of the tracer's offset apart. A thin shell barely deviates light.
  const bake::Scene sphere = builtin("sphere", 2, 1.5f, 0.0f);
  bake::Scene s;
  s.name = "thin-shell";
  s.media = {sphere.media[0], sphere.media[1], bake::Medium{"inside", 1.0f, 0.0f, glm::vec3(1.0f)}};
  bake::Surface outer = sphere.surfaces[0];
  outer.name = "outer";
  outer.innerMedium = 1;
  outer.outerMedium = 0;
  bake::Surface inner = transformed(sphere.surfaces[0], 1.0 - 1e-4, glm::dvec3(0.0));
  inner.name = "inner";  // normals point out of the cavity, toward the glass
  inner.innerMedium = 2;
  inner.outerMedium = 1;
  s.surfaces = {outer, inner};
  for (uint32_t m = 1; m < 3; ++m) ASSERT_TRUE(bake::checkMediumClosure(s, m).closed()) << m;
  StabilityCase c{"thin shell 1e-4 (sphere in sphere)", s};
  c.camera = sphereCamera();
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_EQ(r.eyeLabelConflicts, 0u) << "a 1e-4 shell must not be skipped by the tracer's offsets";
  EXPECT_LT(r.errors.meanAngleDegrees, 8.0);
}

TEST(Stability, OpenMesh) {
  // The sphere without its top cap: the glass is not closed. The bake must complete; paths that
  // leave through the hole count label conflicts.
  bake::Scene s = builtin("sphere", 2);
  bake::Surface& surface = s.surfaces[0];
  std::vector<uint32_t> kept;
  for (size_t t = 0; t < surface.indices.size(); t += 3) {
    bool cap = true;
    for (size_t k = 0; k < 3; ++k) cap = cap && surface.positions[surface.indices[t + k]].y > 0.55f;
    if (!cap) kept.insert(kept.end(), surface.indices.begin() + long(t), surface.indices.begin() + long(t + 3));
  }
  ASSERT_LT(kept.size(), surface.indices.size());
  surface.indices = kept;
  ASSERT_FALSE(bake::checkMediumClosure(s, 1).closed());
  StabilityCase c{"open mesh (sphere without its cap)", s};
  c.camera = cameraAt({0.3, 2.4, 3.0}, {0.0, 0.0, 0.0}, 2.0);
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_GT(r.eyeLabelConflicts, 0u) << "paths through the hole meet mislabelled interfaces";
  EXPECT_LT(r.errors.meanAngleDegrees, 25.0);
}

TEST(Stability, DegenerateAndSliverTriangles) {
  // The sphere with edges split by collinear slivers (zero area, three distinct corners: they close
  // the mesh) or nearly collinear ones (the midpoint lifted by 1e-6), plus triangles with repeated
  // corners and a triangle with all three corners equal.
  bake::Scene s = builtin("sphere", 1);
  bake::Surface& m = s.surfaces[0];
  std::vector<uint32_t> indices;
  std::set<std::pair<uint32_t, uint32_t>> splitEdges;
  const size_t triangles = m.indices.size() / 3;
  size_t slivers = 0, degenerate = 0;
  for (size_t t = 0; t < triangles; ++t) {
    const uint32_t a = m.indices[3 * t], b = m.indices[3 * t + 1], c = m.indices[3 * t + 2];
    const auto edge = std::minmax(a, b);
    if (t % 4 == 0 && !splitEdges.count(edge)) {
      splitEdges.insert(edge);
      const glm::vec3 n = glm::normalize(m.normals[a] + m.normals[b]);
      const float lift = (slivers % 2 == 0) ? 0.0f : 1e-6f;
      const uint32_t mid = uint32_t(m.positions.size());
      m.positions.push_back(0.5f * (m.positions[a] + m.positions[b]) + lift * n);
      m.normals.push_back(n);
      // (a, b, c) -> (a, mid, c), (mid, b, c) and the sliver (a, b, mid) that pairs the old edge.
      indices.insert(indices.end(), {a, mid, c, mid, b, c, a, b, mid});
      ++slivers;
    } else {
      indices.insert(indices.end(), {a, b, c});
    }
    if (t % 9 == 0) {
      indices.insert(indices.end(), {a, a, c});
      ++degenerate;
    }
  }
  indices.insert(indices.end(), {m.indices[0], m.indices[0], m.indices[0]});
  m.indices = indices;
  ASSERT_GT(slivers, 5u);
  ASSERT_GT(degenerate, 5u);
  const bake::TopologyReport topology = bake::checkMediumClosure(s, 1);
  EXPECT_GT(topology.degenerateTriangles, degenerate);
  StabilityCase c{"degenerate and sliver triangles (sphere)", s};
  c.camera = sphereCamera();
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_LT(r.errors.meanAngleDegrees, 20.0);
}

TEST(Stability, ScalesAndDistanceFromTheOrigin) {
  // The sphere at scales 1e-4, 1 and 1e4, each also moved about 100 times its size away from the
  // origin. The error must not depend on the scale (the tracer's offsets are relative).
  const bake::Scene unit = builtin("sphere", 2);
  double unitError = -1.0;
  for (double scale : {1.0, 1e-4, 1e4})
    for (bool far : {false, true}) {
      const glm::dvec3 center = far ? scale * glm::dvec3(120.0, -60.0, 90.0) : glm::dvec3(0.0);
      bake::Scene s = unit;
      s.surfaces[0] = transformed(unit.surfaces[0], scale, center);
      // Keep the optical depth per unit of the object's size: absorption scales as 1 / size.
      s.media[1].absorption = unit.media[1].absorption / float(scale);
      char name[96];
      std::snprintf(name, sizeof(name), "scale %g%s (sphere)", scale, far ? ", 150x its size from the origin" : "");
      StabilityCase c{name, s};
      c.camera = sphereCamera(center, scale);
      const StabilityResult r = run(c);
      expectFiniteAndSeen(c.name, r);
      if (unitError < 0.0) unitError = r.errors.meanAngleDegrees;
      // At the origin the scaled scenes are the unit scene up to a power of ten: the same error to
      // within rounding. Moved away, the vertices round differently (a float resolves about 1e-5 of
      // the size at 150 sizes away), which moves a few silhouette pixels: within a degree.
      EXPECT_NEAR(r.errors.meanAngleDegrees, unitError, far ? 1.0 : 0.05) << name;
      EXPECT_LT(r.errors.meanAngleDegrees, 20.0) << name;
    }
}

TEST(Stability, ShOrderTwenty) {
  // 441 basis functions from a 24x48 grid (1152 directions): ringing and large coefficients at high
  // order must stay finite.
  StabilityCase c{"SH order 20 (sphere)", builtin("sphere", 1)};
  c.settings = smallSettings(150);
  c.settings.order = 20;
  c.settings.directionsTheta = 24;
  c.settings.directionsPhi = 48;
  c.camera = sphereCamera();
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_EQ(r.field.basisCount(), 441u);
  EXPECT_LT(r.errors.meanAngleDegrees, 25.0);
}

TEST(Stability, OverlappingMedia) {
  // Two intersecting spheres of different media, each labelled against air: inside the overlap the
  // labels disagree with the path's medium. The bake must complete; conflicts are counted.
  const bake::Scene sphere = builtin("sphere", 2);
  bake::Scene s;
  s.name = "overlap";
  s.media = {sphere.media[0], bake::Medium{"glass", 1.5f, 0.1f, glm::vec3(1.0f)},
             bake::Medium{"water", 1.33f, 0.3f, glm::vec3(1.0f)}};
  bake::Surface a = transformed(sphere.surfaces[0], 0.8, {-0.4, 0.0, 0.0});
  a.name = "glass-ball";
  a.innerMedium = 1;
  bake::Surface b = transformed(sphere.surfaces[0], 0.8, {0.4, 0.0, 0.0});
  b.name = "water-ball";
  b.innerMedium = 2;
  s.surfaces = {a, b};
  StabilityCase c{"overlapping media (two intersecting spheres)", s};
  c.settings = smallSettings(800);
  c.camera = cameraAt({0.3, 0.8, 4.0}, {0.0, 0.0, 0.0}, 2.0);
  const StabilityResult r = run(c);
  expectFiniteAndSeen(c.name, r);
  EXPECT_GT(r.eyeLabelConflicts, 0u) << "paths through the overlap cross inconsistent labels";
  EXPECT_LT(r.errors.meanAngleDegrees, 30.0);
}

}  // namespace
}  // namespace shrefract::stability
