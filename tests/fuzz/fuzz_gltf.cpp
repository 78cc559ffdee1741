// libFuzzer target: the glTF importer (importGltf) on arbitrary bytes, written to a temporary file
// (the importer reads paths; .glb when the bytes start with the GLB magic, .gltf otherwise).
//
// Beyond the sanitizers: an import that succeeds must return a scene that passes validateScene
// (every consumer relies on it), and a failure must carry a one-line message naming the file.
#include <shrefract/assets/gltf_import.h>
#include <shrefract/assets/scene.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <unistd.h>

namespace {

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_gltf: %s: %s\n", what, detail.c_str());
  std::abort();
}

std::string tempPath(bool binary) {
  const char* dir = std::getenv("TMPDIR");
  return std::string(dir && *dir ? dir : "/tmp") + "/shrefract_fuzz_" + std::to_string(getpid()) +
         (binary ? ".glb" : ".gltf");
}

void check(const std::string& path, const shrefract::bake::ImportOptions& options) {
  shrefract::bake::ImportReport report;
  auto scene = shrefract::bake::importGltf(path, options, &report);
  if (!scene) {
    const std::string& m = scene.error().message;
    if (m.find('\n') != std::string::npos) finding("a multi-line error", m);
    if (m.rfind(path, 0) != 0) finding("an error that does not start with the file", m);
    return;
  }
  if (auto valid = shrefract::bake::validateScene(scene.value()); !valid)
    finding("importGltf returned a scene that validateScene rejects", valid.error().message);
  for (uint32_t m = 0; m < scene.value().media.size(); ++m) {
    (void)shrefract::bake::checkMediumClosure(scene.value(), m);
    (void)shrefract::bake::signedVolume(scene.value(), m);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const bool binary = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  const std::string path = tempPath(binary);
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return 0;
  const bool written = std::fwrite(data, 1, size, f) == size;
  std::fclose(f);
  if (written) {
    check(path, {});
    shrefract::bake::ImportOptions open;
    open.allowOpenMeshes = true;
    check(path, open);
  }
  std::remove(path.c_str());
  return 0;
}
