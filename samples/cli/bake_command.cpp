// `shrefract bake SCENE -o FILE.shrf`: the offline bake, with progress and a summary.
#include <shrefract/bake/bake.h>
#include <shrefract/bake/fit.h>
#include <shrefract/bake/layout.h>

#include <array>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <string>
#include <unistd.h>
#include <utility>
#include <vector>

#include "cli/args.h"
#include "cli/commands.h"
#include "cli/field_summary.h"
#include "cli/progress.h"
#include "cli/scene_source.h"
#include "cli/shard_commands.h"

namespace shrefract::cli {
namespace {

using K = ValueKind;

// The ranges come from the bake library's own limits where it has them. --help lists the flags a
// user bakes with, one short line each (docs/encodings.md has the details); the experiment
// switches and the knobs tests turn are developer options (--dev KEY=VALUE, listed by --help-dev).
std::vector<FlagSpec> bakeFlags() {
  const auto dev = developerOption;
  return sceneCommandFlags({
      {"output", true, "the field file to write, .shrf (also -o)"},
      {"encoding", true, "volume, pca, table or sh (default: chosen from the scene)"},
      {"choose-by-images", false, "choose between pca and volume by rendering both (minutes and GiB)"},
      {"max-bytes-per-sample", true, "keep the encoding with the lowest error in this many bytes a sample",
       K::Real, {1, 65536}},
      {"samples", true,
       "total surface samples (default " + std::to_string(bake::kDefaultSampleBudget) + ", or the scene's choice)",
       K::Integer, {1, 1e8}},
      {"layout", true, "sample layout: charts (default) or split"},
      {"volume-size", true, "volume: voxels per side of the distance grid (default " +
                                std::to_string(kDefaultVolumeSize) + ")", K::Integer,
       {double(kMinVolumeSize), double(kMaxVolumeSize)}},
      {"order", true, "SH order L (default 8; implies --encoding sh)", K::Integer, {0, double(bake::kMaxFitOrder)}},
      {"table-size", true, "table and pca: nodes per side of each table (default by encoding)", K::Integer,
       {2, double(bake::kMaxBakeTableSize)}},
      {"components", true, "pca: basis functions, the bytes a sample in u8 (default 324)", K::Integer,
       {1, double(kMaxComponents)}},
      {"quant", true, "coefficient storage: u8 (default) or f16"},
      {"path-rule", true, "branch followed at every interface: first-refraction (default) or highest-energy"},
      {"threads", true, "worker threads (default: all cores), never changing the result", K::Integer, {1, 1024}},
      {"shard", true, "I/N: bake shard I of N of the samples into a part for `shrefract merge`"},
      // Developer options: experiments and test knobs, each with its default the measured best.
      dev({"directions", true, "SH and grid tables: hemisphere grid ROWSxCOLUMNS (default 32x64)", K::Size,
           {double(bake::kMinDirectionRows), double(bake::kMaxDirectionRows)},
           {double(bake::kMinDirectionColumns), double(bake::kMaxDirectionColumns)}}),
      dev({"direction-sampling", true, "directions traced per sample: nodes or grid (default: by encoding)"}),
      dev({"density", true, "samples per unit area instead of a budget", K::Real, {0, kUnbounded, true}}),
      dev({"max-bounces", true, "cap on interactions inside the object (default 16)", K::Integer,
           {1, double(bake::kMaxBakeBounces)}}),
      dev({"clusters", true, "pca: clusters tried against the components (default: K and 3K)", K::Integer,
           {1, double(kMaxClusters)}}),
      dev({"exit-frame", true, "frame the exits are stored in: auto (default), sample or object"}),
      dev({"no-jump-distance", false, "tables traced at their nodes: store no jump distance"}),
      dev({"throughput", false, "store the path's Fresnel throughput as a channel"}),
      dev({"sh-fit", true, "SH fit: robust (default) or least-squares"}),
      dev({"window", true, "SH frequency smoothing: none (default), hann or lanczos"}),
      dev({"spatial", true, "smoothing over 0 (default), 3 or 5 neighbouring samples"}),
      dev({"regularization", true, "Tikhonov weight of the SH fit (default 1e-5)", K::Real, {0, kUnbounded}}),
      dev({"max-error", true, "smallest SH order and grid meeting this mean error in degrees", K::Real,
           {0, 180, true}}),
      dev({"held-out", true, "held-out directions a sample for the error estimate (default 4)", K::Integer,
           {0, 1024}}),
      }, true, "print the summary as JSON on stdout");
}

int fail(const std::string& message, int code = 1) {
  std::fprintf(stderr, "%s\n", message.c_str());
  return code;
}

// A usage error: the caller prints the message and exits 2.
Error usageError(std::string message) { return makeError(ErrorCode::InvalidArgument, std::move(message)); }

// Flag `name`'s value, one of `choices` by its name (toString, field.h), into `out`; `fallback`
// when the flag is not given. Else the usage error that lists them in order, naming the flag as
// `shown` ("--dev window").
template <class E>
Result<void> pick(const Args& args, const std::string& name, const std::string& shown, E fallback,
                  std::initializer_list<E> choices, E& out) {
  const std::string value = args.get(name).value_or(toString(fallback));
  std::string listed;
  size_t i = 0;
  for (const E e : choices) {
    if (value == toString(e)) {
      out = e;
      return {};
    }
    listed += std::string(i == 0 ? "" : i + 1 == choices.size() ? " or " : ", ") + toString(e);
    ++i;
  }
  return usageError("shrefract bake: " + shown + " must be " + listed + ", got '" + value + "'");
}

// --shard, checked against mpirun, and the output's extension, which depends on it.
Result<std::optional<bake::Shard>> shardFlag(const Args& args, const std::string& output) {
  std::optional<bake::Shard> shard;
  if (const auto text = args.get("shard")) {
    auto parsedShard = bake::parseShard(*text);
    if (!parsedShard) return usageError("shrefract bake: " + parsedShard.error().message);
    if (launchedRanks() > 1) return usageError("shrefract bake: --shard and mpirun both shard the samples: give one");
    shard = parsedShard.value();
  }
  const char* extension = shard ? ".shrfpart" : ".shrf";
  if (!hasExtension(output, extension)) return usageError(output + ": the output must end in " + extension);
  return shard;
}

// The flags with numeric values, each absent or within its declared range.
struct NumericFlags {
  std::optional<int64_t> order, samples, threads, bounces, spatial, heldOut, tableSize, components, clusters,
      volumeSize;
  std::optional<double> density, reg, maxError, maxBytes;
  std::optional<std::array<uint32_t, 2>> dirs;
};

Result<NumericFlags> readNumericFlags(const Args& args) {
  NumericFlags n;
  std::optional<Error> error;  // the first malformed flag's, in this order
  const auto read = [&error](auto parsed, auto& into) {
    if (parsed) into = parsed.value();
    else if (!error) error = parsed.error();
  };
  read(args.integer("order"), n.order);
  read(args.integer("samples"), n.samples);
  read(args.number("density"), n.density);
  read(args.integer("threads"), n.threads);
  read(args.integer("max-bounces"), n.bounces);
  read(args.integer("spatial"), n.spatial);
  read(args.number("regularization"), n.reg);
  read(args.integer("held-out"), n.heldOut);
  read(args.size("directions"), n.dirs);
  read(args.number("max-error"), n.maxError);
  read(args.integer("table-size"), n.tableSize);
  read(args.integer("components"), n.components);
  read(args.integer("clusters"), n.clusters);
  read(args.number("max-bytes-per-sample"), n.maxBytes);
  read(args.integer("volume-size"), n.volumeSize);
  if (error) return *error;
  return n;
}

// The numeric flags that combine with no text flag: their conflicts, then the settings.
Result<void> applyNumericFlags(const NumericFlags& n, BakeSettings& s) {
  if (n.spatial && *n.spatial != 0 && *n.spatial != 3 && *n.spatial != 5)
    return usageError("shrefract bake: --dev spatial must be 0, 3 or 5, got '" + std::to_string(*n.spatial) + "'");
  if (n.density && n.samples) return usageError("shrefract bake: give --samples or --dev density, not both");
  if (n.maxBytes && n.maxError)
    return usageError("shrefract bake: give --max-bytes-per-sample or --dev max-error, not both");
  if (n.maxError) {
    s.maxErrorDegrees = static_cast<float>(*n.maxError);
    s.order = 16;  // the ceiling of the search unless --order lowers it
  }
  if (n.order) s.order = static_cast<uint32_t>(*n.order);
  if (n.samples) s.sampleBudget = static_cast<uint64_t>(*n.samples);
  if (n.density) {
    s.sampleBudget = 0;
    s.samplesPerUnitArea = static_cast<float>(*n.density);
  }
  if (n.threads) s.threads = static_cast<uint32_t>(*n.threads);
  if (n.bounces) s.maxBounces = static_cast<uint32_t>(*n.bounces);
  if (n.spatial) s.spatialNeighbours = static_cast<uint32_t>(*n.spatial);
  if (n.reg) s.regularization = static_cast<float>(*n.reg);
  if (n.dirs) {
    s.directionsTheta = (*n.dirs)[0];
    s.directionsPhi = (*n.dirs)[1];
  }
  return {};
}

// --layout, --quant and the options --dev window and --dev sh-fit.
Result<void> applyLayoutFlags(const Args& args, BakeSettings& s) {
  // Charts by default: at the default budget the split layout's per-triangle lattices are coarse
  // (n = 1 to 7 on the built-in scenes and the bunny) and flicker more (docs/technique.md).
  Result<void> picked =
      pick(args, "layout", "--layout", SampleLayout::Charts, {SampleLayout::Split, SampleLayout::Charts}, s.layout);
  if (picked)
    picked = pick(args, "window", "--dev window", SmoothingWindow::None,
                  {SmoothingWindow::None, SmoothingWindow::Hann, SmoothingWindow::Lanczos}, s.window);
  if (picked)
    picked = pick(args, "sh-fit", "--dev sh-fit", ShFit::Robust, {ShFit::Robust, ShFit::LeastSquares}, s.shFit);
  if (picked)
    picked = pick(args, "quant", "--quant", Quantization::U8, {Quantization::U8, Quantization::F16}, s.quantization);
  return picked;
}

// --encoding with the flags that belong to one encoding: --components, --order, --dev max-error.
Result<void> applyEncodingFlag(const Args& args, const NumericFlags& n, BakeSettings& s) {
  // The default is the measured best at the paper's 324 bytes per sample (docs/encodings.md): Pca
  // with 324 weights over 64x64 tables traced at their nodes. --order or --dev max-error ask for SH.
  const bool shImplied = n.order || n.maxError;
  const Result<void> picked =
      pick(args, "encoding", "--encoding", shImplied ? Encoding::Sh : Encoding::Pca,
           {Encoding::Sh, Encoding::Table, Encoding::Pca, Encoding::Volume}, s.encoding);
  if (!picked) return picked;
  // The default (no --encoding, no byte budget, none of Pca's own flags): Pca, and the volume tried
  // beside it where the scene allows (BakeSettings::tryVolume). A flag of Pca's asks for a Pca field.
  const bool pcaAsked = n.components || n.clusters || n.tableSize || n.dirs || args.get("direction-sampling") ||
                        args.get("exit-frame") || args.has("no-jump-distance");
  s.tryVolume = !args.get("encoding") && !shImplied && !n.maxBytes && !pcaAsked;
  s.chooseByImages = args.has("choose-by-images");
  if (s.chooseByImages && !s.tryVolume)
    return usageError("shrefract bake: --choose-by-images chooses the encoding: give no --encoding, nor a flag of one");
  if (n.volumeSize && s.encoding != Encoding::Volume && !s.tryVolume)
    return usageError("shrefract bake: --volume-size needs --encoding volume (or no --encoding)");
  // The default bake chooses its volume's size by images (bake.h kFinerVolumeGainDb): 0 asks for that.
  s.volumeSize = n.volumeSize ? static_cast<uint32_t>(*n.volumeSize) : s.tryVolume ? 0u : kDefaultVolumeSize;
  if (s.encoding == Encoding::Volume && (n.tableSize || n.components || n.maxBytes))
    return usageError("shrefract bake: --table-size, --components and --max-bytes-per-sample do not apply to "
                      "--encoding volume (it stores no bytes per sample)");
  if ((n.tableSize || n.components) && s.encoding == Encoding::Sh && !n.maxBytes)
    return usageError("shrefract bake: --table-size and --components need --encoding table or pca");
  if (n.clusters && s.encoding != Encoding::Pca)
    return usageError("shrefract bake: --dev clusters needs --encoding pca");
  s.components = n.components ? static_cast<uint32_t>(*n.components) : 324u;
  s.clusters = n.clusters ? static_cast<uint32_t>(*n.clusters) : 0u;
  if ((n.order || n.maxError) && s.encoding != Encoding::Sh)
    return usageError("shrefract bake: --order and --dev max-error apply to --encoding sh only");
  // With a byte budget the chosen encoding may be SH, so its fit may be asked for.
  if (args.get("sh-fit") && s.encoding != Encoding::Sh && !n.maxBytes)
    return usageError("shrefract bake: --dev sh-fit applies to --encoding sh only");
  return {};
}

// --dev direction-sampling and --table-size, whose defaults follow the encoding.
Result<void> applySamplingFlags(const Args& args, const NumericFlags& n, BakeSettings& s) {
  // Node sampling is the measured better one for Pca's tables, the grid fit for the coarser
  // tables of `table` (docs/encodings.md, "Sampling"); asking for a grid size asks for the grid.
  // With --max-bytes-per-sample it is what a chosen Pca field is baked with (SH and Table fields
  // are grid fits whatever this says).
  const bool tabulated = s.encoding == Encoding::Table || s.encoding == Encoding::Pca;
  const bool nodesByDefault = s.encoding == Encoding::Pca && !n.dirs;
  const Result<void> picked =
      pick(args, "direction-sampling", "--dev direction-sampling",
           nodesByDefault ? DirectionSampling::Nodes : DirectionSampling::Grid,
           {DirectionSampling::Nodes, DirectionSampling::Grid}, s.directionSampling);
  if (!picked) return picked;
  if (s.directionSampling == DirectionSampling::Nodes && !tabulated && !n.maxBytes)
    return usageError("shrefract bake: --dev direction-sampling=nodes needs --encoding table or pca");
  if (s.directionSampling == DirectionSampling::Nodes && n.dirs)
    return usageError("shrefract bake: --dev directions sets the grid, which --dev direction-sampling=nodes does not "
                      "trace");
  // A Pca fitted to a grid keeps its former tables: the default 32x64 grid has half as many
  // directions as 64x64 tables have nodes.
  const uint32_t pcaTableSize = s.directionSampling == DirectionSampling::Nodes ? bake::kDefaultPcaTableSize
                                                                                : bake::kDefaultGridPcaTableSize;
  s.tableSize = n.tableSize ? static_cast<uint32_t>(*n.tableSize) : s.encoding == Encoding::Pca ? pcaTableSize : 9u;
  return {};
}

// --path-rule, --max-bytes-per-sample and the options --dev throughput, no-jump-distance and exit-frame.
Result<void> applyPathFlags(const Args& args, const NumericFlags& n, BakeSettings& s) {
  const Result<void> rule = pick(args, "path-rule", "--path-rule", PathRule::FirstRefraction,
                                 {PathRule::HighestEnergy, PathRule::FirstRefraction}, s.pathRule);
  if (!rule) return rule;
  s.throughput = args.has("throughput");
  // The image contest chooses the rule too, by the exact renders against the full tree, where no
  // rule is given (BakeSettings::choosePathRule).
  s.choosePathRule = !args.get("path-rule") && !s.throughput && s.chooseByImages;
  s.jumpDistance = !args.has("no-jump-distance");
  const Result<void> frame = pick(args, "exit-frame", "--dev exit-frame", ExitFrame::Auto,
                                  {ExitFrame::Auto, ExitFrame::Sample, ExitFrame::Object}, s.exitFrame);
  if (!frame) return frame;
  if (n.maxBytes) s.maxBytesPerSample = static_cast<float>(*n.maxBytes);
  return {};
}

// Every bake setting from the flags, or the first usage error in the order the flags are checked.
Result<BakeSettings> bakeSettingsFrom(const Args& args, const NumericFlags& n) {
  BakeSettings s;
  s.source = args.positional()[0];
  s.sampleBudget = bake::kDefaultSampleBudget;
  // Nor a basis size: the clusters tried may outnumber the components (BakeSettings::moreClusters).
  s.moreClusters = !n.components && !n.clusters && !n.maxBytes;
  if (auto applied = applyNumericFlags(n, s); !applied) return applied.error();
  if (auto applied = applyLayoutFlags(args, s); !applied) return applied.error();
  if (auto applied = applyEncodingFlag(args, n, s); !applied) return applied.error();
  const bool budgetGiven = n.samples || n.density;
  // The image contest, with the default budget, lays a Volume field out again at more samples where
  // its texels miss the paths between them (bake.h kVolumeDensifyBelowDb); a budget given is kept.
  s.volumeDensify = !budgetGiven && s.chooseByImages;
  // The scene's own default takes the budget its encoding affords (bake.h settingsForScene).
  if (!budgetGiven && s.tryVolume && !s.chooseByImages) s.sampleBudget = 0;
  if (auto applied = applySamplingFlags(args, n, s); !applied) return applied.error();
  if (auto applied = applyPathFlags(args, n, s); !applied) return applied.error();
  return s;
}

// Progress and notes on stderr while the bake runs.
bake::BakeOptions bakeOptions(const BakeSettings& s, const NumericFlags& n, Progress& progress) {
  bake::BakeOptions options;
  options.settings = s;
  if (n.heldOut) options.heldOutDirections = static_cast<uint32_t>(*n.heldOut);
  options.note = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
  options.stage = [&progress](const std::string& what) { progress.stage(what); };
  options.progress = [&progress](const bake::BakeProgress& p) {
    progress.update(p.samplesDone, p.samplesTotal, p.seconds, p.seconds > 0 ? double(p.rays) / p.seconds : 0.0,
                    "rays/s");
  };
  return options;
}

// Loads the scene and bakes it: across the mpirun ranks, as one shard, or whole in this process.
int bakeScene(const Args& args, BakeSettings s, const NumericFlags& n, const std::string& output,
              const std::optional<bake::Shard>& shard) {
  const SceneOverrides overrides = sceneOverridesFrom(args, true);
  std::vector<std::string> warnings;
  auto scene = loadScene(s.source, overrides, &warnings);
  // Recorded with its overrides and where the file lies from the field, so that `render --mode
  // exact` and `report` rebuild this scene from any working directory.
  s.source = recordedSceneSpec(s.source, overrides, output);
  // On failure the error alone: one line naming the file (the warnings led up to it).
  if (!scene) return fail(scene.error().message);
  for (const auto& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());

  Progress progress("bake", stderr);
  const bake::BakeOptions options = bakeOptions(s, n, progress);
  if (launchedRanks() > 1) return distributedBake(scene.value(), options, output, args.has("json"));
  if (shard) {
    return bakeShardToFile(scene.value(), options, *shard, output, args.has("json"), progress);
  }
  auto field = bake::bakeField(scene.value(), options);
  progress.finish();
  if (!field) return fail(s.source + ": " + field.error().message);
  return writeFieldAndSummary(field.value(), output, args.has("json"));
}

}  // namespace

int bakeCommand(int argc, char** argv) {
  const std::vector<FlagSpec> kFlags = bakeFlags();
  auto parsed = Args::parse("bake", argc, argv, 2, kFlags);
  if (!parsed) return fail(parsed.error().message, 2);
  const Args& args = parsed.value();
  if (args.has("help")) {
    std::printf("usage: shrefract bake SCENE -o FILE.shrf [flags]\n  SCENE: builtin:NAME or a .gltf/.glb file\n%s"
                "developer options (--dev KEY=VALUE): shrefract bake --help-dev\n",
                usageLines(kFlags).c_str());
    return 0;
  }
  if (args.has("help-dev")) {
    std::printf("usage: shrefract bake SCENE -o FILE.shrf [flags] [--dev KEY[=VALUE]]...\n"
                "developer options: experiments and test knobs, each with a measured default; they may change\n%s",
                developerUsageLines(kFlags).c_str());
    return 0;
  }
  if (args.positional().size() != 1) return fail("shrefract bake: expected exactly one SCENE argument", 2);
  const auto output = args.get("output");
  if (!output) return fail("shrefract bake: missing -o FILE.shrf", 2);
  auto shard = shardFlag(args, *output);
  if (!shard) return fail(shard.error().message, 2);
  auto numeric = readNumericFlags(args);
  if (!numeric) return fail(numeric.error().message, 2);
  auto settings = bakeSettingsFrom(args, numeric.value());
  if (!settings) return fail(settings.error().message, 2);

  if (auto writable = checkOutputPath(*output); !writable) return fail(writable.error().message);
  return bakeScene(args, settings.value(), numeric.value(), *output, shard.value());
}

int infoCommand(int argc, char** argv) {
  const std::vector<FlagSpec> flags = {{"json", false, "print as JSON"}, {"help", false, "this text"}};
  auto parsed = Args::parse("info", argc, argv, 2, flags);
  if (!parsed) return fail(parsed.error().message, 2);
  const Args& args = parsed.value();
  if (args.has("help")) {
    std::printf("usage: shrefract info FILE.shrf [--json]\n%s", usageLines(flags).c_str());
    return 0;
  }
  if (args.positional().size() != 1) return fail("shrefract info: expected exactly one FILE.shrf", 2);
  const std::string path = args.positional()[0];
  auto field = readField(path);
  if (!field) return fail(field.error().message);
  std::error_code ec;
  const uint64_t bytes = std::filesystem::file_size(path, ec);
  if (args.has("json")) std::printf("%s\n", fieldSummaryJson(field.value(), bytes).c_str());
  else std::printf("%s: format version %u\n%s", path.c_str(), kFieldFormatVersion, fieldSummaryText(field.value(), bytes).c_str());
  return 0;
}

}  // namespace shrefract::cli
