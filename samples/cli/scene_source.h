// SCENE arguments of the tool: "builtin:NAME" or a glTF file (.gltf, .glb).
//
// A bake records its scene as a canonical spec, SCENE with its overrides appended as a query:
// "builtin:sphere?tessellation=2&ior=2.42", "model.glb?absorption=0.5&allow-open". loadScene
// accepts that form too, so `render --mode exact` and `report` rebuild exactly the baked scene.
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

// SCENE plus the overrides that are set, as a query string (see above).
std::string canonicalSceneSpec(const std::string& scene, const SceneOverrides& overrides);

// Loads the scene; a query in `spec` adds to `overrides` (explicit overrides win). Warnings (open
// meshes, dropped triangles) are appended to `warnings`. Errors name the scene argument.
Result<bake::Scene> loadScene(const std::string& spec, const SceneOverrides& overrides,
                              std::vector<std::string>* warnings);

}  // namespace shrefract::cli
