// glTF import: files written here (JSON with data-URI buffers, and GLB from a minimal writer), so
// the test needs nothing from outside the repository. Cubes have analytic volumes and normals.
#include "import/gltf_import_fixture.h"

namespace shrefract::bake {
namespace {

// Float tolerance on positions and normals computed in double and stored as float.
constexpr float kTolerance = 1e-5f;

// Every normal unit and pointing away from `center` (true for convex shapes around it).
void expectOutwardUnitNormals(const Surface& surface, glm::vec3 center) {
  ASSERT_EQ(surface.normals.size(), surface.positions.size());
  for (size_t i = 0; i < surface.normals.size(); ++i) {
    EXPECT_NEAR(glm::length(surface.normals[i]), 1.0f, kTolerance) << i;
    EXPECT_GT(glm::dot(surface.normals[i], surface.positions[i] - center), 0.0f) << i;
  }
}

TEST_F(GltfImport, CubeWithIorAndAttenuation) {
  json material = glassMaterial(1.33, "water");
  material["extensions"]["KHR_materials_volume"]["attenuationDistance"] = 2.0;
  material["extensions"]["KHR_materials_volume"]["attenuationColor"] = {0.5, 0.25, 1.0};
  CubeFile f = cubeFile(makeCube(), material);
  ImportReport report;
  const Scene scene = importOk(f.writer.writeGltf(file("cube.gltf")), {}, &report);
  ASSERT_EQ(scene.surfaces.size(), 1u);
  ASSERT_EQ(scene.media.size(), 2u);
  EXPECT_EQ(scene.media[0].ior, 1.0f);
  EXPECT_EQ(scene.media[0].absorption, 0.0f);
  EXPECT_EQ(scene.media[1].name, "water");
  EXPECT_FLOAT_EQ(scene.media[1].ior, 1.33f);
  // Documented rule: absorption = mean over channels of -ln(c) / d, colour = c / max(c).
  const double expected = (-std::log(0.5) - std::log(0.25) - std::log(1.0)) / 2.0 / 3.0;
  EXPECT_NEAR(scene.media[1].absorption, expected, 1e-6);
  EXPECT_NEAR(scene.media[1].color.x, 0.5f, 1e-6f);
  EXPECT_NEAR(scene.media[1].color.y, 0.25f, 1e-6f);
  EXPECT_NEAR(scene.media[1].color.z, 1.0f, 1e-6f);

  const Surface& s = scene.surfaces[0];
  EXPECT_EQ(s.innerMedium, 1u);
  EXPECT_EQ(s.outerMedium, 0u);
  EXPECT_EQ(s.positions.size(), 8u);
  EXPECT_EQ(s.indices.size(), 36u);
  EXPECT_TRUE(s.uvs.empty());
  EXPECT_TRUE(checkSurface(s).closed());
  EXPECT_TRUE(checkMediumClosure(scene, 1).closed());
  EXPECT_NEAR(signedVolume(scene, 1), 8.0, 1e-9);
  expectOutwardUnitNormals(s, glm::vec3(0.0f));
  EXPECT_TRUE(validateScene(scene).ok());

  EXPECT_EQ(report.meshes, 1u);
  EXPECT_EQ(report.primitives, 1u);
  EXPECT_EQ(report.triangles, 12u);
  EXPECT_TRUE(report.warnings.empty()) << report.warnings.front();
}

TEST_F(GltfImport, GreyAttenuationGoesIntoAbsorptionOnly) {
  json material = glassMaterial(1.5);
  material["extensions"]["KHR_materials_volume"]["attenuationDistance"] = 4.0;
  material["extensions"]["KHR_materials_volume"]["attenuationColor"] = {0.2, 0.4, 0.2};
  CubeFile f = cubeFile(makeCube(), material);
  const Scene scene = importOk(f.writer.writeGltf(file("grey.gltf")));
  ASSERT_EQ(scene.media.size(), 2u);
  const double expected = -(2.0 * std::log(0.2) + std::log(0.4)) / 4.0 / 3.0;
  EXPECT_NEAR(scene.media[1].absorption, expected, 1e-6);
  // The tint keeps the hue only: brightest channel 1.
  EXPECT_NEAR(scene.media[1].color.x, 0.5f, 1e-6f);
  EXPECT_NEAR(scene.media[1].color.y, 1.0f, 1e-6f);
  EXPECT_NEAR(scene.media[1].color.z, 0.5f, 1e-6f);
}

TEST_F(GltfImport, NoAttenuationDistanceMeansClear) {
  json material = glassMaterial(1.5);
  material["extensions"]["KHR_materials_volume"]["attenuationColor"] = {0.5, 0.5, 0.5};
  CubeFile f = cubeFile(makeCube(), material);
  const Scene scene = importOk(f.writer.writeGltf(file("clear.gltf")));
  ASSERT_EQ(scene.media.size(), 2u);
  EXPECT_EQ(scene.media[1].absorption, 0.0f);
  EXPECT_EQ(scene.media[1].color, glm::vec3(1.0f));
}

TEST_F(GltfImport, NodeTransformAppliesToPositionsAndNormals) {
  const glm::dvec3 translation(1.0, 2.0, 3.0);
  const glm::dquat rotation = glm::angleAxis(0.7, glm::normalize(glm::dvec3(1.0, 2.0, 0.5)));
  const glm::dvec3 scale(2.0, 0.5, 1.5);
  json node = {{"translation", {translation.x, translation.y, translation.z}},
               {"rotation", {rotation.x, rotation.y, rotation.z, rotation.w}},
               {"scale", {scale.x, scale.y, scale.z}}};
  // The node sits under a parent that translates again: transforms compose.
  const Cube cube = makeCube();
  CubeFile f = cubeFile(cube, glassMaterial(1.5), node);
  const int parent = f.writer.addNode({{"translation", {0.0, 0.0, -10.0}}, {"children", {f.node}}});
  f.writer.setScene({parent});
  const Scene scene = importOk(f.writer.writeGltf(file("transform.gltf")));
  ASSERT_EQ(scene.surfaces.size(), 1u);
  const Surface& s = scene.surfaces[0];
  ASSERT_EQ(s.positions.size(), 8u);

  const glm::dmat3 rs = glm::mat3_cast(rotation) * glm::dmat3(glm::dvec3(scale.x, 0, 0),
                                                              glm::dvec3(0, scale.y, 0),
                                                              glm::dvec3(0, 0, scale.z));
  const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(rs));
  const glm::dvec3 offset = translation + glm::dvec3(0.0, 0.0, -10.0);
  for (size_t i = 0; i < cube.positions.size(); ++i) {
    const glm::vec3 expectedPosition(rs * glm::dvec3(cube.positions[i]) + offset);
    const glm::vec3 expectedNormal(glm::normalize(normalMatrix * glm::dvec3(cube.normals[i])));
    // Vertices may be reordered by the import: find the one at this position.
    const auto it = std::find_if(s.positions.begin(), s.positions.end(), [&](glm::vec3 p) {
      return glm::length(p - expectedPosition) < 1e-4f;
    });
    ASSERT_NE(it, s.positions.end()) << "corner " << i;
    const glm::vec3 normal = s.normals[static_cast<size_t>(it - s.positions.begin())];
    EXPECT_NEAR(normal.x, expectedNormal.x, kTolerance) << i;
    EXPECT_NEAR(normal.y, expectedNormal.y, kTolerance) << i;
    EXPECT_NEAR(normal.z, expectedNormal.z, kTolerance) << i;
  }
  // Volume scales with the determinant.
  EXPECT_NEAR(signedVolume(scene, 1), 8.0 * scale.x * scale.y * scale.z, 1e-4);
}

TEST_F(GltfImport, MatrixNodeTransform) {
  // Column-major: scale 3 and translate (5, 0, 0).
  json node = {{"matrix", {3, 0, 0, 0, 0, 3, 0, 0, 0, 0, 3, 0, 5, 0, 0, 1}}};
  CubeFile f = cubeFile(makeCube(), glassMaterial(1.5), node);
  const Scene scene = importOk(f.writer.writeGltf(file("matrix.gltf")));
  ASSERT_EQ(scene.surfaces.size(), 1u);
  const Bounds b = bounds(scene);
  EXPECT_NEAR(b.min.x, 2.0f, kTolerance);
  EXPECT_NEAR(b.max.x, 8.0f, kTolerance);
  EXPECT_NEAR(b.max.y, 3.0f, kTolerance);
  EXPECT_NEAR(signedVolume(scene, 1), 216.0, 1e-3);
}

TEST_F(GltfImport, MirroredNodeKeepsOutwardWinding) {
  CubeFile f = cubeFile(makeCube(1.0f, glm::vec3(2.0f, 0.0f, 0.0f)), glassMaterial(1.5),
                        {{"scale", {-1.0, 1.0, 1.0}}});
  ImportReport report;
  const Scene scene = importOk(f.writer.writeGltf(file("mirror.gltf")), {}, &report);
  ASSERT_EQ(scene.surfaces.size(), 1u);
  EXPECT_GT(signedVolume(scene, 1), 7.99);
  EXPECT_TRUE(checkMediumClosure(scene, 1).closed());
  expectOutwardUnitNormals(scene.surfaces[0], glm::vec3(-2.0f, 0.0f, 0.0f));
  // The mirror is handled by the transform, not by the inside-out repair.
  EXPECT_FALSE(anyWarningContains(report, "inside out"));
}

TEST_F(GltfImport, InsideOutCubeIsTurnedOutward) {
  Cube cube = makeCube();
  for (size_t t = 0; t < cube.indices.size(); t += 3) {
    std::swap(cube.indices[t + 1], cube.indices[t + 2]);
  }
  CubeFile f = cubeFile(cube, glassMaterial(1.5), json::object(), /*withNormals=*/false);
  ImportReport report;
  const Scene scene = importOk(f.writer.writeGltf(file("insideout.gltf")), {}, &report);
  EXPECT_NEAR(signedVolume(scene, 1), 8.0, 1e-9);
  EXPECT_TRUE(anyWarningContains(report, "inside out"));
  expectOutwardUnitNormals(scene.surfaces[0], glm::vec3(0.0f));
}

TEST_F(GltfImport, NestedCubesTakeTheirContainerAsOuterMedium) {
  GltfWriter w;
  const Cube big = makeCube(2.0f);
  const Cube small = makeCube(0.5f, glm::vec3(0.3f, -0.2f, 0.1f));
  const int bigMaterial = w.addMaterial(glassMaterial(1.5, "glass"));
  const int smallMaterial = w.addMaterial(glassMaterial(1.33, "water"));
  auto mesh = [&w](const Cube& cube, int material, const std::string& name) {
    const json attributes = {{"POSITION", w.addVec3(cube.positions)},
                             {"NORMAL", w.addVec3(cube.normals)}};
    return w.addMesh(json::array({json{{"attributes", attributes},
                                       {"indices", w.addIndices(cube.indices)},
                                       {"material", material}}}),
                     name);
  };
  // The small cube first, so that the order of nodes does not decide nesting.
  const int smallNode = w.addNode({{"mesh", mesh(small, smallMaterial, "small")}, {"name", "in"}});
  const int bigNode = w.addNode({{"mesh", mesh(big, bigMaterial, "big")}, {"name", "out"}});
  w.setScene({smallNode, bigNode});
  const Scene scene = importOk(w.writeGltf(file("nested.gltf")));
  ASSERT_EQ(scene.surfaces.size(), 2u);
  ASSERT_EQ(scene.media.size(), 3u);
  const Surface& inner = scene.surfaces[0];
  const Surface& outer = scene.surfaces[1];
  EXPECT_EQ(inner.name, "in/small");
  EXPECT_EQ(outer.name, "out/big");
  EXPECT_EQ(scene.media[inner.innerMedium].name, "water");
  EXPECT_EQ(scene.media[outer.innerMedium].name, "glass");
  EXPECT_EQ(inner.outerMedium, outer.innerMedium);
  EXPECT_EQ(outer.outerMedium, 0u);
  EXPECT_TRUE(checkMediumClosure(scene, outer.innerMedium).closed());
  EXPECT_TRUE(checkMediumClosure(scene, inner.innerMedium).closed());
  EXPECT_NEAR(signedVolume(scene, outer.innerMedium), 64.0 - 1.0, 1e-6);
  EXPECT_NEAR(signedVolume(scene, inner.innerMedium), 1.0, 1e-6);
}

TEST_F(GltfImport, NestedVolumesOfOneMaterialAreAnError) {
  GltfWriter w;
  const Cube big = makeCube(2.0f);
  const Cube small = makeCube(0.5f);
  const int material = w.addMaterial(glassMaterial(1.5));
  auto mesh = [&](const Cube& cube) {
    return w.addMesh(json::array({json{{"attributes", {{"POSITION", w.addVec3(cube.positions)}}},
                                       {"indices", w.addIndices(cube.indices)},
                                       {"material", material}}}));
  };
  const int a = w.addNode({{"mesh", mesh(big)}});
  const int b = w.addNode({{"mesh", mesh(small)}});
  w.setScene({a, b});
  expectError(w.writeGltf(file("same.gltf")), ErrorCode::InvalidArgument, {"same medium"});
}

TEST_F(GltfImport, SeparateVolumesOfOneMaterialShareAMedium) {
  GltfWriter w;
  const Cube cube = makeCube();
  const int material = w.addMaterial(glassMaterial(1.5));
  const int mesh =
      w.addMesh(json::array({json{{"attributes", {{"POSITION", w.addVec3(cube.positions)}}},
                                  {"indices", w.addIndices(cube.indices)},
                                  {"material", material}}}));
  const int a = w.addNode({{"mesh", mesh}, {"translation", {-3.0, 0.0, 0.0}}});
  const int b = w.addNode({{"mesh", mesh}, {"translation", {3.0, 0.0, 0.0}}});
  w.setScene({a, b});
  ImportReport report;
  const Scene scene = importOk(w.writeGltf(file("two.gltf")), {}, &report);
  ASSERT_EQ(scene.surfaces.size(), 2u);
  EXPECT_EQ(scene.media.size(), 2u);
  EXPECT_EQ(scene.surfaces[0].outerMedium, 0u);
  EXPECT_EQ(scene.surfaces[1].outerMedium, 0u);
  EXPECT_NEAR(signedVolume(scene, 1), 16.0, 1e-6);
  EXPECT_EQ(report.meshes, 2u);
  EXPECT_EQ(report.triangles, 24u);
}

TEST_F(GltfImport, GlbRoundTrip) {
  json material = glassMaterial(1.33);
  material["extensions"]["KHR_materials_volume"]["attenuationDistance"] = 0.5;
  CubeFile f = cubeFile(makeCube(), material);
  const Scene fromGltf = importOk(f.writer.writeGltf(file("cube.gltf")));
  // The extension is matched case-insensitively.
  const Scene fromGlb = importOk(f.writer.writeGlb(file("cube.GLB")));
  ASSERT_EQ(fromGlb.surfaces.size(), 1u);
  ASSERT_EQ(fromGltf.surfaces.size(), 1u);
  EXPECT_EQ(fromGlb.surfaces[0].positions, fromGltf.surfaces[0].positions);
  EXPECT_EQ(fromGlb.surfaces[0].normals, fromGltf.surfaces[0].normals);
  EXPECT_EQ(fromGlb.surfaces[0].indices, fromGltf.surfaces[0].indices);
  EXPECT_EQ(fromGlb.media[1].ior, fromGltf.media[1].ior);
  EXPECT_EQ(fromGlb.media[1].absorption, 0.0f);  // colour (1,1,1): -ln(1) = 0
  EXPECT_TRUE(checkMediumClosure(fromGlb, 1).closed());
}

TEST_F(GltfImport, ExternalBufferFile) {
  CubeFile f = cubeFile();
  json doc = f.writer.finished(true);
  // Recreate the buffer as an external .bin next to the .gltf.
  const std::string glb = f.writer.writeGlb(file("tmp.glb"));
  const std::string bytes = readFile(glb);
  uint32_t jsonLength = 0;
  std::memcpy(&jsonLength, bytes.data() + 12, 4);
  const size_t binStart = 12 + 8 + jsonLength + 8;
  std::ofstream(file("cube.bin"), std::ios::binary)
      .write(bytes.data() + binStart, static_cast<std::streamsize>(bytes.size() - binStart));
  doc["buffers"][0]["uri"] = "cube.bin";
  std::ofstream(file("external.gltf")) << doc.dump();
  const Scene scene = importOk(file("external.gltf").string());
  ASSERT_EQ(scene.surfaces.size(), 1u);
  EXPECT_EQ(triangles(scene), 12u);
}

TEST_F(GltfImport, NonIndexedFlatCube) {
  const Cube cube = makeCube();
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;
  for (size_t t = 0; t < cube.indices.size(); t += 3) {
    const glm::vec3 a = cube.positions[cube.indices[t]];
    const glm::vec3 b = cube.positions[cube.indices[t + 1]];
    const glm::vec3 c = cube.positions[cube.indices[t + 2]];
    const glm::vec3 n = glm::normalize(glm::cross(b - a, c - a));
    positions.insert(positions.end(), {a, b, c});
    normals.insert(normals.end(), {n, n, n});
  }
  GltfWriter w;
  const int material = w.addMaterial(glassMaterial(1.5));
  const json attributes = {{"POSITION", w.addVec3(positions)}, {"NORMAL", w.addVec3(normals)}};
  const int mesh =
      w.addMesh(json::array({json{{"attributes", attributes}, {"material", material}}}));
  w.setScene({w.addNode({{"mesh", mesh}})});
  const Scene scene = importOk(w.writeGltf(file("flat.gltf")));
  ASSERT_EQ(scene.surfaces.size(), 1u);
  EXPECT_EQ(scene.surfaces[0].positions.size(), 36u);
  EXPECT_EQ(triangles(scene), 12u);
  EXPECT_TRUE(checkSurface(scene.surfaces[0]).closed());  // closed by position
  EXPECT_NEAR(signedVolume(scene, 1), 8.0, 1e-9);
}

TEST_F(GltfImport, InterleavedAttributesWithByteStride) {
  const Cube cube = makeCube();
  std::vector<float> interleaved;
  for (size_t i = 0; i < cube.positions.size(); ++i) {
    interleaved.insert(interleaved.end(), {cube.positions[i].x, cube.positions[i].y,
                                           cube.positions[i].z, cube.normals[i].x,
                                           cube.normals[i].y, cube.normals[i].z});
  }
  GltfWriter w;
  const int view = w.addView(interleaved.data(), interleaved.size() * sizeof(float), 24);
  const int positions = w.addAccessor(view, kFloat, 8, "VEC3");
  const int normals = w.addAccessor(view, kFloat, 8, "VEC3", 12);
  const int material = w.addMaterial(glassMaterial(1.5));
  const int mesh =
      w.addMesh(json::array({json{{"attributes", {{"POSITION", positions}, {"NORMAL", normals}}},
                                  {"indices", w.addIndices(cube.indices)},
                                  {"material", material}}}));
  w.setScene({w.addNode({{"mesh", mesh}})});
  const Scene scene = importOk(w.writeGltf(file("interleaved.gltf")));
  ASSERT_EQ(scene.surfaces.size(), 1u);
  EXPECT_NEAR(signedVolume(scene, 1), 8.0, 1e-9);
  expectOutwardUnitNormals(scene.surfaces[0], glm::vec3(0.0f));
}

TEST_F(GltfImport, SmallIndexTypes) {
  for (int type : {kUnsignedByte, kUnsignedShort, kUnsignedInt}) {
    CubeFile f = cubeFile(makeCube(), glassMaterial(1.5), json::object(), true, type);
    const Scene scene = importOk(f.writer.writeGltf(file("idx" + std::to_string(type) + ".gltf")));
    ASSERT_EQ(scene.surfaces.size(), 1u) << type;
    EXPECT_EQ(triangles(scene), 12u) << type;
    EXPECT_TRUE(checkSurface(scene.surfaces[0]).closed()) << type;
  }
}

TEST_F(GltfImport, MissingNormalsAreComputed) {
  CubeFile f = cubeFile(makeCube(), glassMaterial(1.5), json::object(), /*withNormals=*/false);
  ImportReport report;
  const Scene scene = importOk(f.writer.writeGltf(file("nonormals.gltf")), {}, &report);
  ASSERT_EQ(scene.surfaces.size(), 1u);
  EXPECT_TRUE(anyWarningContains(report, "normals computed"));
  expectOutwardUnitNormals(scene.surfaces[0], glm::vec3(0.0f));
  // Each face's split into two triangles weights the corners unevenly, so the computed corner
  // normals are not exactly the diagonals; they do stay in their corner's octant.
  for (size_t i = 0; i < scene.surfaces[0].positions.size(); ++i) {
    const glm::vec3 p = scene.surfaces[0].positions[i];
    const glm::vec3 n = scene.surfaces[0].normals[i];
    EXPECT_GT(n.x * p.x, 0.0f);
    EXPECT_GT(n.y * p.y, 0.0f);
    EXPECT_GT(n.z * p.z, 0.0f);
  }
}

TEST_F(GltfImport, NormalizedTexcoords) {
  const Cube cube = makeCube();
  GltfWriter w;
  std::vector<uint16_t> uv;
  for (size_t i = 0; i < 8; ++i) {
    uv.push_back(static_cast<uint16_t>(i * 8191));
    uv.push_back(65535);
  }
  const int uvView = w.addView(uv.data(), uv.size() * sizeof(uint16_t));
  const int uvAccessor = w.addAccessor(uvView, kUnsignedShort, 8, "VEC2", 0, /*normalized=*/true);
  const int material = w.addMaterial(glassMaterial(1.5));
  const int mesh = w.addMesh(json::array({json{
      {"attributes", {{"POSITION", w.addVec3(cube.positions)}, {"TEXCOORD_0", uvAccessor}}},
      {"indices", w.addIndices(cube.indices)},
      {"material", material}}}));
  w.setScene({w.addNode({{"mesh", mesh}})});
  const Scene scene = importOk(w.writeGltf(file("uv.gltf")));
  ASSERT_EQ(scene.surfaces.size(), 1u);
  const Surface& s = scene.surfaces[0];
  ASSERT_EQ(s.uvs.size(), s.positions.size());
  for (size_t i = 0; i < s.positions.size(); ++i) {
    // Recover the corner index from the position (bit k set when coordinate k is +1).
    const size_t corner = (s.positions[i].x > 0 ? 1u : 0u) | (s.positions[i].y > 0 ? 2u : 0u) |
                          (s.positions[i].z > 0 ? 4u : 0u);
    EXPECT_NEAR(s.uvs[i].x, static_cast<float>(corner * 8191) / 65535.0f, 1e-6f);
    EXPECT_EQ(s.uvs[i].y, 1.0f);
  }
}

TEST_F(GltfImport, DegenerateTrianglesAreDropped) {
  Cube cube = makeCube();
  cube.indices.insert(cube.indices.end(), {0, 0, 1, 2, 3, 3});
  CubeFile f = cubeFile(cube);
  ImportReport report;
  const Scene scene = importOk(f.writer.writeGltf(file("degenerate.gltf")), {}, &report);
  EXPECT_EQ(triangles(scene), 12u);
  EXPECT_EQ(report.triangles, 12u);
  EXPECT_TRUE(anyWarningContains(report, "dropped 2 degenerate"));
}

// Meshes as exporters write them (docs/scenes.md, "Repairs"): welded, deduplicated, degenerate
// triangles dropped, each repair counted in a warning; overlapping volumes named in a warning.
TEST_F(GltfImport, BlenderStyleBoxesAreRepairedAndTheirOverlapNamed) {
  const BlenderBoxesCounts counts;
  ImportReport report;
  const Scene scene = importOk(blenderStyleBoxes().writeGltf(file("boxes.gltf")), {}, &report);
  ASSERT_EQ(scene.surfaces.size(), 2u);
  EXPECT_EQ(scene.media.size(), 3u);
  for (const Surface& s : scene.surfaces) {
    EXPECT_TRUE(checkSurface(s).closed()) << s.name;
    EXPECT_EQ(s.indices.size() / 3, 12u) << s.name;
    EXPECT_EQ(s.outerMedium, 0u) << s.name << ": overlapping, so neither is inside the other";
  }
  EXPECT_TRUE(anyWarningContains(report, "('boxA') in node 0 ('A'): welded " + std::to_string(counts.welded) +
                                             " vertex(es)"));
  EXPECT_TRUE(anyWarningContains(report, "('boxA') in node 0 ('A'): dropped " +
                                             std::to_string(counts.duplicated) + " duplicated triangle(s)"));
  EXPECT_TRUE(anyWarningContains(report, "('boxA') in node 0 ('A'): dropped " +
                                             std::to_string(counts.degenerateA) + " degenerate"));
  EXPECT_TRUE(anyWarningContains(report, "('boxB') in node 1 ('B'): dropped " +
                                             std::to_string(counts.degenerateB) + " degenerate"));
  EXPECT_TRUE(anyWarningContains(report, "mesh 0 ('boxA') in node 0 ('A') and mesh 1 ('boxB') in node 1 ('B') "
                                         "overlap"));
  EXPECT_FALSE(anyWarningContains(report, "('boxB') in node 1 ('B'): welded"));
}

// Two boxes of one material joined face to face in one mesh: the shared face is written once per
// box with opposite windings; both copies go and the union is one closed volume.
TEST_F(GltfImport, InternalWallsBetweenJoinedPartsAreDropped) {
  const FaceBox left = makeFaceBox(1.0f, glm::vec3(-1.0f, 0.0f, 0.0f));
  const FaceBox right = makeFaceBox(1.0f, glm::vec3(1.0f, 0.0f, 0.0f));
  FaceBox both = left;
  for (const glm::vec3& p : right.positions) both.positions.push_back(p);
  for (const glm::vec3& n : right.normals) both.normals.push_back(n);
  for (uint32_t i : right.indices) both.indices.push_back(i + 24);
  GltfWriter w;
  const int m = w.addMaterial(glassMaterial(1.5));
  json attributes = {{"POSITION", w.addVec3(both.positions)}, {"NORMAL", w.addVec3(both.normals)}};
  const int mesh = w.addMesh(json::array({json{{"attributes", attributes}, {"indices", w.addIndices(both.indices)},
                                               {"material", m}}}), "bar");
  w.setScene({w.addNode(json{{"mesh", mesh}})});
  ImportReport report;
  const Scene scene = importOk(w.writeGltf(file("bar.gltf")), {}, &report);
  ASSERT_EQ(scene.surfaces.size(), 1u);
  EXPECT_TRUE(checkSurface(scene.surfaces[0]).closed());
  EXPECT_EQ(scene.surfaces[0].indices.size() / 3, 20u);
  EXPECT_TRUE(anyWarningContains(report, "dropped 4 triangle(s) in coincident pairs of opposite winding"));
  EXPECT_NEAR(signedVolume(scene, 1), 16.0, 1e-4);
}

// Only a volume still open after the repairs is refused, and the message names the tool's flag.
TEST_F(GltfImport, AVolumeStillOpenAfterRepairsNamesAllowOpen) {
  Cube cube = makeCube();
  cube.indices.resize(cube.indices.size() - 3);
  CubeFile f = cubeFile(cube);
  Result<Scene> scene = importGltf(f.writer.writeGltf(file("open.gltf")));
  ASSERT_FALSE(scene.ok());
  EXPECT_NE(scene.error().message.find("--allow-open"), std::string::npos) << scene.error().message;
}

// Nested volumes are a medium stack, not an overlap.
TEST_F(GltfImport, NestedVolumesAreNotReportedAsOverlapping) {
  GltfWriter w;
  const Cube outer = makeCube(2.0f);
  const Cube inner = makeCube(0.5f, glm::vec3(0.3f, 0.2f, 0.1f));
  const int glass = w.addMaterial(glassMaterial(1.5, "glass"));
  const int water = w.addMaterial(glassMaterial(1.33, "water"));
  auto add = [&w](const Cube& c, int material) {
    json attributes = {{"POSITION", w.addVec3(c.positions)}};
    const int mesh = w.addMesh(json::array({json{{"attributes", attributes}, {"indices", w.addIndices(c.indices)},
                                                  {"material", material}}}));
    return w.addNode(json{{"mesh", mesh}});
  };
  w.setScene({add(outer, glass), add(inner, water)});
  ImportReport report;
  const Scene scene = importOk(w.writeGltf(file("nested.gltf")), {}, &report);
  ASSERT_EQ(scene.surfaces.size(), 2u);
  EXPECT_EQ(scene.surfaces[1].outerMedium, scene.surfaces[0].innerMedium);
  EXPECT_FALSE(anyWarningContains(report, "overlap"));
}

TEST_F(GltfImport, MultipleMaterialsInOneMeshBecomeSeparateVolumes) {
  GltfWriter w;
  const Cube a = makeCube(1.0f, glm::vec3(-3.0f, 0.0f, 0.0f));
  const Cube b = makeCube(1.0f, glm::vec3(3.0f, 0.0f, 0.0f));
  const int glass = w.addMaterial(glassMaterial(1.5, "glass"));
  const int water = w.addMaterial(glassMaterial(1.33, "water"));
  json primitives = json::array();
  for (const auto& [cube, material] : {std::pair{&a, glass}, std::pair{&b, water}}) {
    primitives.push_back({{"attributes", {{"POSITION", w.addVec3(cube->positions)}}},
                          {"indices", w.addIndices(cube->indices)},
                          {"material", material}});
  }
  const int mesh = w.addMesh(primitives, "pair");
  w.setScene({w.addNode({{"mesh", mesh}, {"name", "n"}})});
  ImportReport report;
  const Scene scene = importOk(w.writeGltf(file("two_materials.gltf")), {}, &report);
  ASSERT_EQ(scene.surfaces.size(), 2u);
  ASSERT_EQ(scene.media.size(), 3u);
  EXPECT_EQ(scene.surfaces[0].name, "n/pair/glass");
  EXPECT_EQ(scene.surfaces[1].name, "n/pair/water");
  EXPECT_NE(scene.surfaces[0].innerMedium, scene.surfaces[1].innerMedium);
  EXPECT_EQ(report.meshes, 1u);
  EXPECT_EQ(report.primitives, 2u);
}

TEST_F(GltfImport, NonTransmissiveMaterialWarnsAndIsGlass) {
  CubeFile f = cubeFile(makeCube(), json{{"name", "plastic"}});
  ImportReport report;
  const Scene scene = importOk(f.writer.writeGltf(file("plastic.gltf")), {}, &report);
  ASSERT_EQ(scene.media.size(), 2u);
  EXPECT_FLOAT_EQ(scene.media[1].ior, 1.5f);
  EXPECT_TRUE(anyWarningContains(report, "neither transmissive nor a volume"));
}

TEST_F(GltfImport, Overrides) {
  GltfWriter w;
  const Cube big = makeCube(2.0f);
  const Cube small = makeCube(0.5f);
  json glass = glassMaterial(1.5, "glass");
  glass["extensions"]["KHR_materials_volume"]["attenuationDistance"] = 1.0;
  glass["extensions"]["KHR_materials_volume"]["attenuationColor"] = {0.5, 0.5, 0.5};
  const int m0 = w.addMaterial(glass);
  const int m1 = w.addMaterial(glassMaterial(1.33, "water"));
  auto mesh = [&](const Cube& cube, int material) {
    return w.addMesh(json::array({json{{"attributes", {{"POSITION", w.addVec3(cube.positions)}}},
                                       {"indices", w.addIndices(cube.indices)},
                                       {"material", material}}}));
  };
  w.setScene({w.addNode({{"mesh", mesh(big, m0)}}), w.addNode({{"mesh", mesh(small, m1)}})});
  const std::string path = w.writeGltf(file("overrides.gltf"));
  ImportOptions options;
  options.iorOverride = 1.7f;
  options.absorptionOverride = 0.25f;
  const Scene scene = importOk(path, options);
  ASSERT_EQ(scene.media.size(), 3u);
  EXPECT_EQ(scene.media[0].ior, 1.0f);
  EXPECT_EQ(scene.media[0].absorption, 0.0f);
  for (size_t m = 1; m < scene.media.size(); ++m) {
    EXPECT_EQ(scene.media[m].ior, 1.7f) << m;
    EXPECT_EQ(scene.media[m].absorption, 0.25f) << m;
  }

  ImportOptions badIor;
  badIor.iorOverride = 0.0f;
  expectError(path, ErrorCode::InvalidArgument, {"iorOverride"}, badIor);
  ImportOptions badAbsorption;
  badAbsorption.absorptionOverride = -1.0f;
  expectError(path, ErrorCode::InvalidArgument, {"absorptionOverride"}, badAbsorption);
}

}  // namespace
}  // namespace shrefract::bake
