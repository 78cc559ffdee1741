#include "cli/scene_source.h"

#include <shrefract/bake/gltf_import.h>

namespace shrefract::cli {

Result<bake::Scene> loadScene(const std::string& spec, const SceneOverrides& overrides,
                              std::vector<std::string>* warnings) {
  if (spec.rfind("builtin:", 0) == 0) {
    bake::BuiltinSceneOptions options;
    if (overrides.tessellation) options.tessellation = *overrides.tessellation;
    options.iorOverride = overrides.ior;
    options.absorptionOverride = overrides.absorption;
    auto scene = bake::makeBuiltinScene(spec.substr(8), options);
    if (!scene) return makeError(scene.error().code, spec + ": " + scene.error().message);
    return scene;
  }
  if (overrides.tessellation)
    return makeError(ErrorCode::InvalidArgument, spec + ": --tessellation applies to built-in scenes only");
  bake::ImportOptions options;
  options.iorOverride = overrides.ior;
  options.absorptionOverride = overrides.absorption;
  options.allowOpenMeshes = overrides.allowOpenMeshes;
  bake::ImportReport report;
  auto scene = bake::importGltf(spec, options, &report);
  if (warnings)
    for (const auto& w : report.warnings) warnings->push_back(spec + ": " + w);
  return scene;
}

}  // namespace shrefract::cli
