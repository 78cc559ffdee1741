// glTF 2.0 import (.gltf with external or data-URI buffers, .glb): static triangle meshes of
// transparent media become a Scene of world-space surfaces, with the media taken from
// KHR_materials_ior / KHR_materials_volume and nested by containment. The rules (which material
// becomes which medium, how absorption is derived, the medium stack) are in docs/scenes.md,
// section "glTF media and the medium stack".
#pragma once

#include <shrefract/assets/scene.h>
#include <shrefract/result.h>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace shrefract::bake {

struct ImportOptions {
  // Replaces the ior of every medium except air (media[0]). Must be finite and > 0.
  std::optional<float> iorOverride;
  // Replaces the absorption of every medium except air. Must be finite and >= 0.
  std::optional<float> absorptionOverride;
  // Volumes with open, inconsistently wound or non-manifold edges after the repairs are an error
  // unless this is set (the tool's --allow-open); then they are kept and reported as warnings.
  bool allowOpenMeshes = false;
};

struct ImportReport {
  std::vector<std::string> warnings;  // one line each, prefixed with the file path
  size_t meshes = 0;                  // mesh instances (nodes with a mesh) in the scene
  size_t primitives = 0;              // primitives read
  size_t triangles = 0;               // triangles in the returned scene (degenerate ones dropped)
};

// Imports the default scene of a glTF file (scene 0 when none is marked default).
//
// Geometry: node transforms (matrix or TRS) are composed and applied to positions and, by the
// inverse transpose, to normals; mirroring transforms swap the winding so triangles stay
// counter-clockwise seen from outside. Primitives must be TRIANGLES with FLOAT VEC3 positions;
// indices (u8/u16/u32), NORMAL (FLOAT VEC3; area-weighted smooth normals are computed when
// absent) and TEXCOORD_0 (FLOAT, or normalized u8/u16 VEC2) are optional. Every accessor, index
// and value is validated. Triangles with two corners at the same position are dropped (counted
// in a warning).
//
// Media and surfaces: media[0] is air (ior 1). Every glTF material used by the scene becomes one
// medium (primitives without a material use a default glass, ior 1.5). The primitives of one
// mesh instance that share a material form one Surface, a closed volume of that medium: its
// innerMedium is the material's medium, its outerMedium the medium of the smallest other volume
// containing it (air when none). Closed volumes that are inside out are turned outward (warning).
//
// The container is chosen by the extension (.gltf, .glb), else by the content ("glTF" magic or a
// JSON object). Meshes are repaired before the closure check (docs/scenes.md, "Repairs": weld
// within 1e-5 of the diagonal, degenerate, duplicated and internal-wall triangles dropped; each a
// warning with its count); closed volumes that overlap are named in a warning and are siblings
// (neither is the other's container).
//
// Errors, each a single line "<path>: <problem>" naming the mesh, primitive and accessor where
// one is at fault: Io (missing or unreadable file), InvalidArgument (not glTF, no scene or
// no triangles, a zero-area volume, an open or inconsistently wound volume without
// allowOpenMeshes, a volume inside another of the same material, a bad override), CorruptData
// (parse errors, accessors out of range, bad indices, non-finite values), Unsupported (other
// primitive modes, other component types, sparse accessors, required geometry extensions).
// `report`, when given, is filled on success and on failure (as far as the import got).
Result<Scene> importGltf(const std::string& path, const ImportOptions& options = {},
                         ImportReport* report = nullptr);

}  // namespace shrefract::bake
