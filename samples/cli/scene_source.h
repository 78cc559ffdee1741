// SCENE arguments of the tool: "builtin:NAME" or a glTF file (.gltf, .glb).
#pragma once

#include <shrefract/bake/scene.h>
#include <shrefract/result.h>

#include <optional>
#include <string>
#include <vector>

namespace shrefract::cli {

struct SceneOverrides {
  std::optional<float> ior;
  std::optional<float> absorption;
  std::optional<int> tessellation;  // built-in scenes only
  bool allowOpenMeshes = false;     // glTF only
};

// Loads the scene; warnings (open meshes, dropped triangles) are appended to `warnings`.
// Errors name the scene argument.
Result<bake::Scene> loadScene(const std::string& spec, const SceneOverrides& overrides,
                              std::vector<std::string>* warnings);

}  // namespace shrefract::cli
