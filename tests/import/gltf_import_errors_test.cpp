// glTF import refused: each bad file or option gives one line that names the file and what is
// wrong (gltf_import_fixture.h GltfImport::expectError).
#include "import/gltf_import_fixture.h"

namespace shrefract::bake {
namespace {

using GltfImportRefuses = GltfImport;  // a suite of its own: this file's copy of the fixture

TEST_F(GltfImportRefuses, MissingFile) {
  expectError(file("nothing.gltf").string(), ErrorCode::Io, {"no such file"});
}

TEST_F(GltfImportRefuses, NotGltf) {
  const std::string path = file("cube.obj").string();
  std::ofstream(path) << "v 0 0 0\n";
  expectError(path, ErrorCode::InvalidArgument, {"not a glTF file"});
}

TEST_F(GltfImportRefuses, ParseErrorIsOneLine) {
  const std::string path = file("broken.gltf").string();
  std::ofstream(path) << "{ \"asset\": { \"version\": \"2.0\" }, \n\n \"nodes\": [ {,, ] }\n";
  expectError(path, ErrorCode::CorruptData, {"cannot parse"});
  const std::string glb = file("broken.glb").string();
  std::ofstream(glb) << "glTF but not really\n";
  expectError(glb, ErrorCode::CorruptData, {"cannot parse"});
}

TEST_F(GltfImportRefuses, AccessorOutOfBufferViewRange) {
  CubeFile f = cubeFile();
  // POSITION accessor (0) claims more elements than its view holds.
  f.writer.doc()["accessors"][0]["count"] = 9;
  expectError(f.writer.writeGltf(file("range.gltf")), ErrorCode::CorruptData,
              {"mesh 0 ('cube') primitive 0", "accessor 0 (POSITION)", "does not fit"});
  // A byte offset that pushes the last element past the view.
  CubeFile g = cubeFile();
  g.writer.doc()["accessors"][1]["byteOffset"] = 4;
  expectError(g.writer.writeGltf(file("offset.gltf")), ErrorCode::CorruptData,
              {"accessor 1 (NORMAL)", "does not fit"});
  // A view that runs past the end of the buffer.
  CubeFile h = cubeFile();
  h.writer.doc()["bufferViews"][0]["byteLength"] = 4096;
  expectError(h.writer.writeGltf(file("view.gltf")), ErrorCode::CorruptData, {"accessor 0"});
}

TEST_F(GltfImportRefuses, IndexOutOfRange) {
  Cube cube = makeCube();
  cube.indices[5] = 8;
  CubeFile f = cubeFile(cube);
  expectError(f.writer.writeGltf(file("index.gltf")), ErrorCode::CorruptData,
              {"mesh 0 ('cube') primitive 0", "(indices)", "index 5 is 8, out of range"});
}

TEST_F(GltfImportRefuses, LinesAreUnsupported) {
  CubeFile f = cubeFile();
  f.writer.doc()["meshes"][0]["primitives"][0]["mode"] = 1;
  expectError(f.writer.writeGltf(file("lines.gltf")), ErrorCode::Unsupported,
              {"mesh 0 ('cube') primitive 0", "mode 1", "LINES"});
}

TEST_F(GltfImportRefuses, EmptyScene) {
  CubeFile f = cubeFile();
  f.writer.setScene({});
  expectError(f.writer.writeGltf(file("empty.gltf")), ErrorCode::InvalidArgument, {"empty"});
  CubeFile g = cubeFile();
  g.writer.doc().erase("scenes");
  g.writer.doc().erase("scene");
  expectError(g.writer.writeGltf(file("noscene.gltf")), ErrorCode::InvalidArgument, {"no scene"});
}

TEST_F(GltfImportRefuses, ZeroAreaMesh) {
  GltfWriter w;
  const std::vector<glm::vec3> line{{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 0, 0}};
  const int material = w.addMaterial(glassMaterial(1.5));
  // One collinear triangle and one with two corners at one position.
  const int mesh = w.addMesh(json::array({json{{"attributes", {{"POSITION", w.addVec3(line)}}},
                                               {"indices", w.addIndices({0, 1, 2, 0, 1, 3})},
                                               {"material", material}}}));
  w.setScene({w.addNode({{"mesh", mesh}})});
  expectError(w.writeGltf(file("zero.gltf")), ErrorCode::InvalidArgument, {"zero area"});
}

TEST_F(GltfImportRefuses, OpenMesh) {
  Cube cube = makeCube();
  cube.indices.resize(cube.indices.size() - 3);  // remove one triangle
  CubeFile f = cubeFile(cube);
  const std::string path = f.writer.writeGltf(file("open.gltf"));
  expectError(path, ErrorCode::InvalidArgument, {"mesh 0 ('cube')", "3 open"});

  ImportOptions allow;
  allow.allowOpenMeshes = true;
  ImportReport report;
  const Scene scene = importOk(path, allow, &report);
  EXPECT_EQ(triangles(scene), 11u);
  EXPECT_TRUE(anyWarningContains(report, "3 open"));
}

TEST_F(GltfImportRefuses, InconsistentWindingIsAnError) {
  Cube cube = makeCube();
  std::swap(cube.indices[1], cube.indices[2]);  // flip one triangle
  CubeFile f = cubeFile(cube);
  expectError(f.writer.writeGltf(file("flipped.gltf")), ErrorCode::InvalidArgument,
              {"inconsistently wound"});
}

TEST_F(GltfImportRefuses, OtherMalformedInput) {
  {  // positions that are not FLOAT VEC3
    CubeFile f = cubeFile();
    f.writer.doc()["accessors"][0]["type"] = "VEC2";
    expectError(f.writer.writeGltf(file("vec2.gltf")), ErrorCode::Unsupported,
                {"accessor 0 (POSITION)", "FLOAT VEC3"});
  }
  {  // index count not a multiple of 3
    CubeFile f = cubeFile();
    f.writer.doc()["accessors"][2]["count"] = 35;
    expectError(f.writer.writeGltf(file("count.gltf")), ErrorCode::CorruptData,
                {"(indices)", "not a multiple of 3"});
  }
  {  // a non-finite position
    Cube cube = makeCube();
    cube.positions[3].y = std::numeric_limits<float>::infinity();
    CubeFile f = cubeFile(cube);
    expectError(f.writer.writeGltf(file("inf.gltf")), ErrorCode::CorruptData,
                {"accessor 0 (POSITION)", "element 3 is not finite"});
  }
  {  // geometry compression is not read
    CubeFile f = cubeFile();
    f.writer.doc()["extensionsRequired"] = {"KHR_draco_mesh_compression"};
    f.writer.doc()["extensionsUsed"] = {"KHR_draco_mesh_compression"};
    expectError(f.writer.writeGltf(file("draco.gltf")), ErrorCode::Unsupported,
                {"KHR_draco_mesh_compression"});
  }
  {  // a node cycle
    CubeFile f = cubeFile();
    f.writer.doc()["nodes"][0]["children"] = {0};
    expectError(f.writer.writeGltf(file("cycle.gltf")), ErrorCode::CorruptData, {"cycle"});
  }
  {  // a singular transform
    CubeFile f = cubeFile(makeCube(), glassMaterial(1.5), {{"scale", {1.0, 0.0, 1.0}}});
    expectError(f.writer.writeGltf(file("flat.gltf")), ErrorCode::InvalidArgument, {"singular"});
  }
}

// Truncations of a valid file are rejected cleanly (no crash, one line naming the file). Every
// length through the GLB header and chunk headers, then a sample (each cut is a file write, and
// the filesystem dominates the run time), then every length of the last bytes.
TEST_F(GltfImportRefuses, TruncatedFilesAreRejected) {
  CubeFile f = cubeFile();
  for (const std::string& name : {std::string("whole.glb"), std::string("whole.gltf")}) {
    const std::string whole = name.ends_with(".glb") ? f.writer.writeGlb(file(name))
                                                     : f.writer.writeGltf(file(name));
    const std::string bytes = readFile(whole);
    ASSERT_TRUE(importGltf(whole).ok());
    const std::string cut = file("cut" + name.substr(name.find('.'))).string();
    for (size_t length = 0; length < bytes.size();
         length += (length < 32 || length + 16 >= bytes.size()) ? 1 : 7) {
      std::ofstream(cut, std::ios::binary | std::ios::trunc)
          .write(bytes.data(), static_cast<std::streamsize>(length));
      const Result<Scene> scene = importGltf(cut);
      ASSERT_FALSE(scene.ok()) << name << " cut to " << length << " bytes";
      EXPECT_EQ(scene.error().message.rfind(cut + ": ", 0), 0u) << scene.error().message;
      EXPECT_EQ(scene.error().message.find('\n'), std::string::npos) << scene.error().message;
    }
  }
}

// The shared bunny asset, when present on this machine (tests must not need it).
TEST_F(GltfImportRefuses, BunnyAssetWhenPresent) {
  const std::filesystem::path bunny = "/work/shared/assets/bunny.glb";
  if (!std::filesystem::exists(bunny)) {
    GTEST_SKIP() << bunny << " not present";
  }
  ImportReport report;
  const Scene scene = importOk(bunny.string(), {}, &report);
  ASSERT_EQ(scene.surfaces.size(), 1u);
  EXPECT_EQ(triangles(scene), 27864u);
  EXPECT_TRUE(checkMediumClosure(scene, 1).closed());
  EXPECT_GT(signedVolume(scene, 1), 0.0);
  EXPECT_FLOAT_EQ(scene.media[1].ior, 1.5f);
  EXPECT_EQ(scene.media[1].absorption, 0.0f);
  for (const std::string& warning : report.warnings) {
    std::cout << "bunny warning: " << warning << "\n";
  }
}

}  // namespace
}  // namespace shrefract::bake
