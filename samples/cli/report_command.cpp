// `shrefract report [SCENES...] -o DIR`: error against run time for every setting.
#include <cstdio>
#include <string>

#include "cli/args.h"
#include "cli/commands.h"
#include "report/report.h"

namespace shrefract::cli {

int reportCommand(int argc, char** argv) {
  const std::vector<FlagSpec> flags = {
      {"output", true, "output directory (created); also -o"},
      {"full", false, "the paper's workload (35k samples, 32x64 directions; long)"},
      {"smoke", false, "a tiny report in seconds (for tests)"},
      {"fidelity-only", false, "only the fidelity section (physical reference, encodings, error decomposition)"},
      {"size", true, "image size WxH (default 320x240; --full 640x480)"},
      {"frames", true, "GPU frames timed per setting"},
      {"threads", true, "bake and CPU reference threads (default: all cores)"},
      {"device", true, "Vulkan device index"},
      {"help", false, "this text"},
  };
  auto parsed = Args::parse("report", argc, argv, 2, flags);
  if (!parsed) {
    std::fprintf(stderr, "%s\n", parsed.error().message.c_str());
    return 2;
  }
  const Args& args = parsed.value();
  if (args.has("help")) {
    std::printf("usage: shrefract report [SCENES...] -o DIR [flags]\n"
                "  SCENES: builtin:NAME[?tessellation=N&ior=X&absorption=Y] or glTF files\n"
                "  default: builtin:sphere and builtin:glass-of-water for the settings sweeps; the fidelity\n"
                "  section takes the four built-in scenes and ../shared/assets/bunny.glb when it exists\n%s",
                usageLines(flags).c_str());
    return 0;
  }
  auto bad = [](const std::string& m) {
    std::fprintf(stderr, "%s\n", m.c_str());
    return 2;
  };
  const auto out = args.get("output");
  if (!out) return bad("shrefract report: missing -o DIR");
  if (args.has("full") && args.has("smoke")) return bad("shrefract report: --full and --smoke exclude each other");
  auto size = args.size("size");
  auto frames = args.integer("frames");
  auto threads = args.integer("threads");
  auto device = args.integer("device");
  for (const Error* e : {size.ok() ? nullptr : &size.error(), frames.ok() ? nullptr : &frames.error(),
                         threads.ok() ? nullptr : &threads.error(), device.ok() ? nullptr : &device.error()})
    if (e) return bad(e->message);
  if (frames.value() && (*frames.value() < 1 || *frames.value() > 1000)) return bad("shrefract report: --frames must be 1..1000");
  if (threads.value() && (*threads.value() < 1 || *threads.value() > 1024)) return bad("shrefract report: --threads must be 1..1024");

  report::ReportOptions options;
  options.scenes = args.positional();
  options.outputDirectory = *out;
  options.size = args.has("full") ? report::ReportSize::Full
                 : args.has("smoke") ? report::ReportSize::Smoke
                                     : report::ReportSize::Default;
  if (size.value()) {
    options.width = (*size.value())[0];
    options.height = (*size.value())[1];
  }
  if (frames.value()) options.frames = static_cast<uint32_t>(*frames.value());
  if (threads.value()) options.threads = static_cast<uint32_t>(*threads.value());
  if (device.value()) options.deviceIndex = static_cast<int>(*device.value());
  options.fidelityOnly = args.has("fidelity-only");
  auto result = report::runReport(options);
  if (!result) {
    std::fprintf(stderr, "%s\n", result.error().message.c_str());
    return 1;
  }
  std::printf("report: %zu settings measured in %.1f s; wrote %zu files to %s (start with %s/report.md)\n",
              result.value().rows.size(), result.value().seconds, result.value().files.size(), out->c_str(),
              out->c_str());
  for (const auto& row : result.value().rows)
    if (row.group == "order" || row.group == "baseline")
      std::printf("  %-40s %-24s mean angle %6.2f deg  PSNR %6.2f dB  frame %8.2f ms%s\n",
                  row.scene.substr(0, 40).c_str(), row.label.c_str(), row.meanAngle, row.psnr, row.frameMs,
                  row.gpu ? "" : " (CPU)");
  for (const auto& scene : result.value().fidelity) {
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
  return 0;
}

}  // namespace shrefract::cli
