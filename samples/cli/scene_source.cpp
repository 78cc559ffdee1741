#include "cli/scene_source.h"

#include <shrefract/assets/gltf_import.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace shrefract::cli {
namespace {

std::string number(float v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", static_cast<double>(v));
  return buf;
}

bool isBuiltin(const std::string& scene) { return scene.rfind("builtin:", 0) == 0; }

// A spec taken apart: the scene, the overrides of its query, and the recorded absolute path.
struct ParsedSpec {
  std::string scene;
  SceneOverrides overrides;
  std::optional<std::string> absolute;
};

// Fills `slot` from the text of a query item; false when malformed.
bool parseItem(const std::string& key, const std::string& value, ParsedSpec& out) {
  char* end = nullptr;
  errno = 0;
  if (key == "tessellation") {
    const long n = std::strtol(value.c_str(), &end, 10);
    if (value.empty() || *end || errno) return false;
    out.overrides.tessellation = static_cast<int>(n);
    return true;
  }
  if (key == "ior" || key == "absorption") {
    const float v = std::strtof(value.c_str(), &end);
    if (value.empty() || *end || errno || !std::isfinite(v)) return false;
    (key == "ior" ? out.overrides.ior : out.overrides.absorption) = v;
    return true;
  }
  if (key == "absolute" && !value.empty()) {
    out.absolute = value;
    return true;
  }
  return false;
}

// Splits "SCENE?k=v&k=v&allow-open&absolute=PATH". The absolute path is last and runs to the end
// of the spec, so it may hold '&' (not '?', which splits the scene from its query).
Result<ParsedSpec> parseSpec(const std::string& spec) {
  ParsedSpec out;
  const size_t q = spec.find('?');
  out.scene = spec.substr(0, q);
  std::string rest = q == std::string::npos ? "" : spec.substr(q + 1);
  while (!rest.empty()) {
    const bool last = rest.rfind("absolute=", 0) == 0;
    const size_t amp = last ? std::string::npos : rest.find('&');
    const std::string item = rest.substr(0, amp);
    rest = amp == std::string::npos ? "" : rest.substr(amp + 1);
    const size_t eq = item.find('=');
    const std::string key = item.substr(0, eq);
    if (key == "allow-open" && eq == std::string::npos) {
      out.overrides.allowOpenMeshes = true;
    } else if (eq == std::string::npos || !parseItem(key, item.substr(eq + 1), out)) {
      const bool known = key == "tessellation" || key == "ior" || key == "absorption" || key == "absolute";
      return makeError(ErrorCode::InvalidArgument,
                       spec + (known ? ": bad " + key : ": unknown scene option '" + item + "'"));
    }
  }
  return out;
}

std::string formatSpec(const std::string& scene, const SceneOverrides& o, const std::optional<std::string>& absolute) {
  std::string query;
  auto add = [&](const std::string& item) { query += (query.empty() ? "?" : "&") + item; };
  if (o.tessellation) add("tessellation=" + std::to_string(*o.tessellation));
  if (o.ior) add("ior=" + number(*o.ior));
  if (o.absorption) add("absorption=" + number(*o.absorption));
  if (o.allowOpenMeshes) add("allow-open");
  if (absolute) add("absolute=" + *absolute);
  return scene + query;
}

// `base` with the overrides of `top` that are set.
SceneOverrides merge(SceneOverrides base, const SceneOverrides& top) {
  if (top.ior) base.ior = top.ior;
  if (top.absorption) base.absorption = top.absorption;
  if (top.tessellation) base.tessellation = top.tessellation;
  base.allowOpenMeshes = base.allowOpenMeshes || top.allowOpenMeshes;
  return base;
}

bool startsLikeGltf(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[64] = {};
  in.read(head, sizeof head);
  const auto n = static_cast<size_t>(in.gcount());
  if (n >= 4 && std::memcmp(head, "glTF", 4) == 0) return true;
  for (size_t i = 0; i < n; ++i) {
    if (std::isspace(static_cast<unsigned char>(head[i]))) continue;
    return head[i] == '{';
  }
  return false;
}

}  // namespace

std::vector<FlagSpec> sceneFlags(bool mediumAbsorption) {
  std::vector<FlagSpec> flags = {
      {"allow-open", false, "accept a glTF volume that stays open after the repairs (with a warning)"},
      {"ior", true, "override the IOR of every medium but the surrounding one", ValueKind::Real, {0, kUnbounded, true}},
      {"tessellation", true, "tessellation level of a built-in scene (default 3)", ValueKind::Integer,
       {double(bake::kMinTessellation), double(bake::kMaxTessellation)}},
  };
  if (mediumAbsorption)
    flags.push_back({"absorption", true, "override the absorption of every medium but the surrounding one",
                     ValueKind::Real, {0, kUnbounded}});
  return flags;
}

