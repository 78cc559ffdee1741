// `shrefract report [SCENES...] -o DIR`: error against run time for every setting.
#include <cstdio>
#include <filesystem>
#include <string>

#include <unistd.h>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/interrupt.h"
#include "cli/scene_source.h"
#include "report/report.h"

namespace shrefract::cli {
namespace {

namespace fs = std::filesystem;
using K = ValueKind;

std::vector<FlagSpec> reportFlags() {
  return sceneCommandFlags({
      {"output", true, "output directory (replaced only once the report is complete); also -o"},
      {"full", false, "also the settings sweeps, stability cases and flicker orbits, and every fidelity row (hours)"},
      {"smoke", false, "a tiny report in seconds (for tests)"},
      {"fidelity-only", false, "with --full or --smoke: only the fidelity section"},
      {"size", true, "image size WxH (default 240x180; --full 320x240)", K::Size, {1, 16384}, {1, 16384}},
      {"frames", true, "GPU frames timed per setting", K::Integer, {1, 1000}},
      {"samples", true, "surface sample budget of every bake (default: each encoding's own)", K::Integer, {1, 1e8}},
      {"threads", true, "bake and CPU reference threads (default: all cores)", K::Integer, {1, 1024}},
      {"device", true, "Vulkan device index", K::Integer, {0, 1024}},
      }, true);
}

int usageError(const std::string& m) {
  std::fprintf(stderr, "%s\n", m.c_str());
  return 2;
}

// The output directory may exist (it is replaced), but not as a file, and its parent must.
Result<void> checkOutputDirectory(const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    return makeError(ErrorCode::Io, dir.string() + ": exists and is not a directory");
  fs::path parent = dir.parent_path();
  if (parent.empty()) parent = ".";
  if (!fs::is_directory(parent, ec)) return makeError(ErrorCode::Io, dir.string() + ": parent directory does not exist");
  if (access(parent.c_str(), W_OK) != 0) return makeError(ErrorCode::Io, dir.string() + ": parent directory is not writable");
  return {};
}

// Moves the finished report from `staging` to `dir`, replacing an earlier report there.
Result<void> publish(const fs::path& staging, const fs::path& dir) {
  std::error_code ec;
  const fs::path old = dir.string() + ".old-" + std::to_string(getpid());
  const bool replacing = fs::exists(dir, ec);
  if (replacing) fs::rename(dir, old, ec);
  if (!ec) fs::rename(staging, dir, ec);
  if (ec) return makeError(ErrorCode::Io, dir.string() + ": cannot move the report into place: " + ec.message());
  if (replacing) fs::remove_all(old, ec);
  return {};
}

void printSummary(const report::ReportResult& result, const std::string& out) {
  std::printf("report: %zu scenes' fidelity and %zu sweep settings measured in %.1f s; wrote %zu files to %s (start "
              "with %s/report.md)\n",
              result.fidelity.size(), result.rows.size(), result.seconds, result.files.size(), out.c_str(), out.c_str());
  for (const auto& row : result.rows)
    if (row.group == "order" || row.group == "baseline")
      std::printf("  %-40s %-24s mean angle %6.2f deg  PSNR %6.2f dB  frame %8.2f ms%s\n",
                  row.scene.substr(0, 40).c_str(), row.label.c_str(), row.meanAngle, row.psnr, row.frameMs,
                  row.gpu ? "" : " (CPU)");
  for (const auto& scene : result.fidelity) {
    if (!scene.skipped.empty()) {
      std::printf("  fidelity %-31s skipped: %s\n", scene.scene.substr(0, 31).c_str(), scene.skipped.c_str());
      continue;
    }
    for (const auto& row : scene.rows)
      if (row.error.empty() && row.kind != "physical")
        std::printf("  fidelity %-31s %-40s PSNR %6.2f dB vs physical\n", scene.scene.substr(0, 31).c_str(),
                    (row.kind == "field" ? row.series + " " + row.label : row.label).substr(0, 40).c_str(),
                    row.psnrPhysical);
  }
}

void printHelp(const std::vector<FlagSpec>& flags) {
  std::printf("usage: shrefract report [SCENES...] -o DIR [flags]\n"
              "  SCENES: builtin:NAME or glTF files; --allow-open, --ior, --absorption and --tessellation apply\n"
              "  to them as in bake. Default: builtin:sphere and builtin:glass-of-water for the settings sweeps;\n"
              "  the fidelity section takes the four built-in scenes and ../shared/assets/bunny.glb when it exists\n%s",
              usageLines(flags).c_str());
}

// -o DIR as a path without a trailing separator.
std::string outputDirectoryOf(const Args& args) {
  // "out/" names the directory out, and its staging sibling must not land inside it.
  fs::path outPath = fs::path(*args.get("output")).lexically_normal();
  if (outPath.filename().empty()) outPath = outPath.parent_path();
  return outPath.string();
}

report::ReportOptions reportOptionsFrom(const Args& args, const SceneOverrides& overrides) {
  report::ReportOptions options;
  for (const std::string& scene : args.positional()) options.scenes.push_back(canonicalSceneSpec(scene, overrides));
  options.size = args.has("full") ? report::ReportSize::Full
                 : args.has("smoke") ? report::ReportSize::Smoke
                                     : report::ReportSize::Default;
  // Kinds and ranges were checked by Args::parse.
  if (auto size = args.size("size").value()) {
    options.width = (*size)[0];
    options.height = (*size)[1];
  }
  if (auto v = args.integer("frames").value()) options.frames = static_cast<uint32_t>(*v);
  if (auto v = args.integer("threads").value()) options.threads = static_cast<uint32_t>(*v);
  if (auto v = args.integer("samples").value()) options.samples = static_cast<uint64_t>(*v);
  if (auto v = args.integer("device").value()) options.deviceIndex = static_cast<int>(*v);
  // The default report is the fidelity section; --full adds the sweeps (ReportSize).
  options.fidelityOnly = args.has("fidelity-only") || options.size == report::ReportSize::Default;
  return options;
}

// A failed report: its staging directory goes, and the exit code says whose fault it was.
int reportFailure(const Error& error, const fs::path& staging, int deviceIndex) {
  std::error_code ec;
  fs::remove_all(staging, ec);
  // A device index the machine does not have is a usage error naming the flag.
  const std::string message = error.message;
  const bool badDevice = deviceIndex >= 0 && message.find("device index") != std::string::npos;
  if (badDevice) return usageError("shrefract report: --device " + std::to_string(deviceIndex) + ": " + message);
  std::fprintf(stderr, "%s\n", message.c_str());
  return error.code == ErrorCode::NoDevice ? kExitNoDevice : 1;
}

// Runs the report into a staging directory and moves it to `out` once complete.
int runStaged(report::ReportOptions& options, const std::string& out) {
  // Written beside DIR and moved into place once complete: a failed run leaves nothing behind.
  // An interrupt removes it as well (the report runs for hours).
  const fs::path staging = out + ".partial-" + std::to_string(getpid());
  const RemoveOnInterrupt removeStaging(staging);
  options.outputDirectory = staging.string();
  auto result = report::runReport(options);
  if (result) {
    const auto held = holdInterrupts();
    if (auto moved = publish(staging, out); !moved) result = moved.error();
  }
  if (!result) return reportFailure(result.error(), staging, options.deviceIndex);
  printSummary(result.value(), out);
  return 0;
}

}  // namespace

int reportCommand(int argc, char** argv) {
  const std::vector<FlagSpec> flags = reportFlags();
  auto parsed = Args::parse("report", argc, argv, 2, flags);
  if (!parsed) return usageError(parsed.error().message);
  const Args& args = parsed.value();
  if (args.has("help")) {
    printHelp(flags);
    return 0;
  }
  if (!args.get("output")) return usageError("shrefract report: missing -o DIR");
  const std::string out = outputDirectoryOf(args);
  if (args.has("full") && args.has("smoke")) return usageError("shrefract report: --full and --smoke exclude each other");
  const SceneOverrides overrides = sceneOverridesFrom(args, true);
  const bool sceneFlag = args.has("allow-open") || args.has("ior") || args.has("absorption") || args.has("tessellation");
  if (sceneFlag && args.positional().empty())
    return usageError("shrefract report: --allow-open, --ior, --absorption and --tessellation apply to the SCENES "
                      "given; give at least one");

  report::ReportOptions options = reportOptionsFrom(args, overrides);
  if (auto ok = checkOutputDirectory(out); !ok) {
    std::fprintf(stderr, "%s\n", ok.error().message.c_str());
    return 1;
  }
  return runStaged(options, out);
}

}  // namespace shrefract::cli
