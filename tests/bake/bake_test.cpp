// End-to-end bakes of built-in scenes at small sizes: valid fields, deterministic across thread
// counts, the attenuation channel dropped when nothing absorbs, error falling with the SH order;
// and the batch tracing the bake uses for every sample's directions, against single paths.
#include <gtest/gtest.h>
#include <shrefract/field_decode.h>
#include <shrefract/bake/bake.h>
#include <shrefract/bake/fit.h>
#include <shrefract/bake/layout.h>
#include <shrefract/bake/sample_frame.h>
#include <shrefract/trace/tracer.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <cstring>
#include <limits>

namespace shrefract::bake {
namespace {

Field bake(const std::string& name, BakeSettings s, int tessellation = 2, std::optional<float> absorption = {}) {
  BuiltinSceneOptions so;
  so.tessellation = tessellation;
  so.absorptionOverride = absorption;
  auto scene = makeBuiltinScene(name, so);
  EXPECT_TRUE(scene.ok());
  BakeOptions options;
  s.source = "builtin:" + name;
  options.settings = s;
  auto field = bakeField(scene.value(), options);
  EXPECT_TRUE(field.ok()) << (field.ok() ? "" : field.error().message);
  return field.ok() ? std::move(field).value() : Field{};
}

BakeSettings small() {
  BakeSettings s;
  s.order = 4;
  s.directionsTheta = 8;
  s.directionsPhi = 16;
  s.sampleBudget = 700;
  s.threads = 2;
  return s;
}

// Tables of N x N traced at their nodes, exits in each sample's frame, on a chart atlas.
BakeSettings tracedAtTheNodes(Encoding encoding, uint32_t n, uint64_t sampleBudget) {
  BakeSettings s = small();
  s.encoding = encoding;
  s.tableSize = n;
  s.directionSampling = DirectionSampling::Nodes;
  s.exitFrame = ExitFrame::Sample;
  s.layout = SampleLayout::Charts;
  s.sampleBudget = sampleBudget;
  return s;
}

// Timing statistics and the thread count are the only fields allowed to differ between runs.
std::vector<uint8_t> dataBytes(Field f) {
  f.statistics.bakeSeconds = f.statistics.traceSeconds = f.statistics.fitSeconds = f.statistics.raysPerSecond = 0;
  f.statistics.peakMemoryBytes = 0;
  f.settings.threads = 0;
  return serializeField(f);
}

// Normals over the sphere, the poles and the rim of the polar cap included.
std::vector<glm::vec3> testNormals() {
  std::vector<glm::vec3> normals = {{0, 1, 0}, {0, -1, 0}, {1, 0, 0}, {0, 0, -1}, glm::normalize(glm::vec3(0.1f, 1, 0)),
                                    glm::normalize(glm::vec3(0.0999f, -0.995f, 0.0f))};
  for (int i = 0; i < 200; ++i) {
    const float z = 1.0f - 2.0f * (float(i) + 0.5f) / 200.0f, phi = 2.39996323f * float(i);
    const float r = std::sqrt(1.0f - z * z);
    normals.push_back({r * std::cos(phi), z, r * std::sin(phi)});
  }
  return normals;
}

// sample_frame.h: a right-handed orthonormal frame around the normal whose tangent follows the
// latitude around +Y, so a rotation about +Y carries frames onto frames.
TEST(SampleFrame, TangentFollowsTheLatitudeAroundUp) {
  for (const glm::vec3 n : testNormals()) {
    SCOPED_TRACE(testing::Message() << "n = " << n.x << ", " << n.y << ", " << n.z);
    const LocalFrame f = frameFromNormal(n);
    EXPECT_NEAR(glm::length(f.tangent), 1.0f, 1e-6f);
    EXPECT_NEAR(glm::length(f.bitangent), 1.0f, 1e-6f);
    EXPECT_NEAR(glm::dot(f.tangent, n), 0.0f, 1e-6f);
    EXPECT_NEAR(glm::dot(f.bitangent, n), 0.0f, 1e-6f);
    EXPECT_LT(glm::length(glm::cross(f.tangent, f.bitangent) - n), 1e-6f);
    const bool polar = n.x * n.x + n.z * n.z <= kPolarCapSin2;
    if (!polar) {
      EXPECT_NEAR(f.tangent.y, 0.0f, 1e-6f) << "off the latitude";
    }
    // Rotated about +Y by 1 radian, the normal's frame is the rotated frame (outside the cap).
    const float c = std::cos(1.0f), s = std::sin(1.0f);
    auto rotate = [&](glm::vec3 v) { return glm::vec3(c * v.x + s * v.z, v.y, -s * v.x + c * v.z); };
    const LocalFrame g = frameFromNormal(rotate(n));
    if (!polar) {
      EXPECT_LT(glm::length(g.tangent - rotate(f.tangent)), 1e-5f);
      EXPECT_LT(glm::length(g.bitangent - rotate(f.bitangent)), 1e-5f);
    }
  }
}

// sample_frame.h frameAt: in the polar cap of a curved surface the tangent is the latitude through
// the point, so a rotation about +Y carries a cap sample's frame onto the rotated sample's, as it
// does outside the cap; a flat face across the axis and a point on the axis keep frameFromNormal,
// and so does every point outside the cap.
TEST(SampleFrame, CapOfACurvedSurfaceTurnsWithThePoint) {
  const float c = std::cos(1.0f), s = std::sin(1.0f);
  auto rotate = [&](glm::vec3 v) { return glm::vec3(c * v.x + s * v.z, v.y, -s * v.x + c * v.z); };
  auto point = [](glm::vec3 position, glm::vec3 shading, glm::vec3 geometric) {
    SurfacePoint p;
    p.position = position;
    p.shadingNormal = glm::normalize(shading);
    p.geometricNormal = glm::normalize(geometric);
    return p;
  };
  auto near = [](glm::vec3 a, glm::vec3 b) { return glm::length(a - b) < 1e-5f; };
  // A torus's top ring: the interpolated normal leans 2 deg off its triangle's, inside the cap.
  for (const SurfacePoint& p : {point({1.5f, 0.5f, 0.3f}, {0.03f, 1.0f, 0.01f}, {0.0f, 1.0f, 0.0f}),
                                point({-0.2f, -0.5f, 1.1f}, {0.0f, -1.0f, 0.04f}, {0.02f, -1.0f, 0.0f})}) {
    SCOPED_TRACE(testing::Message() << "p = " << p.position.x << ", " << p.position.y << ", " << p.position.z);
    const LocalFrame f = frameAt(p);
    EXPECT_NEAR(glm::length(f.tangent), 1.0f, 1e-6f);
    EXPECT_NEAR(glm::dot(f.tangent, p.shadingNormal), 0.0f, 1e-6f);
    EXPECT_LT(glm::length(glm::cross(f.tangent, f.bitangent) - p.shadingNormal), 1e-6f);
    // Along up x position, as the latitude outside the cap on a surface of revolution's outer side.
    EXPECT_GT(glm::dot(f.tangent, glm::normalize(glm::vec3(p.position.z, 0.0f, -p.position.x))), 0.99f);
    const LocalFrame g = frameAt(point(rotate(p.position), rotate(p.shadingNormal), rotate(p.geometricNormal)));
    EXPECT_TRUE(near(g.tangent, rotate(f.tangent))) << "the cap's frame does not turn with the point";
    EXPECT_TRUE(near(g.bitangent, rotate(f.bitangent)));
  }
  // A cube's top face (flat), a point on the axis, a wall outside the cap: frameFromNormal.
  for (const SurfacePoint& p : {point({0.7f, 1.0f, -0.4f}, {0.0f, 1.0f, 0.0f}, {0.0f, 1.0f, 0.0f}),
                                point({0.0f, 1.0f, 0.0f}, {0.03f, 1.0f, 0.0f}, {0.0f, 1.0f, 0.0f}),
                                point({1.0f, 0.2f, 0.3f}, {1.0f, 0.3f, 0.2f}, {1.0f, 0.25f, 0.2f})}) {
    const LocalFrame f = frameAt(p), expected = frameFromNormal(p.shadingNormal);
    EXPECT_TRUE(near(f.tangent, expected.tangent) && near(f.bitangent, expected.bitangent))
        << "p = " << p.position.x << ", " << p.position.y << ", " << p.position.z;
  }
}

// A sample-frame field decodes (evaluateSample, object space) to the exits the object-space
// field of the same scene decodes to: the node-sampled f16 table holds the traced exit at every
// node in either frame, so at node directions the two agree to f16 rounding.
TEST(Bake, SampleFrameExitsDecodeToTheObjectSpaceExits) {
  // The sphere: its frames are general rotations (a cube's are signed permutations).
  auto scene = makeBuiltinScene("sphere", {.tessellation = 1});
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  BakeOptions options;
  options.settings.encoding = Encoding::Table;
  options.settings.order = 0;
  options.settings.tableSize = 6;
  options.settings.directionSampling = DirectionSampling::Nodes;
  options.settings.quantization = Quantization::F16;
  options.settings.sampleBudget = 200;
  options.settings.threads = 2;
  options.heldOutDirections = 0;
  options.settings.exitFrame = ExitFrame::Sample;
  auto sample = bakeField(*scene, options);
  options.settings.exitFrame = ExitFrame::Object;
  auto object = bakeField(*scene, options);
  ASSERT_TRUE(sample.ok() && object.ok());
  ASSERT_TRUE(sample->sampleFrameExits);
  ASSERT_FALSE(object->sampleFrameExits);
  double maxDiff = 0.0, maxStored = 0.0;
  for (uint64_t t = 0; t < sample->texelCount(); ++t) {
    if (sample->texelKinds[t] != kTexelSample) continue;
    for (uint32_t node = 0; node < 36; ++node) {
      const std::array<float, 3> w = hemiOctDirection(node % 6, node / 6, 6);
      float a[4] = {}, b[4] = {};
      evaluateSample(*sample, t, w, a);
      evaluateSample(*object, t, w, b);
      for (int c = 0; c < 3; ++c) maxDiff = std::max(maxDiff, double(std::abs(a[c] - b[c])));
      for (int c = 0; c < 3; ++c)  // the stored values differ from the decoded ones (a rotation)
        maxStored = std::max(maxStored, double(std::abs(fieldCoefficient(*sample, node, t, uint32_t(c)) -
                                                        fieldCoefficient(*object, node, t, uint32_t(c)))));
    }
  }
  std::printf("sample frame against object space: max decoded difference %.2e, max stored %.2f\n", maxDiff,
              maxStored);
  EXPECT_LT(maxDiff, 2e-3);  // two f16 roundings of values up to 1 (4.9e-4 each) and the rotation
  EXPECT_GT(maxStored, 0.5);
}

TEST(Bake, SphereFieldIsValidAndAccurate) {
  const Field f = bake("sphere", small(), 2, 0.0f);
  ASSERT_TRUE(validateField(f).ok());
  EXPECT_EQ(f.channels, 3u) << "a clear sphere stores no optical depth";
  EXPECT_EQ(f.order, 4u);
  EXPECT_GT(f.statistics.samples, 100u);
  EXPECT_EQ(f.statistics.directions, 128u);
  EXPECT_GE(f.statistics.rays, f.statistics.paths);
  EXPECT_TRUE(std::isfinite(f.statistics.fitRmsDegrees));
  EXPECT_GT(f.statistics.heldOutRmsDegrees, 0.0f);
  EXPECT_GT(f.mesh.indices.size(), 0u);
  // The RMS over every direction bounds a least-squares fit. The robust fit (the default) gives up
  // on the directions it misses by far (the trapped paths at the rim), so its RMS is the larger.
  BakeSettings lsq = small();
  lsq.shFit = ShFit::LeastSquares;
  const Field g = bake("sphere", lsq, 2, 0.0f);
  EXPECT_EQ(f.settings.shFit, ShFit::Robust);
  EXPECT_EQ(g.settings.shFit, ShFit::LeastSquares);
  EXPECT_LT(g.statistics.fitRmsDegrees, 20.0f);
  EXPECT_GT(f.statistics.fitRmsDegrees, g.statistics.fitRmsDegrees);
}

TEST(Bake, DeterministicAcrossThreadCounts) {
  BakeSettings one = small(), two = small();
  one.threads = 1;
  two.threads = 2;
  EXPECT_EQ(dataBytes(bake("torus", one, 2)), dataBytes(bake("torus", two, 2)));
}

// The Pca fit splits its products into fixed blocks run on the bake's threads (table_fit.cpp
// productInBlocks, gramOf): at the default 32x32 tables (5120 values with the jump distance) the
// basis takes the subspace iteration, and the field must not depend on the thread count either.
TEST(Bake, PcaFitIsDeterministicAcrossThreadCounts) {
  BakeSettings s = small();
  s.encoding = Encoding::Pca;
  s.order = 0;
  s.tableSize = 32;
  s.components = 8;
  s.directionSampling = DirectionSampling::Nodes;
  s.exitFrame = ExitFrame::Sample;
  s.sampleBudget = 300;
  BakeSettings three = s;
  s.threads = 1;
  three.threads = 3;
  const Field a = bake("torus", s, 1), b = bake("torus", three, 1);
  ASSERT_EQ(a.basis.size(), size_t(8) * 32 * 32 * a.channels);
  EXPECT_EQ(dataBytes(a), dataBytes(b));
}

// A Pca bake of the coarse torus traced at its table nodes, the exit frame left to the bake, no
// held-out directions (the frame tests below).
BakeOptions autoFramePcaOptions(uint32_t tableSize, uint32_t components, uint64_t sampleBudget) {
  BakeOptions options;
  options.settings = small();
  options.settings.encoding = Encoding::Pca;
  options.settings.order = 0;
  options.settings.tableSize = tableSize;
  options.settings.components = components;
  options.settings.directionSampling = DirectionSampling::Nodes;
  options.settings.sampleBudget = sampleBudget;
  options.heldOutDirections = 0;
  return options;
}

// ExitFrame::Auto (the default) compares the two frames on bases learned from a subset of the
// samples, not from all of them (bake/src/driver/basis.cpp keepSampleFrame: two full fits made the 64x64 default
// bake twice as slow), and then learns the field's basis once, in the frame kept: the field is the
// one an explicit --exit-frame of that frame bakes, byte for byte.
TEST(Bake, AutoExitFrameChoosesOnASubsetAndLearnsTheFieldOnce) {
  auto scene = makeBuiltinScene("torus", {.tessellation = 1});
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  BakeOptions options = autoFramePcaOptions(8, 8, 6000);  // over 2 x 2048 samples: the choice learns from a subset
  std::string notes;
  options.note = [&notes](const std::string& line) { notes += line + "\n"; };
  auto automatic = bakeField(*scene, options);
  ASSERT_TRUE(automatic.ok()) << automatic.error().message;
  const size_t at = notes.find("bases learned from ");
  ASSERT_NE(at, std::string::npos) << notes;
  const unsigned long learnedFrom = std::stoul(notes.substr(at + 19));
  std::printf("%s", notes.c_str());
  EXPECT_GE(learnedFrom, 2048u);
  EXPECT_LT(learnedFrom, automatic->statistics.samples / 2) << "the choice learned from the whole field";
  options.settings.exitFrame = automatic->sampleFrameExits ? ExitFrame::Sample : ExitFrame::Object;
  options.note = nullptr;
  auto explicitFrame = bakeField(*scene, options);
  ASSERT_TRUE(explicitFrame.ok()) << explicitFrame.error().message;
  EXPECT_EQ(dataBytes(automatic.value()), dataBytes(explicitFrame.value()));
}

// Under 2 x 2048 samples the choice learns both candidate bases from every sample, so the kept one
// is the field's basis: the bake keeps it rather than learning it again (bake/src/driver/basis.cpp keepSampleFrame),
// and the field is still the one an explicit --exit-frame of that frame bakes, byte for byte.
TEST(Bake, SmallAutoExitFrameKeepsTheChoicesBasis) {
  auto scene = makeBuiltinScene("torus", {.tessellation = 1});
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  BakeOptions options = autoFramePcaOptions(12, 16, 1500);
  std::string stages;
  options.stage = [&stages](const std::string& what) { stages += what + "\n"; };
  auto automatic = bakeField(*scene, options);
  ASSERT_TRUE(automatic.ok()) << automatic.error().message;
  ASSERT_LT(automatic->statistics.samples, 4096u);
  EXPECT_NE(stages.find("the exit frame's choice learned it"), std::string::npos) << stages;
  options.settings.exitFrame = automatic->sampleFrameExits ? ExitFrame::Sample : ExitFrame::Object;
  options.stage = nullptr;
  auto explicitFrame = bakeField(*scene, options);
  ASSERT_TRUE(explicitFrame.ok()) << explicitFrame.error().message;
  EXPECT_EQ(dataBytes(automatic.value()), dataBytes(explicitFrame.value()));
}

// A Pca bake keeps the mean tables of K clusters of its samples where they decode closer than K
// components to the views it traces for the choice (bake/src/driver/basis.cpp keepClusters; docs/encodings.md,
// "Clusters"). Its note gives both figures and the field follows the smaller. A clustered field
// stores each sample's cluster index (2 bytes), not K weights.
struct BasisChoice {
  Field field;
  double components = 0.0, clusters = 0.0;
  bool keptClusters = false;
  std::string note;  // the bake's "pca basis: chose ..." line
};

// expectChoice false: the bake is to make no choice (too few samples for the clusters).
BasisChoice bakeAndChooseBasis(const char* scene, uint32_t components, uint32_t clusters = 0, bool expectChoice = true,
                               bool moreClusters = false) {
  BakeSettings s = small();
  s.encoding = Encoding::Pca;
  s.order = 0;
  s.tableSize = 8;
  s.components = components;
  s.clusters = clusters;
  s.moreClusters = moreClusters;
  s.directionSampling = DirectionSampling::Nodes;
  s.exitFrame = ExitFrame::Sample;
  s.sampleBudget = 1500;
  BakeOptions options;
  options.settings = s;
  std::string notes;
  options.note = [&notes](const std::string& line) { notes += line + "\n"; };
  auto field = bakeField(makeBuiltinScene(scene, {.tessellation = 1}).value(), options);
  EXPECT_TRUE(field.ok()) << field.error().message;
  BasisChoice out{field.ok() ? std::move(field.value()) : Field{}};
  const size_t at = notes.find("pca basis: chose ");
  EXPECT_EQ(at != std::string::npos, expectChoice) << notes;
  if (at == std::string::npos) return out;
  const std::string line = notes.substr(at, notes.find('\n', at) - at);
  std::printf("%s: %s\n", scene, line.c_str());
  out.note = line;
  out.keptClusters = line.find("chose clusters") != std::string::npos;
  out.components = std::stod(line.substr(line.find("views: ") + 7));
  out.clusters = std::stod(line.substr(line.find("components, ") + 12));
  EXPECT_EQ(out.keptClusters, out.field.clustered);
  return out;
}

// Whether the field stores one function index per sample (EncodingShape::clustered: 2 bytes a
// sample) and its samples use more than one function.
bool storesIndices(const Field& f) {
  if (!f.clustered || f.bytesPerSample() != 2 || !f.coefficientsU8.empty() || !f.coefficientsF16.empty()) return false;
  std::vector<bool> used(f.components, false);
  for (uint64_t t = 0; t < uint64_t(f.width) * f.height; ++t)
    if (f.texelKinds[t] == kTexelSample) used.at(f.clusterIndices.at(t)) = true;
  return std::count(used.begin(), used.end(), true) > 1;
}

TEST(Bake, PcaKeepsClustersWhereTheyDecodeCloser) {
  // The sphere's samples are alike up to a rotation: 24 clusters hold its few distinct functions.
  const BasisChoice sphere = bakeAndChooseBasis("sphere", 24);
  EXPECT_TRUE(sphere.keptClusters);
  EXPECT_LT(sphere.clusters, sphere.components);
  EXPECT_TRUE(storesIndices(sphere.field));
  // The cube's functions vary along each face: 24 components follow them, 24 clusters do not.
  const BasisChoice cube = bakeAndChooseBasis("cube", 24);
  EXPECT_FALSE(cube.keptClusters);
  EXPECT_LT(cube.components, cube.clusters);
  EXPECT_FALSE(cube.field.clustered);
  EXPECT_EQ(cube.field.bytesPerSample(), 24u);
}

// BakeSettings::clusters: the clusters tried need not be as many as the components. A clustered
// field then holds that many tables (its components and settings say so) and 2 bytes a sample,
// whatever the count. (More clusters are not always closer: on this 1500-sample sphere of 8x8
// tables 96 read 1.512 deg on the views against 24's 1.483.)
TEST(Bake, PcaTriesTheClustersAskedFor) {
  const BasisChoice few = bakeAndChooseBasis("sphere", 24), more = bakeAndChooseBasis("sphere", 24, 96);
  ASSERT_TRUE(more.keptClusters);
  EXPECT_EQ(more.field.components, 96u);
  EXPECT_EQ(more.field.settings.components, 96u);
  EXPECT_EQ(more.field.settings.clusters, 96u);
  EXPECT_TRUE(storesIndices(more.field));
  EXPECT_EQ(more.field.basis.size(), size_t(96) * 8 * 8 * more.field.channels);
  EXPECT_EQ(more.components, few.components);  // the same 24 components are measured against them
  EXPECT_NE(more.clusters, few.clusters);
  // 1500 samples hold at most 187 clusters of 8 (bake/src/driver/basis.cpp kMinSamplesPerCluster): beyond, the
  // components stay without a try.
  const BasisChoice tooMany = bakeAndChooseBasis("sphere", 24, 200, false);
  EXPECT_FALSE(tooMany.field.clustered);
  EXPECT_EQ(tooMany.field.components, 24u);
}

// BakeSettings::moreClusters (the tool's default): without `clusters` the bake tries as many
// clusters as components and three times as many (bake/src/driver/basis.cpp kDefaultClustersPerComponent), where the
// samples hold 8 a cluster, and keeps the closest on the views: its note names both tries, and the
// field holds the closer one's tables. Without the flag only as many are tried (the tests above).
TEST(Bake, PcaTriesThreeTimesTheClustersByDefault) {
  const BasisChoice tried = bakeAndChooseBasis("sphere", 24, 0, true, true);
  const Field& f = tried.field;
  ASSERT_TRUE(f.clustered);
  // The note: "<components> deg with 24 components, <kept> deg with <N|as many> clusters; <other> deg with <M>, ..."
  const std::string line = tried.note;
  const size_t other = line.find("; ");
  ASSERT_NE(other, std::string::npos) << line;
  const double otherDegrees = std::stod(line.substr(other + 2));
  const uint32_t otherCount = uint32_t(std::stoul(line.substr(line.find(" deg with ", other) + 10)));
  EXPECT_LE(tried.clusters, otherDegrees);
  EXPECT_TRUE((f.components == 24u && otherCount == 72u) || (f.components == 72u && otherCount == 24u)) << line;
  EXPECT_EQ(f.settings.clusters, 0u);
  EXPECT_EQ(f.basis.size(), size_t(f.components) * 8 * 8 * f.channels);
  EXPECT_TRUE(storesIndices(f));
  // 64 components: 192 clusters would hold under 8 samples each of these ~1500, so only 64 are tried.
  const std::string one = bakeAndChooseBasis("sphere", 64, 0, true, true).note;
  EXPECT_EQ(one.find("; "), std::string::npos) << one;
}

// --max-bytes-per-sample measures its candidates on grid fits (Pca on 16x16 tables) but bakes a
// chosen Pca field in the requested shape, node tables of the requested size with the jump
// distance, as the tool's default is baked: a budget of the default's bytes gives the default's
// field (the tool's `bake --max-bytes-per-sample 324` and its default agree: docs/encodings.md).
// An SH or Table choice stays a grid fit.
TEST(Bake, BudgetBakesAChosenPcaFieldInTheRequestedShape) {
  BakeSettings s = small();
  s.encoding = Encoding::Pca;
  s.tableSize = 12;  // kJumpMinTableSize: the smallest with the jump distance
  s.components = 40;
  s.directionSampling = DirectionSampling::Nodes;
  s.maxBytesPerSample = 40.0f;
  s.source = "builtin:torus";
  BuiltinSceneOptions so;
  so.tessellation = 1;
  std::string notes;
  BakeOptions options;
  options.settings = s;
  options.note = [&notes](const std::string& line) { notes += line + "\n"; };
  auto field = bakeField(makeBuiltinScene("torus", so).value(), options);
  ASSERT_TRUE(field.ok()) << field.error().message;
  const Field& f = field.value();
  std::printf("%s", notes.c_str());
  ASSERT_EQ(f.encoding, Encoding::Pca) << "the torus at 40 bytes chose another encoding; the test needs Pca:\n" << notes;
  EXPECT_EQ(f.settings.directionSampling, DirectionSampling::Nodes);
  EXPECT_EQ(f.tableSize, 12u);
  EXPECT_TRUE(f.jumpDistance);
  EXPECT_LE(f.bytesPerSample(), 40u);
  EXPECT_NE(notes.find("baking the pca field on 12x12 node tables"), std::string::npos) << notes;

  // The same budget asking for grid sampling keeps the probe's shape.
  options.settings.directionSampling = DirectionSampling::Grid;
  auto grid = bakeField(makeBuiltinScene("torus", so).value(), options);
  ASSERT_TRUE(grid.ok()) << grid.error().message;
  EXPECT_EQ(grid.value().encoding, Encoding::Pca);
  EXPECT_EQ(grid.value().settings.directionSampling, DirectionSampling::Grid);
  EXPECT_EQ(grid.value().tableSize, 16u);
  EXPECT_FALSE(grid.value().jumpDistance);
}

// The --max-error and --max-bytes-per-sample searches run their probes in parallelFor (oneTBB):
// their choice and the field must not depend on the thread count either.
// Besides the field, the notes (each candidate's measured error, printed to 4 digits) must match.
TEST(Bake, SearchesAreDeterministicAcrossThreadCounts) {
  BakeSettings error = small(), bytes = small();
  error.maxErrorDegrees = 6.0f;
  bytes.maxBytesPerSample = 40.0f;
  auto run = [](BakeSettings s, uint32_t threads, std::string& notes) {
    s.threads = threads;
    s.source = "builtin:torus";
    BuiltinSceneOptions so;
    so.tessellation = 1;
    BakeOptions options;
    options.settings = s;
    options.note = [&notes](const std::string& line) { notes += line + "\n"; };
    auto field = bakeField(makeBuiltinScene("torus", so).value(), options);
    EXPECT_TRUE(field.ok()) << (field.ok() ? "" : field.error().message);
    return field.ok() ? dataBytes(std::move(field).value()) : std::vector<uint8_t>{};
  };
  for (const BakeSettings& s : {error, bytes}) {
    std::string notesOne, notesThree;
    EXPECT_EQ(run(s, 1, notesOne), run(s, 3, notesThree));
    EXPECT_FALSE(notesOne.empty());
    EXPECT_EQ(notesOne, notesThree);
  }
}

TEST(Bake, AbsorbingMediaKeepTheOpticalDepthChannel) {
  BakeSettings s = small();
  s.sampleBudget = 3000;
  const Field f = bake("glass-of-water", s, 1);
  EXPECT_EQ(f.channels, 4u);
  EXPECT_EQ(f.media.size(), 3u);
  // Some optical depth must have been recorded: the DC term of tau is positive somewhere.
  float maxTau = 0.0f;
  for (uint64_t t = 0; t < f.texelCount(); ++t)
    if (f.texelKinds[t] == kTexelSample) maxTau = std::max(maxTau, fieldCoefficient(f, 0, t, 3));
  EXPECT_GT(maxTau, 0.0f);
}

TEST(Bake, FitErrorFallsAsTheOrderRises) {
  float previous = 1e9f;
  for (uint32_t order : {1u, 4u, 8u}) {
    BakeSettings s = small();
    s.order = order;
    s.directionsTheta = 16;
    s.directionsPhi = 32;
    s.sampleBudget = 700;
    const Field f = bake("sphere", s, 2);
    std::printf("sphere order %u: held-out RMS %.3f deg, grid RMS %.3f deg\n", order,
                static_cast<double>(f.statistics.heldOutRmsDegrees), static_cast<double>(f.statistics.fitRmsDegrees));
    EXPECT_LT(f.statistics.fitRmsDegrees, previous);
    previous = f.statistics.fitRmsDegrees;
  }
}

// A table traced at its nodes holds every traced exit as it is: its fit at the nodes is exact but
// for float rounding, the border nodes too (traced lifted above the horizon, they must be checked
// at their own place in the table, not at the lifted direction, which the table maps inside the
// border; checked there, this torus read 5.1 deg RMS, 163 deg at most). The torus's grazing paths
// jump between the border row and the next, so a check off the nodes cannot pass. A Pca field
// with all its components is the same table, up to the decomposition's rounding.
TEST(Bake, NodeTablesFitTheirOwnNodesExactly) {
  const Field table = bake("torus", tracedAtTheNodes(Encoding::Table, 16, 500));
  ASSERT_GT(table.statistics.samples, 0u);
  std::printf("torus table 16x16 at its nodes: fit RMS %.4f deg, max %.4f deg\n",
              static_cast<double>(table.statistics.fitRmsDegrees), static_cast<double>(table.statistics.fitMaxDegrees));
  EXPECT_LT(table.statistics.fitRmsDegrees, 0.02f);
  EXPECT_LT(table.statistics.fitMaxDegrees, 0.2f);
  EXPECT_GT(table.statistics.heldOutRmsDegrees, 1.0f) << "the held-out check must still see the interpolation";
}

// The same for a Pca field with as many components as the table has values: its weights span
// every sample's table, so its fit at the nodes is exact but for the decomposition's rounding. The
// check decodes each checked sample's weights summed into its table (bake/src/driver/bake_driver.h,
// ManyDirectionDecoder); a sum that dropped or misplaced a component would read degrees here.
TEST(Bake, FullRankPcaFitsItsOwnNodesExactly) {
  BakeSettings s = tracedAtTheNodes(Encoding::Pca, 12, 800);
  s.components = 12 * 12 * 5;  // x, y, z, the glass's optical depth and the jump distance
  s.quantization = Quantization::F16;
  const Field pca = bake("torus", s);
  ASSERT_EQ(pca.channels, 5u);
  ASSERT_GT(pca.statistics.samples, 0u);
  ASSERT_FALSE(pca.clustered);
  std::printf("torus pca K=%u 12x12 at its nodes: fit RMS %.4f deg, max %.4f deg; quantization RMS %.4f deg\n",
              pca.components, static_cast<double>(pca.statistics.fitRmsDegrees),
              static_cast<double>(pca.statistics.fitMaxDegrees), static_cast<double>(pca.statistics.quantizationRmsDegrees));
  EXPECT_LT(pca.statistics.fitRmsDegrees, 0.02f);
  EXPECT_LT(pca.statistics.fitMaxDegrees, 0.2f);
  EXPECT_GT(pca.statistics.quantizationRmsDegrees, 0.0f) << "f16 weights round: the check must see it";
  EXPECT_LT(pca.statistics.quantizationRmsDegrees, 0.05f);
}

TEST(Bake, QuantizationAndLayoutsAndSmoothing) {
  BakeSettings s = small();
  s.quantization = Quantization::F16;
  const Field f16 = bake("sphere", s);
  s.quantization = Quantization::U8;
  const Field u8 = bake("sphere", s);
  EXPECT_LT(f16.statistics.quantizationRmsDegrees, u8.statistics.quantizationRmsDegrees);
  EXPECT_TRUE(f16.coefficientsU8.empty());
  EXPECT_FALSE(f16.coefficientsF16.empty());

  s.layout = SampleLayout::Charts;
  const Field charts = bake("cube", s, 1);
  EXPECT_TRUE(validateField(charts).ok());
  EXPECT_TRUE(charts.gutters.empty());

  s.layout = SampleLayout::Split;
  s.window = SmoothingWindow::Hann;
  s.spatialNeighbours = 5;
  const Field smooth = bake("sphere", s);
  EXPECT_TRUE(validateField(smooth).ok());
}

TEST(Bake, MaxErrorPicksTheCheapestOrderThatMeetsTheTarget) {
  BakeSettings s = small();
  s.order = 6;
  s.directionsTheta = 16;
  s.directionsPhi = 32;
  s.maxErrorDegrees = 60.0f;  // anything meets it: order 0 on the coarsest grid
  const Field loose = bake("sphere", s);
  EXPECT_EQ(loose.order, 0u);
  EXPECT_EQ(loose.settings.directionsTheta, 8u);
  EXPECT_EQ(loose.settings.maxErrorDegrees, 60.0f);
  s.maxErrorDegrees = 0.001f;  // nothing meets it: the ceiling is used
  const Field tight = bake("sphere", s);
  EXPECT_EQ(tight.order, 6u);
  EXPECT_EQ(tight.settings.directionsTheta, 16u);
  s.maxErrorDegrees = 6.0f;
  const Field mid = bake("sphere", s);
  EXPECT_GT(mid.order, 0u);
  EXPECT_LE(mid.order, 6u);
  // What was chosen is stored and survives the file.
  auto parsed = parseField(serializeField(mid).data(), serializeField(mid).size(), "mid.shrf");
  ASSERT_TRUE(parsed.ok());
  EXPECT_EQ(parsed.value().settings.maxErrorDegrees, 6.0f);
  EXPECT_EQ(parsed.value().order, mid.order);
}

TEST(Bake, RejectsBadSettings) {
  auto scene = makeBuiltinScene("sphere");
  ASSERT_TRUE(scene.ok());
  BakeOptions o;
  o.settings = small();
  o.settings.spatialNeighbours = 4;
  EXPECT_FALSE(bakeField(scene.value(), o).ok());
  o.settings = small();
  o.settings.order = 99;
  EXPECT_FALSE(bakeField(scene.value(), o).ok());
  o.settings = small();
  o.settings.directionsTheta = 0;
  EXPECT_FALSE(bakeField(scene.value(), o).ok());
  o.settings = small();
  o.settings.maxErrorDegrees = -1.0f;
  EXPECT_FALSE(bakeField(scene.value(), o).ok());
}

bool sameBits(const PathResult& a, const PathResult& b) {
  const auto same = [](const auto& x, const auto& y) { return std::memcmp(&x, &y, sizeof x) == 0; };
  return same(a.exitDirection, b.exitDirection) && same(a.opticalDepth, b.opticalDepth) && same(a.energy, b.energy) &&
         a.interactions == b.interactions && a.rays == b.rays && a.labelConflicts == b.labelConflicts &&
         a.trapped == b.trapped;
}

// The bake traces all directions of a sample in one call (several paths in flight, their hits
// prefetched); the field may not depend on it. Every path of the batch must be the single call's,
// bit for bit: nested and absorbing media (glass of water), re-entry (torus), a coarse sphere
// (grazing shading-normal fallbacks), both path rules, a low cap, invalid directions among valid
// ones, and points without a valid triangle or surface.
TEST(BakeTracing, BatchOfDirectionsIsSinglePathsBitForBit) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const DirectionGrid grid = makeHemisphereGrid(8, 16);
  for (const auto& [name, tessellation] : {std::pair{"glass-of-water", 1}, {"torus", 2}, {"sphere", 0}}) {
    BuiltinSceneOptions so;
    so.tessellation = tessellation;
    const Result<Scene> scene = makeBuiltinScene(name, so);
    ASSERT_TRUE(scene.ok()) << name;
    auto tracer = Tracer::create(scene.value());
    ASSERT_TRUE(tracer.ok()) << name;
    LayoutOptions lo;
    lo.sampleBudget = 150;
    auto atlas = buildChartsLayout(scene.value(), lo);
    ASSERT_TRUE(atlas.ok()) << name;
    std::vector<SurfacePoint> points(atlas.value().samples.begin(), atlas.value().samples.begin() + 60);
    SurfacePoint noTriangle = points[0], noSurface = points[1];
    noTriangle.triangle = 0xFFFFFFFFu;  // falls back to the point's own normals
    noSurface.surface = 1000;           // every path invalid
    points.push_back(noTriangle);
    points.push_back(noSurface);

    TraceSettings capped;
    capped.maxBounces = 2;
    TraceSettings firstRefraction;
    firstRefraction.pathRule = PathRule::FirstRefraction;
    size_t paths = 0, mismatches = 0, longPaths = 0, trapped = 0;
    for (const TraceSettings& settings : {TraceSettings{}, capped, firstRefraction}) {
      for (size_t p = 0; p < points.size(); ++p) {
        const LocalFrame frame = frameAt(points[p]);
        std::vector<glm::vec3> incidents;
        for (const glm::dvec3& w : grid.directions) incidents.push_back(-localToWorld(frame, glm::vec3(w)));
        incidents[p % incidents.size()] = glm::vec3(0.0f);
        incidents[(p + 7) % incidents.size()] = glm::vec3(nan, 0.0f, 1.0f);
        std::vector<PathResult> batch(incidents.size());
        tracer.value()->traceFromSurface(points[p], incidents, settings, batch);
        for (size_t i = 0; i < incidents.size(); ++i) {
          const PathResult single = tracer.value()->traceFromSurface(points[p], incidents[i], settings);
          mismatches += sameBits(single, batch[i]) ? 0 : 1;
          longPaths += single.interactions >= 3 ? 1 : 0;
          trapped += single.trapped ? 1 : 0;
          ++paths;
        }
      }
    }
    EXPECT_EQ(mismatches, 0u) << name << ": of " << paths << " paths";
    EXPECT_GT(longPaths, paths / 50) << name << ": paths of different lengths share the batch";
    const size_t invalid = 3 * (2 * (points.size() - 1) + grid.directions.size());
    EXPECT_GT(trapped, invalid + paths / 100) << name << ": beyond the invalid ones, some paths are capped";
  }
}

}  // namespace
}  // namespace shrefract::bake
