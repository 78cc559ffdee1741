#include "cli/scene_source.h"

#include <shrefract/bake/gltf_import.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace shrefract::cli {
namespace {

std::string number(float v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", static_cast<double>(v));
  return buf;
}

// Splits "SCENE?k=v&k=v" and merges the query into `overrides` where they are unset.
Result<std::string> splitQuery(const std::string& spec, SceneOverrides& overrides) {
  const size_t q = spec.find('?');
  if (q == std::string::npos) return spec;
  const std::string scene = spec.substr(0, q);
  std::string rest = spec.substr(q + 1);
  while (!rest.empty()) {
    const size_t amp = rest.find('&');
    const std::string item = rest.substr(0, amp);
    rest = amp == std::string::npos ? "" : rest.substr(amp + 1);
    const size_t eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const std::string value = eq == std::string::npos ? "" : item.substr(eq + 1);
    char* end = nullptr;
    errno = 0;
    if (key == "allow-open" && eq == std::string::npos) {
      overrides.allowOpenMeshes = true;
    } else if (key == "tessellation") {
      const long n = std::strtol(value.c_str(), &end, 10);
      if (value.empty() || *end || errno) return makeError(ErrorCode::InvalidArgument, spec + ": bad tessellation");
      if (!overrides.tessellation) overrides.tessellation = static_cast<int>(n);
    } else if (key == "ior" || key == "absorption") {
      const float v = std::strtof(value.c_str(), &end);
      if (value.empty() || *end || errno || !std::isfinite(v))
        return makeError(ErrorCode::InvalidArgument, spec + ": bad " + key);
      auto& slot = key == "ior" ? overrides.ior : overrides.absorption;
      if (!slot) slot = v;
    } else {
      return makeError(ErrorCode::InvalidArgument, spec + ": unknown scene option '" + item + "'");
    }
  }
  return scene;
}

}  // namespace

std::string canonicalSceneSpec(const std::string& scene, const SceneOverrides& o) {
  std::string query;
  auto add = [&](const std::string& item) { query += (query.empty() ? "?" : "&") + item; };
  if (o.tessellation) add("tessellation=" + std::to_string(*o.tessellation));
  if (o.ior) add("ior=" + number(*o.ior));
  if (o.absorption) add("absorption=" + number(*o.absorption));
  if (o.allowOpenMeshes) add("allow-open");
  return scene + query;
}

Result<bake::Scene> loadScene(const std::string& spec, const SceneOverrides& explicitOverrides,
                              std::vector<std::string>* warnings) {
  SceneOverrides overrides = explicitOverrides;
  auto split = splitQuery(spec, overrides);
  if (!split) return split.error();
  const std::string scene = split.value();
  if (scene.rfind("builtin:", 0) == 0) {
    bake::BuiltinSceneOptions options;
    if (overrides.tessellation) options.tessellation = *overrides.tessellation;
    options.iorOverride = overrides.ior;
    options.absorptionOverride = overrides.absorption;
    auto made = bake::makeBuiltinScene(scene.substr(8), options);
    if (!made) return makeError(made.error().code, scene + ": " + made.error().message);
    return made;
  }
  if (overrides.tessellation)
    return makeError(ErrorCode::InvalidArgument, scene + ": --tessellation applies to built-in scenes only");
  bake::ImportOptions options;
  options.iorOverride = overrides.ior;
  options.absorptionOverride = overrides.absorption;
  options.allowOpenMeshes = overrides.allowOpenMeshes;
  bake::ImportReport report;
  auto imported = bake::importGltf(scene, options, &report);
  if (warnings)
    for (const auto& w : report.warnings) warnings->push_back(w);
  return imported;
}

}  // namespace shrefract::cli