std::vector<FlagSpec> sceneCommandFlags(std::vector<FlagSpec> own, bool mediumAbsorption, const char* jsonHelp) {
  for (auto& f : sceneFlags(mediumAbsorption)) own.push_back(f);
  if (jsonHelp) own.push_back({"json", false, jsonHelp});
  own.push_back({"help", false, "this text"});
  return own;
}

SceneOverrides sceneOverridesFrom(const Args& args, bool mediumAbsorption) {
  SceneOverrides o;
  if (auto v = args.number("ior"); v.ok() && v.value()) o.ior = static_cast<float>(*v.value());
  if (auto v = args.integer("tessellation"); v.ok() && v.value()) o.tessellation = static_cast<int>(*v.value());
  if (mediumAbsorption)
    if (auto v = args.number("absorption"); v.ok() && v.value()) o.absorption = static_cast<float>(*v.value());
  o.allowOpenMeshes = args.has("allow-open");
  return o;
}

bool isSceneInput(const std::string& input) {
  if (isBuiltin(input) || hasExtension(input, ".gltf") || hasExtension(input, ".glb")) return true;
  if (hasExtension(input, ".shrf")) return false;
  const std::string path = input.substr(0, input.find('?'));
  return startsLikeGltf(path);
}

std::string canonicalSceneSpec(const std::string& scene, const SceneOverrides& o) {
  auto parsed = parseSpec(scene);
  if (!parsed) return formatSpec(scene, o, std::nullopt);  // loadScene reports the bad query
  return formatSpec(parsed->scene, merge(parsed->overrides, o), parsed->absolute);
}

std::string recordedSceneSpec(const std::string& scene, const SceneOverrides& overrides, const std::string& fieldPath) {
  namespace fs = std::filesystem;
  auto parsed = parseSpec(scene);
  if (!parsed || isBuiltin(parsed->scene)) return canonicalSceneSpec(scene, overrides);
  std::error_code ec;
  const fs::path absolute = fs::absolute(parsed->scene, ec).lexically_normal();
  const fs::path fieldDir = fs::absolute(fieldPath, ec).parent_path();
  const fs::path relative = absolute.lexically_relative(fieldDir);
  const std::string recorded = relative.empty() ? absolute.string() : relative.generic_string();
  return formatSpec(recorded, merge(parsed->overrides, overrides), absolute.string());
}

Result<std::string> bakedSceneSpec(const std::string& fieldPath, const std::string& recorded,
                                   const std::optional<std::string>& sceneFlag) {
  namespace fs = std::filesystem;
  auto parsed = parseSpec(recorded);
  if (!parsed) return makeError(ErrorCode::CorruptData, fieldPath + ": recorded scene: " + parsed.error().message);
  if (sceneFlag) return formatSpec(*sceneFlag, parsed->overrides, std::nullopt);
  if (isBuiltin(parsed->scene)) return formatSpec(parsed->scene, parsed->overrides, std::nullopt);
  const fs::path recordedPath(parsed->scene);
  std::vector<fs::path> candidates{recordedPath};
  if (recordedPath.is_relative()) {
    candidates = {fs::path(fieldPath).parent_path() / recordedPath};
    if (parsed->absolute) candidates.emplace_back(*parsed->absolute);
    candidates.push_back(recordedPath);  // fields recorded before: relative to the bake's directory
  }
  std::string looked;
  std::vector<fs::path> seen;
  for (const fs::path& candidate : candidates) {
    if (std::find(seen.begin(), seen.end(), candidate.lexically_normal()) != seen.end()) continue;
    seen.push_back(candidate.lexically_normal());
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return formatSpec(candidate.string(), parsed->overrides, std::nullopt);
    looked += (looked.empty() ? "" : ", ") + candidate.string();
  }
  return makeError(ErrorCode::Io, fieldPath + ": the baked scene " + parsed->scene + " is not at " + looked +
                                      "; give its new place with --dev scene=PATH");
}

Result<bake::Scene> loadScene(const std::string& spec, const SceneOverrides& explicitOverrides,
                              std::vector<std::string>* warnings) {
  auto parsed = parseSpec(spec);
  if (!parsed) return parsed.error();
  const SceneOverrides overrides = merge(parsed->overrides, explicitOverrides);
  const std::string& scene = parsed->scene;
  if (isBuiltin(scene)) {
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
