// glTF import: reads the default scene with tinygltf, validates every accessor it touches, bakes
// the node transforms into world-space surfaces and assigns media by containment (the medium
// stack rule of docs/scenes.md, "glTF media and the medium stack").
#include "import/gltf_importer.h"

namespace shrefract::bake::gltf_detail {
namespace {

// The container of a glTF file: by its extension, else by its first bytes (the binary magic
// "glTF", or a JSON object), so that a file exported under another name still imports.
std::optional<bool> isBinaryGltf(const std::string& path) {
  const std::string extension = lowercase(std::filesystem::path(path).extension().string());
  if (extension == ".gltf" || extension == ".glb") {
    return extension == ".glb";
  }
  std::ifstream in(path, std::ios::binary);
  char head[64] = {};
  in.read(head, sizeof head);
  const auto n = static_cast<size_t>(in.gcount());
  if (n >= 4 && std::memcmp(head, "glTF", 4) == 0) {
    return true;
  }
  for (size_t i = 0; i < n; ++i) {
    if (!std::isspace(static_cast<unsigned char>(head[i]))) {
      return head[i] == '{' ? std::optional<bool>(false) : std::nullopt;
    }
  }
  return std::nullopt;
}

}  // namespace

Result<void> Importer::load() {
  std::error_code ec;
  if (!std::filesystem::exists(path_, ec)) {
    return fail(ErrorCode::Io, "no such file");
  }
  if (!std::filesystem::is_regular_file(path_, ec)) {
    return fail(ErrorCode::Io, "not a regular file");
  }
  const std::optional<bool> binary = isBinaryGltf(path_);
  if (!binary) {
    return fail(ErrorCode::InvalidArgument,
                "not a glTF file (neither the extension .gltf or .glb nor glTF content)");
  }

  tinygltf::TinyGLTF loader;
  // Images are never needed: skip decoding them (and do not fail on formats stb cannot read).
  loader.SetImageLoader(
      [](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*,
         int, void*) { return true; },
      nullptr);
  std::string err;
  std::string warnings;
  const bool ok = *binary ? loader.LoadBinaryFromFile(&model_, &err, &warnings, path_)
                                      : loader.LoadASCIIFromFile(&model_, &err, &warnings, path_);
  for (const std::string& line : lines(warnings)) {
    warn(line);
  }
  if (!ok) {
    const std::string message = oneLine(err);
    return fail(ErrorCode::CorruptData,
                "cannot parse glTF: " + (message.empty() ? std::string("unknown error") : message));
  }

  // Required extensions that change how geometry is stored cannot be ignored; material and texture
  // extensions do not touch the geometry.
  for (const std::string& name : model_.extensionsRequired) {
    const bool harmless = name.starts_with("KHR_materials_") || name.starts_with("KHR_texture_") ||
                          name.starts_with("EXT_texture_") || name == "KHR_lights_punctual" ||
                          name == "KHR_mesh_quantization";
    if (!harmless) {
      return fail(ErrorCode::Unsupported,
                  "requires extension " + name + ", which is not supported");
    }
  }
  return {};
}

Result<Scene> Importer::run() {
  if (Result<void> valid = checkOverrides(); !valid) {
    return valid.error();
  }
  if (Result<void> loaded = load(); !loaded) {
    return loaded.error();
  }
  if (Result<void> collected = collectVolumes(); !collected) {
    return collected.error();
  }
  for (Volume& volume : volumes_) {
    if (Result<void> finalized = finalize(volume); !finalized) {
      return finalized.error();
    }
  }
  const std::set<std::pair<size_t, size_t>> overlaps = findOverlaps();

  Scene scene;
  scene.name = std::filesystem::path(path_).stem().string();
  scene.media.push_back(Medium{"air", 1.0f, 0.0f, glm::vec3(1.0f)});
  if (Result<void> assigned = assignMedia(scene); !assigned) {
    return assigned.error();
  }
  if (Result<void> added = addSurfaces(scene, overlaps); !added) {
    return added.error();
  }
  if (Result<void> valid = validateScene(scene); !valid) {
    return fail(valid.error().code, valid.error().message);
  }
  return scene;
}

}  // namespace shrefract::bake::gltf_detail

namespace shrefract::bake {

Result<Scene> importGltf(const std::string& path, const ImportOptions& options,
                         ImportReport* report) {
  ImportReport local;
  ImportReport& out = report != nullptr ? *report : local;
  out = ImportReport{};
  gltf_detail::Importer importer(path, options, out);
  return importer.run();
}

}  // namespace shrefract::bake
