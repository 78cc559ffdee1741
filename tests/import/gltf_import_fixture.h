// The glTF import tests' fixture: files written to a fresh directory (gltf_writer.h), a cube
// mesh on a node, and the checks the tests share.
#pragma once

#include <shrefract/assets/gltf_import.h>
#include <shrefract/assets/scene.h>

#include <glm/geometric.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include "import/gltf_writer.h"


namespace shrefract::bake {
namespace {

using nlohmann::json;
using namespace shrefract::gltf_test;

// A writer holding one cube mesh (indexed, u32, with normals) on one node, material 0.
struct CubeFile {
  GltfWriter writer;
  int mesh = -1;
  int node = -1;
};

CubeFile cubeFile(const Cube& cube = makeCube(), json material = glassMaterial(1.5),
                  json node = json::object(), bool withNormals = true,
                  int indexType = kUnsignedInt) {
  CubeFile f;
  const int positions = f.writer.addVec3(cube.positions);
  json attributes = {{"POSITION", positions}};
  if (withNormals) {
    attributes["NORMAL"] = f.writer.addVec3(cube.normals);
  }
  const int indices = f.writer.addIndices(cube.indices, indexType);
  const int materialIndex = f.writer.addMaterial(std::move(material));
  f.mesh = f.writer.addMesh(
      json::array({json{
          {"attributes", attributes}, {"indices", indices}, {"material", materialIndex}}}),
      "cube");
  node["mesh"] = f.mesh;
  f.node = f.writer.addNode(node);
  f.writer.setScene({f.node});
  return f;
}

class GltfImport : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           (std::string("shrefract_gltf_") + info->name() + "_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  std::filesystem::path file(const std::string& name) const { return dir_ / name; }

  // Imports and expects success.
  Scene importOk(const std::string& path, const ImportOptions& options = {},
                 ImportReport* report = nullptr) {
    Result<Scene> scene = importGltf(path, options, report);
    EXPECT_TRUE(scene.ok()) << (scene.ok() ? "" : scene.error().message);
    return scene.ok() ? std::move(scene).value() : Scene{};
  }

  // Imports and expects an error of `code` whose one-line message names the file and contains
  // every one of `words`.
  void expectError(const std::string& path, ErrorCode code, const std::vector<std::string>& words,
                   const ImportOptions& options = {}) {
    Result<Scene> scene = importGltf(path, options);
    ASSERT_FALSE(scene.ok()) << path;
    EXPECT_EQ(scene.error().code, code) << scene.error().message;
    const std::string& message = scene.error().message;
    EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    for (const std::string& word : words) {
      EXPECT_NE(message.find(word), std::string::npos) << "'" << word << "' not in: " << message;
    }
  }

  std::filesystem::path dir_;
};

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  std::string bytes(static_cast<size_t>(in.tellg()), '\0');
  in.seekg(0);
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return bytes;
}

bool anyWarningContains(const ImportReport& report, const std::string& text) {
  return std::any_of(report.warnings.begin(), report.warnings.end(),
                     [&text](const std::string& w) { return w.find(text) != std::string::npos; });
}

size_t triangles(const Scene& scene) {
  size_t n = 0;
  for (const Surface& s : scene.surfaces) {
    n += s.indices.size() / 3;
  }
  return n;
}

}  // namespace
}  // namespace shrefract::bake
