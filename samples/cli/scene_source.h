// SCENE arguments of the tool: "builtin:NAME" or a glTF file (.gltf, .glb), and the scene options
// every command that loads a scene takes (bake, render, view, report), declared once here.
//
// A bake records its scene as a spec: SCENE with its overrides appended as a query,
// "builtin:sphere?tessellation=2&ior=2.42", "model.glb?absorption=0.5&allow-open". For a glTF
// file the path is relative to the field file's directory and the absolute path follows as a
// fallback ("../model.glb?allow-open&absolute=/data/model.glb"), so that `render --mode exact`
// and `report` rebuild exactly the baked scene from any working directory (bakedSceneSpec).
// loadScene accepts that form too; users give the options as flags (sceneFlags).
#pragma once

#include <shrefract/assets/scene.h>
#include <shrefract/result.h>

#include <optional>
#include <string>
#include <vector>

#include "cli/args.h"

namespace shrefract::cli {

struct SceneOverrides {
  std::optional<float> ior;
  std::optional<float> absorption;
  std::optional<int> tessellation;  // built-in scenes only
  bool allowOpenMeshes = false;     // glTF only
};

// --allow-open, --ior, --tessellation and (mediumAbsorption: bake, report) --absorption as the
// media override; render and view use --absorption for the shading scale k instead.
std::vector<FlagSpec> sceneFlags(bool mediumAbsorption);

// A scene command's table, every flag once (its kind and range are what the parser checks and what
// --help prints): `own`, then sceneFlags, then --json (with `jsonHelp`, when given) and --help.
std::vector<FlagSpec> sceneCommandFlags(std::vector<FlagSpec> own, bool mediumAbsorption,
                                        const char* jsonHelp = nullptr);

// The overrides those flags set (Args::parse has checked their ranges).
SceneOverrides sceneOverridesFrom(const Args& args, bool mediumAbsorption);

// True when `input` names a scene rather than a field file: "builtin:...", a .gltf or .glb file,
// or (any other extension but .shrf) a file whose content starts as glTF: the binary magic
// "glTF" or a JSON object. So a damaged glTF gets a glTF error, never "not a shrefract field".
bool isSceneInput(const std::string& input);

// SCENE plus the overrides that are set, as a query string (see above). A query already in
// `scene` is merged; the explicit overrides win.
std::string canonicalSceneSpec(const std::string& scene, const SceneOverrides& overrides);

// What a bake records for `scene` written next to `fieldPath`: canonicalSceneSpec with a glTF
// path made relative to the field's directory, and the absolute path as a fallback.
std::string recordedSceneSpec(const std::string& scene, const SceneOverrides& overrides,
                              const std::string& fieldPath);

// The spec that rebuilds the scene a field was baked from. `sceneFlag` (render --dev scene=PATH)
// replaces the recorded file and keeps the recorded options. Otherwise a recorded glTF path is
// looked up relative to the field file, then at its absolute path, then (fields baked before
// paths were recorded this way) relative to the working directory. Errors name the field, the
// places looked at and --dev scene.
Result<std::string> bakedSceneSpec(const std::string& fieldPath, const std::string& recorded,
                                   const std::optional<std::string>& sceneFlag);

// Loads the scene; a query in `spec` adds to `overrides` (explicit overrides win). Warnings (open
// meshes, repairs, overlaps) are appended to `warnings`. Errors name the scene argument.
Result<bake::Scene> loadScene(const std::string& spec, const SceneOverrides& overrides,
                              std::vector<std::string>* warnings);

}  // namespace shrefract::cli
