// `bake --shard I/N`, `merge PARTS... -o FILE.shrf`, and what they share with `bake`.
#include "cli/shard_commands.h"

#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/field_summary.h"
#include "cli/progress.h"
#include "cli/scene_source.h"

namespace shrefract::cli {
namespace {

int fail(const std::string& message, int code = 1) {
  std::fprintf(stderr, "%s\n", message.c_str());
  return code;
}

}  // namespace

int writeFieldAndSummary(const Field& field, const std::string& output, bool json) {
  if (auto written = writeField(output, field); !written) return fail(written.error().message);
  std::error_code ec;
  const uint64_t bytes = std::filesystem::file_size(output, ec);
  if (json) {
    std::printf("%s\n", fieldSummaryJson(field, bytes).c_str());
  } else {
    std::printf("%s", fieldSummaryText(field, bytes).c_str());
    std::printf("wrote %s\n", output.c_str());
  }
  return 0;
}

int bakeShardToFile(const bake::Scene& scene, const bake::BakeOptions& options, bake::Shard shard,
                    const std::string& output, bool json, Progress& progress) {
  auto part = bake::bakePart(scene, options, shard);
  progress.finish();
  if (!part) return fail(options.settings.source + ": " + part.error().message);
  if (auto written = bake::writePart(output, part.value()); !written) return fail(written.error().message);
  const bake::BakePart& p = part.value();
  const uint64_t samples = bake::shardSampleCount(p.sampleCount, p.shard);
  if (json)
    std::printf("{\"part\": \"%s\", \"shard\": %u, \"shards\": %u, \"samples\": %" PRIu64
                ", \"total_samples\": %" PRIu64 ", \"rays\": %" PRIu64 ", \"trace_seconds\": %.3f, \"bake_seconds\": %.3f"
                ", \"peak_memory_bytes\": %" PRIu64 "}\n",
                jsonEscape(output).c_str(), p.shard.index, p.shard.count, samples, p.sampleCount, p.rays,
                p.timings.traceWallSeconds, p.timings.bakeSeconds, p.timings.peakMemoryBytes);
  else
    std::printf("shard %u/%u: %" PRIu64 " of %" PRIu64 " samples, %" PRIu64 " rays in %.2f s\nwrote %s\n",
                p.shard.index, p.shard.count, samples, p.sampleCount, p.rays, p.timings.traceWallSeconds,
                output.c_str());
  return 0;
}

int launchedRanks() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "MV2_COMM_WORLD_SIZE"})
    if (const char* v = std::getenv(name)) return std::max(1, std::atoi(v));
  return 1;
}

int mergeCommand(int argc, char** argv) {
  const std::vector<FlagSpec> flags = {{"output", true, "output field file (.shrf); also -o"},
                                       {"json", false, "print the summary as JSON on stdout"},
                                       {"help", false, "this text"}};
  auto parsed = Args::parse("merge", argc, argv, 2, flags);
  if (!parsed) return fail(parsed.error().message, 2);
  const Args& args = parsed.value();
  if (args.has("help")) {
    std::printf("usage: shrefract merge PART.shrfpart... -o FILE.shrf [--json]\n"
                "  joins the parts of `shrefract bake --shard I/N` (every I of one N) into the field the\n"
                "  single-process bake writes; the scene is loaded again from the source they record\n%s",
                usageLines(flags).c_str());
    return 0;
  }
  if (args.positional().empty()) return fail("shrefract merge: expected PART.shrfpart files", 2);
  const auto output = args.get("output");
  if (!output) return fail("shrefract merge: missing -o FILE.shrf", 2);
  if (!hasExtension(*output, ".shrf")) return fail(*output + ": the output must end in .shrf", 2);
  if (auto writable = checkOutputPath(*output); !writable) return fail(writable.error().message);

  std::vector<bake::BakePart> parts;
  for (const std::string& path : args.positional()) {
    auto part = bake::readPart(path);
    if (!part) return fail(part.error().message);
    parts.push_back(std::move(part.value()));
  }
  if (auto ok = bake::checkParts(parts); !ok) return fail(ok.error().message);
  std::vector<std::string> warnings;
  const std::string source = parts.front().settings.source;
  auto scene = loadScene(source, {}, &warnings);
  if (!scene) return fail(scene.error().message);
  for (const auto& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  Progress progress("merge", stderr);
  auto field = bake::mergeParts(
      scene.value(), std::move(parts), [&](const std::string& what) { progress.stage(what); },
      [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); });
  if (!field) return fail(source + ": " + field.error().message);
  return writeFieldAndSummary(field.value(), *output, args.has("json"));
}

}  // namespace shrefract::cli
