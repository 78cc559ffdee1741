#include "report/fidelity.h"

#include <shrefract/bake/bake.h>
#include <shrefract/trace/image_metrics.h>
#include <shrefract/bake/layout.h>
#include <shrefract/trace/reference_render.h>
#include <shrefract/bake/shard.h>
#include <shrefract/cpu_reference.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <tuple>

#include "cli/scene_source.h"
#include "report/plot.h"
#include "report/report_text.h"

namespace shrefract::report {
namespace {


// The bunny of the shared assets, looked for from the working directory as the benchmarks do; the
// section skips it (with a line in the report) when it is not there.
constexpr const char* kBunny = "../shared/assets/bunny.glb";

// One field setting. It is traced once and finished twice, in f16 and in u8 (bakePair): the u8
// row is the field `bake --quant u8` writes, refinement layers included (Pca), for one trace.
struct Variant {
  std::string series;  // plot series without the quantization: "sh", "table", "pca", ...
  std::string label;   // point label: "L4", "N16", "K32"
  BakeSettings settings;
  bool isDefault = false;
  // The default field's path rule decision: this variant bakes the default under the other rule
  // than the one the bake chose, and where the default kept a volume, that volume (its grid and
  // samples) rather than choosing again (followDefault), so that the rule is all its row changes.
  bool followsDefault = false;
};

struct Profile {
  uint32_t width = 320, height = 240;
  uint32_t samplesPerAxis = 4;
  uint32_t treeDepth = 8;
  uint32_t frames = 5;
  uint32_t environmentWidth = 1024;  // as `shrefract render --env builtin`
  bool antialiasing = true;          // the 1-spp section (CPU references filtered at 1 spp)
  std::vector<std::string> scenes;
  std::vector<Variant> variants;
};

BakeSettings withEncoding(BakeSettings s, Encoding encoding, uint32_t order, uint32_t tableSize, uint32_t components) {
  s.encoding = encoding;
  s.order = encoding == Encoding::Sh ? order : 0;
  s.tableSize = tableSize;
  s.components = components;
  // Pca tables are traced at their nodes, Table fields fitted to the grid, as the tool bakes them
  // (docs/encodings.md, "Sampling").
  s.directionSampling = encoding == Encoding::Pca ? DirectionSampling::Nodes : DirectionSampling::Grid;
  return s;
}

}  // namespace

BakeSettings defaultFieldSettings() {
  BakeSettings s;
  s.encoding = Encoding::Pca;  // where the scene is not a volume (bake::settingsForScene)
  s.order = 0;
  s.layout = SampleLayout::Charts;  // the tool's default
  s.pathRule = PathRule::FirstRefraction;
  s.tryVolume = true;  // the scene decides the encoding, as `shrefract bake SCENE` with no flags
  s.sampleBudget = 0;  // and the budget its encoding affords
  return s;
}

namespace {

// The settings a size sweeps the encodings over.
struct SweepSettings {
  BakeSettings base;  // the library default: order 8, 32x64 directions, split layout, default budget
  BakeSettings sweep = base;
  // The SH rows' direction grid where it differs from the sweep's (0: the sweep's).
  uint32_t shDirectionsTheta = 0, shDirectionsPhi = 0;
  std::vector<uint32_t> orders, tables, components, volumes;
  uint32_t pcaTable = 16;  // the Pca sweep's tables: 16x16 keeps the sweep within minutes (the default field is 64x64)
};

// The size's image, reference and scenes go to `p`; its bake settings are returned.
SweepSettings sizeSettings(ReportSize size, Profile& p) {
  SweepSettings w;
  switch (size) {
    case ReportSize::Smoke:
      p.width = 64;
      p.height = 48;
      p.samplesPerAxis = 2;
      p.treeDepth = 4;
      p.frames = 1;
      p.environmentWidth = 128;
      p.scenes = {"builtin:sphere?tessellation=1"};
      w.base.order = 4;
      w.base.directionsTheta = 8;
      w.base.directionsPhi = 16;
      w.base.sampleBudget = 300;
      w.sweep = w.base;
      w.orders = {2};
      w.tables = {4};
      w.pcaTable = 4;
      w.components = {4};
      w.volumes = {16};
      break;
    case ReportSize::Default:
      // Minutes on 2 cores: the default field beside the paper's SH order 8 and a 9x9 table, both
      // at 8000 samples fitted to 16x32 directions, 240x180 at 3x3 against the full tree.
      p.width = 240;
      p.height = 180;
      p.samplesPerAxis = 3;
      p.frames = 3;
      p.antialiasing = false;
      p.scenes = {"builtin:sphere", "builtin:cube", "builtin:torus", "builtin:glass-of-water", kBunny};
      w.base = defaultFieldSettings();
      w.sweep.sampleBudget = 8000;
      w.sweep.directionsTheta = 16;
      w.sweep.directionsPhi = 32;
      w.orders = {8};
      w.tables = {9};
      break;
    case ReportSize::Full:
      // The sweep traces 16x32 directions (SH rows: 32x64, below) at up to 5000 samples, a
      // sixteenth of the default bake's paths; the default field itself is the default bake.
      p.scenes = {"builtin:sphere", "builtin:cube", "builtin:torus", "builtin:glass-of-water", kBunny};
      w.base = defaultFieldSettings();
      w.sweep.directionsTheta = 16;
      w.sweep.directionsPhi = 32;
      w.sweep.sampleBudget = 5000;
      // SH keeps the default bake's 32x64 directions: 16x32 leaves order 12 (169 functions, fitted
      // robustly, which discounts the directions across a jump) under-determined.
      w.shDirectionsTheta = BakeSettings{}.directionsTheta;
      w.shDirectionsPhi = BakeSettings{}.directionsPhi;
      w.orders = {2, 4, 8, 12};
      w.tables = {4, 6, 9, 16};               // N9 in u8: the paper's 324 bytes per sample
      w.components = {8, 32, 81, 324};        // K324 in u8: 324 bytes per sample
      w.volumes = {64, 128, 256};             // 1, 8 and 64 MiB
      break;
  }
  return w;
}

// The default field first (the encoding its scene decides: bake::settingsForScene), then with
// --full its path rule decision, measured: the same field under the other rule.
void addDefaultVariants(Profile& p, const BakeSettings& base, ReportSize size) {
  const std::string label = fmt("volume %u^3 or pca K%u N%u", kDefaultVolumeSize, bake::kDefaultPcaComponents,
                                bake::kDefaultPerSampleTableSize);
  p.variants.push_back({"default", label, base, true});
  if (size != ReportSize::Full) return;
  BakeSettings rule = base;
  const bool firstRefraction = base.pathRule == PathRule::FirstRefraction;
  rule.pathRule = firstRefraction ? PathRule::HighestEnergy : PathRule::FirstRefraction;
  p.variants.push_back(
      {firstRefraction ? "default, highest-energy" : "default, first-refraction", label, rule, false, true});
}

// The encoding sweeps: SH (robust, windowed, least squares, under the other path rule and with
// throughput), Table, Pca.
void addSweepVariants(Profile& p, const SweepSettings& w, ReportSize size) {
  const BakeSettings& base = w.base;
  const BakeSettings& sweep = w.sweep;
  BakeSettings shSweep = sweep;
  if (w.shDirectionsTheta != 0) {
    shSweep.directionsTheta = w.shDirectionsTheta;
    shSweep.directionsPhi = w.shDirectionsPhi;
  }
  for (uint32_t order : w.orders)
    p.variants.push_back({"sh", fmt("L%u", order), withEncoding(shSweep, Encoding::Sh, order, 0, 0)});
  // SH fitted by least squares (`bake --sh-fit least-squares`, the fit before the robust
  // default), plain and with the Lanczos window (`--window lanczos`), which damps the ringing that
  // least squares spreads from the jumps over the hemisphere: what the robust fit gains, and where
  // it loses (docs/technique.md, "Robust fit"). The window is least squares' remedy: after the
  // robust fit it lost on the cube (u8, orders 2 to 12: 11.50, 11.50, 15.45, 16.87 dB against
  // 14.47, 15.59, 16.90, 18.12 unwindowed).
  if (size == ReportSize::Full) {
    const auto leastSquares = [&](uint32_t order, SmoothingWindow window) {
      BakeSettings s = withEncoding(shSweep, Encoding::Sh, order, 0, 0);
      s.shFit = ShFit::LeastSquares;
      s.window = window;
      return s;
    };
    for (uint32_t order : w.orders)
      p.variants.push_back({"sh least-squares lanczos", fmt("L%u", order), leastSquares(order, SmoothingWindow::Lanczos)});
    for (uint32_t order : w.orders)
      p.variants.push_back({"sh least-squares", fmt("L%u", order), leastSquares(order, SmoothingWindow::None)});
  }
  if (size != ReportSize::Default) {
    // The path rule and throughput fields are SH at the paper's order (or the smoke bake's).
    const uint32_t order = base.encoding == Encoding::Sh ? base.order : 8;
    BakeSettings s = withEncoding(shSweep, Encoding::Sh, order, 0, 0);
    s.pathRule = PathRule::FirstRefraction;
    p.variants.push_back({"sh first-refraction", fmt("L%u", order), s});
    s.pathRule = PathRule::HighestEnergy;
    s.throughput = true;
    p.variants.push_back({"sh throughput", fmt("L%u", order), s});
  }
  for (uint32_t n : w.tables)
    p.variants.push_back({"table", fmt("N%u", n), withEncoding(sweep, Encoding::Table, 0, n, 0)});
  for (uint32_t k : w.components)
    p.variants.push_back({"pca", fmt("K%u", k), withEncoding(sweep, Encoding::Pca, 0, w.pcaTable, k)});
  // The volume: no bytes per sample, its memory the grid's (4 N^3 bytes), on the default bake's
  // samples (it traces nothing per sample, so the sweep's budget would only coarsen its atlas).
  for (uint32_t n : w.volumes) {
    BakeSettings s = withEncoding(base, Encoding::Volume, 0, 0, 0);
    s.tryVolume = false;
    s.volumeDensify = false;  // the grid alone varies along the row
    s.volumeSize = n;
    p.variants.push_back({"volume", fmt("V%u", n), s});
  }
}

Profile profileFor(ReportSize size, uint64_t samples) {
  Profile p;
  SweepSettings w = sizeSettings(size, p);
  w.base.quantization = Quantization::F16;
  w.sweep.quantization = Quantization::F16;
  if (samples != 0) {  // report --samples: a budget given, as `bake --samples`
    w.base.sampleBudget = w.sweep.sampleBudget = samples;
    w.base.volumeDensify = false;
  }
  addDefaultVariants(p, w.base, size);
  addSweepVariants(p, w, size);
  return p;
}

std::string sceneTitle(const std::string& spec) {
  std::string t = spec.substr(0, spec.find('?'));
  const size_t slash = t.find_last_of('/');
  return slash == std::string::npos ? t : t.substr(slash + 1);
}

std::string parametersOf(const BakeRecord& s) {
  switch (s.encoding) {
    case Encoding::Sh: return fmt(s.window == SmoothingWindow::None ? "L%u" : "L%u %s", s.order, toString(s.window));
    case Encoding::Table: return fmt("N%u", s.tableSize);
    case Encoding::Pca: return fmt("K%u N%u", s.components, s.tableSize);
    case Encoding::Volume: return fmt("V%u", s.volumeSize);
  }
  return "?";
}

// The f16 field of a variant and its u8 twin from one trace (see Variant): the bake's part, finished
// twice, as `bake --shard` and `merge` would (byte for byte the fields bakeField makes). The u8 twin
// is finished first: it is the tool's default, so where the bake tries the volume (tryVolume) its
// choice is the tool's. A volume stores nothing to quantize, so where the u8 bake kept one the f16
// field is the same grid; where it kept its own encoding the f16 finish does not try the volume
// again. Either way the second finish skips a choice that took 10 to 17 minutes of the default
// bake (the Pca basis, the clusters and the volumes' images) and could only repeat the first.
struct BakedPair {
  Field f16;
  Result<Field> u8;
};
Result<BakedPair> bakePair(const bake::Scene& scene, const bake::BakeOptions& asked) {
  bake::BakeOptions options = asked;
  options.settings = bake::settingsForScene(scene, asked.settings);  // the tool's default decides first
  const auto relabelled = [](Field volume, Quantization q) {
    volume.quantization = volume.settings.quantization = q;
    return volume;
  };
  // A Volume field stores nothing per sample to quantize and has no parts: one bake is both.
  if (options.settings.encoding == Encoding::Volume) {
    auto field = bake::bakeField(scene, options);
    if (!field) return field.error();
    Result<Field> u8 = relabelled(field.value(), Quantization::U8);
    return BakedPair{relabelled(std::move(field.value()), Quantization::F16), std::move(u8)};
  }
  auto part = bake::bakePart(scene, options, bake::Shard{});
  if (!part) return part.error();
  bake::BakePart f16Part = part.value();
  part.value().settings.quantization = Quantization::U8;
  std::vector<bake::BakePart> parts;
  parts.push_back(std::move(part.value()));
  Result<Field> u8 = bake::mergeParts(scene, std::move(parts));
  if (u8 && u8.value().encoding == Encoding::Volume)
    return BakedPair{relabelled(u8.value(), Quantization::F16), std::move(u8)};
  if (u8) f16Part.settings.tryVolume = false;
  parts.clear();
  parts.push_back(std::move(f16Part));
  auto f16 = bake::mergeParts(scene, std::move(parts));
  if (!f16) return f16.error();
  return BakedPair{std::move(f16.value()), std::move(u8)};
}

// A GPU render: the image at S x S samples per pixel (untimed), then `frames` timed frames at 1 spp
// (what a host pays per frame; medians), the last of which is kept; with `msaaToo`, also one
// untimed 1-spp frame with the host's 4x MSAA (a count every Vulkan device offers).
struct GpuRender {
  bake::Image image;
  bake::Image image1spp;
  std::optional<bake::Image> image1sppMsaa;  // with msaaToo: 1 spp with the host's 4x MSAA
  double decompressionMs = 0.0, rasterMs = 0.0, frameMs = 0.0;
};

Result<GpuRender> renderOnGpu(offscreen::Session& session, const Environment& environment,
                              const std::vector<Object*>& objects, const Camera& camera, ShadingMode mode,
                              const Profile& p, uint32_t width, uint32_t height, uint32_t frames,
                              bool msaaToo = false) {
  GpuRender out;
  offscreen::FrameSettings fs;
  fs.width = width;
  fs.height = height;
  fs.camera = camera;
  fs.mode = mode;
  fs.samplesPerAxis = p.samplesPerAxis;
  auto image = offscreen::renderFrame(session, environment, objects, fs, nullptr);
  if (!image) return image.error();
  out.image = std::move(image).value();
  fs.samplesPerAxis = 1;
  // One untimed frame first: pipeline creation and first-use costs are not frame time.
  if (auto warm = offscreen::renderFrame(session, environment, objects, fs, nullptr); !warm) return warm.error();
  fs.frames = frames;
  offscreen::FrameTimings timings;
  auto timed = offscreen::renderFrame(session, environment, objects, fs, &timings);
  if (!timed) return timed.error();
  out.image1spp = std::move(timed).value();
  if (msaaToo) {
    fs.frames = 1;
    fs.msaaSamples = VK_SAMPLE_COUNT_4_BIT;
    auto msaa = offscreen::renderFrame(session, environment, objects, fs, nullptr);
    if (!msaa) return msaa.error();
    out.image1sppMsaa = std::move(msaa).value();
  }
  // Medians over the timed frames: a shared CPU (lavapipe) makes single frames noisy.
  out.decompressionMs = median(timings.gpuDecompressionMs);
  out.rasterMs = median(timings.gpuRasterMs);
  out.frameMs = median(timings.wallMs);
  return out;
}


// What the measurements of one scene share.
struct SceneContext {
  const Profile& profile;
  const FidelityOptions& options;
  offscreen::Session& session;
  const Environment& gpuEnvironment;
  const bake::Image& environment;
  std::vector<std::string>& files;
  const std::string& spec;
  const bake::Scene& scene;
  const bake::Tracer& tracer;
  std::string name;  // file name stem
  uint32_t width = 0, height = 0, frames = 0;
  Camera camera;
  bake::ReferenceImage physical;
  bake::ReferenceImage dense;  // the full tree at 2S x 2S (measurePhysical)
  std::map<std::pair<PathRule, bool>, bake::ReferenceImage> exact;  // by path rule and throughput
};

// PSNR over the physical reference's object pixels.
Result<double> psnrOf(const SceneContext& c, const bake::Image& approx, const bake::Image& reference) {
  auto e = bake::compareImages(approx, reference, c.physical.mask, {}, {});
  if (!e) return e.error();
  return e.value().psnr;
}

Result<void> writeOut(SceneContext& c, const std::string& name, const bake::Image& image) {
  if (auto r = bake::writeImage(c.options.outputDirectory + "/" + name, image); !r) return r;
  c.files.push_back(name);
  return {};
}

// samplesPerAxis 0: the profile's.
Result<bake::ReferenceImage> cpuRender(const SceneContext& c, bake::ReferenceOptions ro, const std::string& what,
                                       uint32_t samplesPerAxis = 0) {
  ro.width = c.width;
  ro.height = c.height;
  ro.camera = c.camera;
  ro.samplesPerAxis = samplesPerAxis ? samplesPerAxis : c.profile.samplesPerAxis;
  ro.threads = c.options.threads;
  auto image = bake::renderReference(c.tracer, c.scene, c.environment, ro);
  if (!image) return makeError(image.error().code, c.spec + ": " + what + ": " + image.error().message);
  std::fprintf(stderr, "report: fidelity: %s: %s (CPU, %ux%u spp): %.2f s\n", c.spec.c_str(), what.c_str(),
               ro.samplesPerAxis, ro.samplesPerAxis, image.value().seconds);
  return image;
}

const char* ruleName(PathRule rule) { return rule == PathRule::HighestEnergy ? "highest-energy" : "first-refraction"; }

FidelityRow baseRow(const SceneContext& c, const std::string& kind, const std::string& label) {
  FidelityRow row;
  row.scene = c.spec;
  row.kind = kind;
  row.label = label;
  row.series = kind;
  row.encoding = row.parameters = row.directions = row.quantization = "-";
  row.psnrPhysical = row.psnrSameRule = row.psnrDense = std::nan("");
  return row;
}

// The default field and its renders, kept for the decomposition.
struct DefaultField {
  std::optional<Field> f16;
  std::optional<GpuRender> gpuF16, gpuU8;
  std::string error;
};

// The default field's path rule (the bake's choice: BakeSettings::choosePathRule): the
// decomposition and the side by side compare it with the exact render of that rule.
PathRule defaultRule(const Profile& p, const DefaultField& def) {
  if (def.f16) return def.f16->settings.pathRule;
  for (const Variant& v : p.variants)
    if (v.isDefault) return v.settings.pathRule;
  return PathRule::HighestEnergy;
}

// Both PSNRs of a row: against the physical reference and against the exact render it approximates.
Result<void> scoreRow(const SceneContext& c, const bake::Image& image, const bake::Image& sameRule, FidelityRow& row) {
  auto physical = psnrOf(c, image, c.physical.color);
  if (!physical) return physical.error();
  auto same = psnrOf(c, image, sameRule);
  if (!same) return same.error();
  auto dense = psnrOf(c, image, c.dense.color);
  if (!dense) return dense.error();
  row.psnrPhysical = physical.value();
  row.psnrSameRule = same.value();
  row.psnrDense = dense.value();
  return {};
}

// A variant's columns, shared by its f16 and u8 rows.
FidelityRow variantRow(const SceneContext& c, const Variant& v) {
  const BakeSettings& s = v.settings;
  FidelityRow proto = baseRow(c, "field", v.label);
  proto.encoding = toString(s.encoding);
  proto.parameters = parametersOf(s);
  proto.directions = s.directionSampling == DirectionSampling::Nodes
                         ? fmt("%ux%u nodes", s.tableSize, s.tableSize)
                         : fmt("%ux%u", s.directionsTheta, s.directionsPhi);
  proto.pathRule = s.pathRule;
  proto.throughput = s.throughput;
  proto.gpu = true;
  return proto;
}

// Both rows of a variant that could not be baked, each carrying `message`.
void addErrorRows(const SceneContext& c, const Variant& v, const FidelityRow& proto, const std::string& message,
                  FidelityScene& out, DefaultField* keep) {
  for (Quantization q : {Quantization::F16, Quantization::U8}) {
    FidelityRow row = proto;
    row.quantization = toString(q);
    row.series = v.series + " " + toString(q);
    row.error = message;
    out.rows.push_back(row);
  }
  if (keep) keep->error = message;
  std::fprintf(stderr, "report: fidelity: %s: %s %s: %s\n", c.spec.c_str(), v.series.c_str(), v.label.c_str(),
               message.c_str());
}

// Empty when the bake returned the field asked for (or, asked to try the volume, the volume it
// kept: BakeSettings::tryVolume); otherwise what it returned instead.
std::string bakeMismatch(const Field& f16, const BakeSettings& s) {
  const bool keptVolume = s.tryVolume && f16.encoding == Encoding::Volume;
  const bool ruleMatches = s.choosePathRule || f16.settings.pathRule == s.pathRule;
  if ((f16.encoding != s.encoding && !keptVolume) || !ruleMatches ||
      f16.throughput != s.throughput || f16.quantization != Quantization::F16)
    return fmt("the bake returned a %s field (%s, throughput %s, %s) for a %s request (%s, throughput %s)",
               toString(f16.encoding), ruleName(f16.settings.pathRule), f16.throughput ? "on" : "off",
               toString(f16.quantization), toString(s.encoding), ruleName(s.pathRule), s.throughput ? "on" : "off");
  return {};
}

// One quantization of a baked variant: a measured row, or an error row where the u8 bake, the
// upload or the GPU render failed.
Result<void> measureQuantization(SceneContext& c, const Variant& v, FidelityRow row, Quantization q,
                                 const BakedPair& baked, FidelityScene& out, DefaultField* keep) {
  const BakeSettings& s = v.settings;
  const Field& f16 = baked.f16;
  const Result<Field>& u8 = baked.u8;
  row.quantization = toString(q);
  row.series = v.series + " " + toString(q);
  row.bakeSeconds = f16.statistics.bakeSeconds;
  const bool isU8 = q == Quantization::U8;
  if (isU8 && !u8) {
    row.error = "u8 bake failed: " + u8.error().message;
    out.rows.push_back(row);
    return {};
  }
  const Field& field = isU8 ? u8.value() : f16;
  row.bytesPerSample = field.bytesPerSample();
  // A clustered field stores 2 bytes a sample and its K tables once (docs/encodings.md, "One index
  // per sample"): its row says so beside the K it was baked with.
  if (field.clustered) row.parameters += fmt(" clustered (%u tables)", field.components);
  // A default bake that kept the volume it tried: the row names what the field is.
  if (field.encoding != s.encoding) {
    row.encoding = toString(field.encoding);
    row.parameters = parametersOf(field.settings);
  }
  row.samples = f16.statistics.uniqueSamples;
  auto object = offscreen::uploadField(c.session, field);
  if (!object) {
    row.error = "upload failed: " + object.error().message;
    out.rows.push_back(row);
    return {};
  }
  std::vector<Object*> list{object.value().get()};
  // The default field's u8 render also with MSAA, for the anti-aliasing table.
  auto gpu = renderOnGpu(c.session, c.gpuEnvironment, list, c.camera, ShadingMode::Field, c.profile, c.width,
                         c.height, c.frames, keep && (isU8 || f16.encoding == Encoding::Volume));
  object.value().reset();
  c.session.context->releaseDeferred();
  if (!gpu) {
    row.error = "GPU render failed: " + gpu.error().message;
    out.rows.push_back(row);
    return {};
  }
  // The rule the field was baked under: the bake may have chosen it (BakeSettings::choosePathRule).
  row.pathRule = field.settings.pathRule;
  if (auto r = scoreRow(c, gpu.value().image, c.exact.at({row.pathRule, s.throughput}).color, row); !r) return r;
  row.decompressionMs = gpu.value().decompressionMs;
  row.rasterMs = gpu.value().rasterMs;
  std::fprintf(stderr,
               "report: fidelity: %s: %s %s %s: %u B/sample, bake %.1f s, PSNR %.2f dB (physical), %.2f dB (exact "
               "%s), GPU %.2f + %.2f ms\n",
               c.spec.c_str(), v.series.c_str(), v.label.c_str(), toString(q), row.bytesPerSample, row.bakeSeconds,
               row.psnrPhysical, row.psnrSameRule, ruleName(row.pathRule), row.decompressionMs, row.rasterMs);
  out.rows.push_back(row);
  if (keep) (isU8 ? keep->gpuU8 : keep->gpuF16) = std::move(gpu).value();
  return {};
}

// A volume stores its grid alike under both quantizations (bakePair), so its u8 row is its f16 row:
// drawn once, the image and timings shared. A lavapipe render of a volume at 4x4 took 4 minutes
// (the torus's default field), twice per variant before.
void sameVolumeAsU8(const Variant& v, FidelityScene& out, DefaultField* keep) {
  FidelityRow row = out.rows.back();
  row.quantization = toString(Quantization::U8);
  row.series = v.series + " " + row.quantization;
  out.rows.push_back(row);
  if (keep && keep->gpuF16) keep->gpuU8 = keep->gpuF16;
}

// Bakes one variant and measures its f16 and u8 rows. A failing bake, upload or
// GPU render makes error rows; only a failing comparison (a bug) is an error.
Result<void> measureVariant(SceneContext& c, const Variant& v, FidelityScene& out, DefaultField* keep) {
  const FidelityRow proto = variantRow(c, v);
  bake::BakeOptions bo;
  bo.settings = v.settings;
  bo.settings.source = c.spec;
  bo.settings.threads = c.options.threads;
  bo.heldOutDirections = 0;
  auto baked = bakePair(c.scene, bo);
  if (!baked) {
    addErrorRows(c, v, proto, "bake failed: " + baked.error().message, out, keep);
    return {};
  }
  // Against what the scene's default decided (bake::settingsForScene), where the row asks for it.
  if (const std::string mismatch = bakeMismatch(baked.value().f16, bake::settingsForScene(c.scene, v.settings));
      !mismatch.empty()) {
    addErrorRows(c, v, proto, mismatch, out, keep);
    return {};
  }
  if (auto r = measureQuantization(c, v, proto, Quantization::F16, baked.value(), out, keep); !r) return r;
  if (baked.value().f16.encoding == Encoding::Volume) {
    sameVolumeAsU8(v, out, keep);
  } else if (auto r = measureQuantization(c, v, proto, Quantization::U8, baked.value(), out, keep); !r) {
    return r;
  }
  if (keep) keep->f16 = std::move(baked.value().f16);
  return {};
}

// One step of the decomposition: its PSNR is between the two stages, its cumulative PSNR the
// coarser stage's against the physical reference.
Result<void> addStep(const SceneContext& c, FidelityScene& out, const std::string& name, const std::string& compares,
                     const bake::Image& coarser, const bake::Image& finer) {
  FidelityStep st;
  st.step = name;
  st.compares = compares;
  auto a = psnrOf(c, coarser, finer);
  if (!a) return a.error();
  auto b = psnrOf(c, coarser, c.physical.color);
  if (!b) return b.error();
  st.psnr = a.value();
  st.cumulative = b.value();
  out.decomposition.push_back(st);
  return {};
}

// Exact paths at the field's sample texels, drawn through its mesh by the CPU raster `ro`.
Result<bake::ReferenceImage> renderExactTexels(const SceneContext& c, const Field& field, glm::vec3 eye,
                                               const bake::DistortionRenderOptions& ro, FidelityScene& out) {
  bake::ExactDistortionOptions eo;
  eo.pathRule = field.settings.pathRule;
  eo.maxBounces = field.settings.maxBounces;
  eo.throughput = field.throughput;
  eo.threads = c.options.threads;
  auto texels = bake::exactDistortion(c.tracer, field, eye, eo);
  if (!texels) return texels.error();
  out.sampleTexels = texels.value().samples;
  out.unmatchedTexels = texels.value().unmatched;
  auto texelRender = bake::renderDistortion(field.mesh, texels.value().image, c.environment, ro);
  if (!texelRender) return texelRender.error();
  std::fprintf(stderr, "report: fidelity: %s: exact paths at %" PRIu64 " sample texels (%" PRIu64
               " unmatched): %.2f s trace, %.2f s CPU raster\n",
               c.spec.c_str(), texels.value().samples, texels.value().unmatched, texels.value().seconds,
               texelRender.value().seconds);
  return texelRender;
}

// The decomposition's last steps, on the GPU's renders: quantization, then the 1-spp image against
// the 4x4 one (and, cumulative, against the 4x4 physical reference).
Result<void> addGpuSteps(const SceneContext& c, const DefaultField& def, FidelityScene& out) {
  if (auto r = addStep(c, out, "quantization", "u8 field vs f16 field (GPU)", def.gpuU8->image, def.gpuF16->image); !r)
    return r;
  const uint32_t spp = c.profile.samplesPerAxis;
  return addStep(c, out, "pixel sampling", fmt("u8 field at 1 spp vs at %ux%u (GPU)", spp, spp),
                 def.gpuU8->image1spp, def.gpuU8->image);
}

// The error decomposition of the default field: each step adds one approximation to the one
// before (see addStep).
Result<void> decompose(SceneContext& c, const DefaultField& def, FidelityScene& out,
                       std::optional<bake::Image>& texelsImage) {
  const PathRule rule = defaultRule(c.profile, def);
  const bake::ReferenceImage& exactRule = c.exact.at({rule, false});
  if (auto r = addStep(c, out, "path rule", std::string("exact ") + ruleName(rule) + " path vs physical",
                       exactRule.color, c.physical.color);
      !r)
    return r;
  if (!def.f16 || !def.gpuF16 || !def.gpuU8) {
    for (const char* name : {"spatial sampling", "angular encoding", "quantization", "pixel sampling"})
      out.decomposition.push_back({name, "-", 0.0, 0.0, "default field unavailable: " + def.error});
    return {};
  }
  const Field& field = *def.f16;
  const glm::vec3 eye(c.camera.eye[0], c.camera.eye[1], c.camera.eye[2]);
  bake::DistortionRenderOptions ro;
  ro.width = c.width;
  ro.height = c.height;
  ro.camera = c.camera;
  ro.samplesPerAxis = c.profile.samplesPerAxis;
  ro.threads = c.options.threads;
  ro.shading.tint = frontMediumColor(field);  // as Object::createFromField sets it
  auto texelRender = renderExactTexels(c, field, eye, ro, out);
  if (!texelRender) return texelRender.error();
  texelsImage = texelRender.value().color;
  if (auto r = addStep(c, out, "spatial sampling", "exact paths at the sample texels (CPU raster) vs exact per pixel",
                       texelRender.value().color, exactRule.color);
      !r)
    return r;
  // The f16 field through the same CPU raster isolates the encoding from the GPU's arithmetic.
  const reference::DistortionImage decoded = reference::decompress(field, {eye.x, eye.y, eye.z});
  auto twin = bake::renderDistortion(field.mesh, decoded, c.environment, ro);
  if (!twin) return twin.error();
  if (auto r = addStep(c, out, "angular encoding", "f16 field (CPU raster) vs exact paths at the sample texels",
                       twin.value().color, texelRender.value().color);
      !r)
    return r;
  if (auto r = addStep(c, out, "GPU arithmetic", "f16 field on the GPU vs the same on the CPU raster",
                       def.gpuF16->image, twin.value().color);
      !r)
    return r;
  return addGpuSteps(c, def, out);
}

// Every mode at one sample per pixel with filtered lookups against itself supersampled, both
// against the physical reference and against the full tree at twice the samples per axis: the
// default field (the GPU's 1-spp render kept by measureVariant, and the same with 4x MSAA: one
// shading sample, silhouettes covered at 4), the exact highest-energy path and the full tree
// (CPU, ReferenceOptions::filtered).
Result<void> measureAntialiasing(SceneContext& c, const DefaultField& def, FidelityScene& out) {
  bake::ReferenceOptions ro;
  ro.mode = bake::ReferenceMode::FullTree;
  ro.treeDepth = c.profile.treeDepth;
  auto entry = [&](const std::string& mode, const bake::Image& one, const bake::Image& supersampled) -> Result<void> {
    FidelityAntialiasing a{mode};
    for (auto [image, reference, psnr] : {std::tuple{&one, &c.physical.color, &a.psnrOneSample},
                                          std::tuple{&supersampled, &c.physical.color, &a.psnrSupersampled},
                                          std::tuple{&one, &c.dense.color, &a.denseOneSample},
                                          std::tuple{&supersampled, &c.dense.color, &a.denseSupersampled}}) {
      auto r = psnrOf(c, *image, *reference);
      if (!r) return r.error();
      *psnr = r.value();
    }
    // The full tree's S x S render is the physical reference: no figure against itself.
    if (&supersampled == &c.physical.color) a.psnrSupersampled = std::numeric_limits<double>::infinity();
    out.antialiasing.push_back(a);
    return {};
  };
  if (def.gpuU8)
    if (auto r = entry("default field u8 (GPU)", def.gpuU8->image1spp, def.gpuU8->image); !r) return r;
  if (def.gpuU8 && def.gpuU8->image1sppMsaa)
    if (auto r = entry("default field u8 (GPU), host's 4x MSAA", *def.gpuU8->image1sppMsaa, def.gpuU8->image); !r)
      return r;
  ro.filtered = true;
  ro.mode = bake::ReferenceMode::Exact;
  auto exact = cpuRender(c, ro, "exact highest-energy, filtered", 1);
  if (!exact) return exact.error();
  if (auto r = entry("exact highest-energy (CPU)", exact.value().color, c.exact.at({PathRule::HighestEnergy, false}).color); !r)
    return r;
  ro.mode = bake::ReferenceMode::FullTree;
  auto tree = cpuRender(c, ro, "full tree, filtered", 1);
  if (!tree) return tree.error();
  return entry(fmt("full tree depth %u (CPU)", c.profile.treeDepth), tree.value().color, c.physical.color);
}

// A CPU render's time per 1-spp frame: the supersampled render's divided by the samples per pixel.
double cpuMsPerFrame(const SceneContext& c, double seconds) {
  return seconds * 1000.0 / double(c.profile.samplesPerAxis * c.profile.samplesPerAxis);
}

// The denser reference's samples per axis: 2S - 1. For an even S its cell centres (odd multiples of
// 1 / (2 (2S - 1))) meet neither the S x S renders' (odd multiples of 1 / 2S) nor those of a volume
// field's 2x2 paths at S x S (odd multiples of 1 / 4S); 2S, the report's before, met the latter
// (docs/encodings.md, "The lines against a reference that shares no sub-samples").
uint32_t denseSamplesPerAxis(uint32_t s) { return std::min(2 * s - 1, bake::kMaxSamplesPerAxis); }

// The physical reference and the same tree at denseSamplesPerAxis, kept in `c` for everything
// after them, and the reference's row. The denser one shares no sample positions with the S x S
// renders: an exact render shares the reference's, so against the reference it gains what both
// alias alike (the bunny's exact first-refraction render 27.48 dB against its 4x4 reference, 24.18
// against the 7x7, where the 4x4 reference itself reads 25.07).
Result<void> measurePhysical(SceneContext& c, FidelityScene& out) {
  bake::ReferenceOptions ro;
  ro.mode = bake::ReferenceMode::FullTree;
  ro.treeDepth = c.profile.treeDepth;
  auto physical = cpuRender(c, ro, fmt("physical reference (full tree, depth %u)", c.profile.treeDepth));
  if (!physical) return physical.error();
  c.physical = std::move(physical).value();
  const uint32_t dense = denseSamplesPerAxis(c.profile.samplesPerAxis);
  auto denser = cpuRender(c, ro, "denser physical reference", dense);
  if (!denser) return denser.error();
  c.dense = std::move(denser).value();
  out.denseSamplesPerAxis = dense;
  out.pixels = static_cast<uint64_t>(std::count(c.physical.mask.begin(), c.physical.mask.end(), uint8_t(1)));
  FidelityRow row = baseRow(c, "physical", fmt("full tree depth %u (CPU)", c.profile.treeDepth));
  row.psnrPhysical = 100.0;
  auto self = psnrOf(c, c.physical.color, c.dense.color);
  if (!self) return self.error();
  row.psnrDense = self.value();
  row.cpuMs = cpuMsPerFrame(c, c.physical.seconds);
  out.rows.push_back(row);
  return {};
}

// The exact single-path renders under both path rules, without and with throughput (kept in `c`),
// and their rows.
Result<void> measureExact(SceneContext& c, FidelityScene& out) {
  for (PathRule rule : {PathRule::HighestEnergy, PathRule::FirstRefraction})
    for (bool throughput : {false, true}) {
      bake::ReferenceOptions ro;
      ro.mode = bake::ReferenceMode::Exact;
      ro.pathRule = rule;
      ro.throughput = throughput;
      const std::string label = std::string("exact ") + ruleName(rule) + (throughput ? " + throughput" : "");
      auto exact = cpuRender(c, ro, label);
      if (!exact) return exact.error();
      c.exact[{rule, throughput}] = std::move(exact).value();
    }
  for (const auto& [key, image] : c.exact) {
    FidelityRow row = baseRow(c, "exact", std::string("exact ") + ruleName(key.first) +
                                              (key.second ? " + throughput" : "") + " (CPU)");
    row.series = "exact (CPU)";
    row.pathRule = key.first;
    row.throughput = key.second;
    if (auto r = scoreRow(c, image.color, c.exact.at({key.first, false}).color, row); !r) return r;
    row.cpuMs = cpuMsPerFrame(c, image.seconds);
    out.rows.push_back(row);
  }
  return {};
}

Result<void> measureSingleInterface(SceneContext& c, FidelityScene& out) {
  auto objects = offscreen::uploadScene(c.session, c.scene);
  if (!objects) return objects.error();
  std::vector<Object*> list;
  for (auto& o : objects.value()) list.push_back(o.get());
  auto gpu = renderOnGpu(c.session, c.gpuEnvironment, list, c.camera, ShadingMode::SingleInterface, c.profile,
                         c.width, c.height, c.frames);
  if (!gpu) return gpu.error();
  objects.value().clear();
  c.session.context->releaseDeferred();
  FidelityRow row = baseRow(c, "single interface", "single interface (GPU)");
  row.gpu = true;
  if (auto r = scoreRow(c, gpu.value().image, c.exact.at({PathRule::HighestEnergy, false}).color, row); !r) return r;
  row.rasterMs = gpu.value().rasterMs;
  out.rows.push_back(row);
  return {};
}

// A split layout needs at least one sample per welded vertex: where the sweep's budget is
// below that, the sweep takes the smallest of 2x, 4x its budget or the default that fits.
void fitSplitBudget(const SceneContext& c, Variant& v) {
  if (v.isDefault || v.settings.layout != SampleLayout::Split || v.settings.sampleBudget == 0) return;
  const uint64_t asked = v.settings.sampleBudget;
  for (uint64_t budget : {asked, 2 * asked, 4 * asked, uint64_t(0)}) {
    bake::LayoutOptions lo;
    lo.sampleBudget = budget;
    v.settings.sampleBudget = budget;
    if (bake::buildSplitLayout(c.scene, lo).ok()) break;
  }
}

// Side by side: physical | exact (the default's rule) | exact at the texels | u8 field | heat map.
Result<void> writeCompare(SceneContext& c, const DefaultField& def, const std::optional<bake::Image>& texels) {
  const bake::Image& physical = c.physical.color;
  const bake::Image& exact = c.exact.at({defaultRule(c.profile, def), false}).color;
  std::vector<const bake::Image*> images{&physical, &exact};
  if (texels) images.push_back(&*texels);
  bake::Image heat;
  if (def.gpuU8) {
    images.push_back(&def.gpuU8->image);
    heat = bake::errorHeatMap(def.gpuU8->image, physical, 0.5f);
    images.push_back(&heat);
  }
  return writeOut(c, "fidelity_" + c.name + "_compare.png", sideBySide(images));
}

// Paired hues (f16 darker, u8 lighter, in the order the rows come), then greys.
// (22: one for each of the 20 field series of a fidelity report; the exact and single-interface
// rows after them may repeat a colour.)
constexpr std::array<std::array<float, 3>, 22> kSeriesColors = {{
    {0.00f, 0.00f, 0.00f}, {0.45f, 0.45f, 0.45f}, {0.60f, 0.35f, 0.10f}, {0.05f, 0.25f, 0.75f},
    {0.35f, 0.60f, 1.00f}, {0.05f, 0.50f, 0.15f}, {0.40f, 0.80f, 0.35f}, {0.75f, 0.05f, 0.10f},
    {1.00f, 0.45f, 0.45f}, {0.45f, 0.10f, 0.60f}, {0.75f, 0.50f, 0.90f}, {0.85f, 0.45f, 0.00f},
    {1.00f, 0.75f, 0.20f}, {0.00f, 0.50f, 0.50f}, {0.30f, 0.80f, 0.80f}, {0.70f, 0.00f, 0.50f},
    {1.00f, 0.40f, 0.80f}, {0.40f, 0.30f, 0.00f}, {0.75f, 0.65f, 0.30f}, {0.10f, 0.10f, 0.35f},
    {0.50f, 0.50f, 0.85f}, {0.25f, 0.25f, 0.25f}}};

// Colours are fixed per series across both plots (`series`: every series, in the order the rows
// come); each plot lists only the series it shows.
template <class XOf>
bake::Image fidelityPlot(const FidelityScene& out, const std::vector<std::string>& series, const std::string& title,
                         const std::string& xLabel, bool fieldsOnly, XOf xOf) {
  Plot plot;
  plot.title = title;
  plot.xLabel = xLabel;
  plot.yLabel = "PSNR vs physical (dB)";
  plot.logX = true;
  plot.yFromZero = false;
  plot.legendOutside = true;
  std::vector<std::string> shown;
  for (const FidelityRow& r : out.rows) {
    if (!r.error.empty() || r.kind == "physical" || (fieldsOnly && r.kind != "field")) continue;
    auto it = std::find(shown.begin(), shown.end(), r.series);
    if (it == shown.end()) {
      const size_t k = size_t(std::find(series.begin(), series.end(), r.series) - series.begin());
      plot.series.push_back({r.series, kSeriesColors[k % kSeriesColors.size()], r.kind == "field"});
      shown.push_back(r.series);
      it = shown.end() - 1;
    }
    const std::string label = r.kind == "field" ? r.label.substr(0, r.label.find(' '))
                              : r.kind == "exact" ? (r.pathRule == PathRule::HighestEnergy ? "HE" : "FR") +
                                                        std::string(r.throughput ? "+T" : "")
                                                  : "";
    plot.points.push_back({xOf(r), r.psnrPhysical, label, static_cast<int>(it - shown.begin())});
  }
  return renderPlot(plot, 900, 480);
}

// Plots: PSNR against bytes per sample and against frame time, one series per encoding.
Result<void> writeFidelityPlots(SceneContext& c, const FidelityScene& out) {
  std::vector<std::string> series;
  for (const FidelityRow& r : out.rows)
    if (std::find(series.begin(), series.end(), r.series) == series.end()) series.push_back(r.series);
  const std::string title = sceneTitle(c.spec);
  const bake::Image bytes = fidelityPlot(out, series, title + ": error vs bytes per sample", "bytes per sample (log)",
                                         true, [](const FidelityRow& r) { return double(r.bytesPerSample); });
  const bake::Image time = fidelityPlot(out, series, title + ": error vs frame time",
                                        "GPU decompress + raster ms, CPU ms (log)", false, [](const FidelityRow& r) {
                                          return r.gpu ? r.decompressionMs + r.rasterMs : r.cpuMs;
                                        });
  if (auto w = writeOut(c, "fidelity_" + c.name + "_psnr_vs_bytes.png", bytes); !w) return w.error();
  if (auto w = writeOut(c, "fidelity_" + c.name + "_psnr_vs_frame_time.png", time); !w) return w.error();
  return {};
}

// Variant::followsDefault: the default bake under the other path rule than the one it chose
// (BakeSettings::choosePathRule); where it kept a volume, that volume (its grid and samples).
void followDefault(const DefaultField& def, Variant& v) {
  if (!def.error.empty() || !def.f16) return;
  const PathRule rule = def.f16->settings.pathRule == PathRule::FirstRefraction ? PathRule::HighestEnergy
                                                                                 : PathRule::FirstRefraction;
  v.series = std::string("default, ") + ruleName(rule);
  if (def.f16->encoding == Encoding::Volume) {
    v.settings = bakeSettingsOf(def.f16->settings);
    v.settings.tryVolume = false;
    v.label = fmt("volume %u^3", v.settings.volumeSize);
  }
  v.settings.pathRule = rule;
  v.settings.choosePathRule = false;
}

Result<FidelityScene> measureScene(SceneContext& c) {
  const auto start = Clock::now();
  FidelityScene out;
  out.scene = c.spec;
  out.samplesPerAxis = c.profile.samplesPerAxis;
  if (auto r = measurePhysical(c, out); !r) return r.error();
  if (auto r = measureExact(c, out); !r) return r.error();
  if (auto r = measureSingleInterface(c, out); !r) return r.error();
  DefaultField def;
  for (Variant v : c.profile.variants) {
    if (v.followsDefault) followDefault(def, v);
    fitSplitBudget(c, v);
    if (auto r = measureVariant(c, v, out, v.isDefault ? &def : nullptr); !r) return r.error();
  }
  std::optional<bake::Image> texels;
  if (auto r = decompose(c, def, out, texels); !r) return r.error();
  if (c.profile.antialiasing)
    if (auto r = measureAntialiasing(c, def, out); !r) return r.error();
  if (auto r = writeCompare(c, def, texels); !r) return r.error();
  if (auto r = writeFidelityPlots(c, out); !r) return r.error();
  out.seconds = since(start);
  return out;
}

std::string number(double v) { return std::isfinite(v) ? fmt("%.2f", v) : "-"; }

std::string introMarkdown(const Profile& p, uint32_t width, uint32_t height, double seconds) {
  const uint32_t s = p.samplesPerAxis, d = denseSamplesPerAxis(s);
  std::string md = "## Fidelity against the physical reference\n\n";
  md += fmt("Physical reference: the full Fresnel tree (every branch at every interface) to depth %u, traced on the "
            "CPU. Every image is %ux%u with %ux%u stratified samples per pixel (sub-pixel cell centres, box filter); "
            "the GPU renders at %ux%u and averages %ux%u blocks. PSNR is over the object's pixels (more than half of "
            "the pixel's samples hit the object in the physical reference), colours clamped to [0, 1]. Built-in "
            "environment (%u px wide), the tool's default view. %.1f s in all.\n\n",
            p.treeDepth, width, height, s, s, width * s, height * s, s, s, p.environmentWidth, seconds);
  md += fmt("Columns: *vs physical* is the PSNR against the physical reference; *vs physical %ux%u* against the same "
            "tree at %ux%u samples, which shares no sample positions with the %ux%u renders (an exact render shares "
            "the reference's, and gains against it what both alias alike; the reference's own row says how far it "
            "is from the denser one); ",
            d, d, d, d, s, s);
  md += "*vs exact* against the exact single-path "
        "render this row approximates (same path rule and throughput; for the exact rows, the same rule without "
        "throughput; single interface: exact highest-energy). Each field setting is traced once and finished in "
        "f16 and in u8, as `bake --shard` and `merge` would (a u8 Pca field has refinement layers); a volume "
        "stores the same grid in both, so its two rows are one render, and where the default bake keeps a volume its "
        "u8 finish chooses it, as the tool's u8 default would. Bytes per sample "
        "count the coefficients only. GPU times are timestamps of one frame at 1 spp; CPU times are per 1-spp "
        "frame (the supersampled render's time divided by the samples per pixel).\n\n";
  return md;
}

// A scene's table: one line per row, error rows with their message.
std::string rowsMarkdown(const FidelityScene& sc) {
  const uint32_t d = sc.denseSamplesPerAxis;
  std::string md = fmt("%" PRIu64 " object pixels, %.1f s.\n\n", sc.pixels, sc.seconds);
  md += fmt("| row | encoding | parameters | directions | samples | quant | path rule | throughput | bytes/sample | "
            "PSNR vs physical dB | PSNR vs physical %ux%u dB | PSNR vs exact dB | bake s | GPU decompress + raster ms | "
            "CPU ms |\n",
            d, d);
  md += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const FidelityRow& r : sc.rows) {
    const bool field = r.kind == "field";
    const std::string rule = r.kind == "physical" || r.kind == "single interface" ? "-" : ruleName(r.pathRule);
    const std::string throughput = rule == "-" ? "-" : (r.throughput ? "yes" : "no");
    if (!r.error.empty()) {
      md += fmt("| %s %s | %s | %s | %s | - | %s | %s | %s | - | error: %s | | | | | |\n", r.series.c_str(),
                r.label.c_str(), r.encoding.c_str(), r.parameters.c_str(), r.directions.c_str(),
                r.quantization.c_str(), rule.c_str(), throughput.c_str(), r.error.c_str());
      continue;
    }
    const std::string gpuMs = r.gpu ? (field ? fmt("%.2f + %.2f", r.decompressionMs, r.rasterMs)
                                             : fmt("%.2f", r.rasterMs))
                                    : "-";
    md += fmt("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n",
              field ? (r.series + " " + r.label).c_str() : r.label.c_str(), r.encoding.c_str(),
              r.parameters.c_str(), r.directions.c_str(), field ? fmt("%" PRIu64, r.samples).c_str() : "-",
              r.quantization.c_str(), rule.c_str(), throughput.c_str(),
              field ? fmt("%u", r.bytesPerSample).c_str() : "-", number(r.psnrPhysical).c_str(),
              number(r.psnrDense).c_str(), number(r.psnrSameRule).c_str(), field ? fmt("%.1f", r.bakeSeconds).c_str() : "-", gpuMs.c_str(),
              r.gpu ? "-" : number(r.cpuMs).c_str());
  }
  return md;
}

// The three fidelity lines for the default u8 field, against both references: within 3 dB of the
// exact render of its path rule, no lower than the highest-energy exact render (the paper's rule)
// less 3 dB, so that a weaker rule cannot pass, and at least 10 dB above the single interface.
// "" without those rows.
std::string targetsMarkdown(const FidelityScene& sc) {
  const FidelityRow *def = nullptr, *exact = nullptr, *paper = nullptr, *single = nullptr, *physical = nullptr;
  for (const FidelityRow& r : sc.rows)
    if (r.kind == "field" && r.series == "default u8" && r.error.empty()) def = &r;
  if (!def) return "";
  for (const FidelityRow& r : sc.rows) {
    if (r.kind == "exact" && r.pathRule == def->pathRule && r.throughput == def->throughput) exact = &r;
    if (r.kind == "exact" && r.pathRule == PathRule::HighestEnergy && !r.throughput) paper = &r;
    if (r.kind == "single interface") single = &r;
    if (r.kind == "physical") physical = &r;
  }
  if (!exact || !paper || !single || !physical) return "";
  const auto line = [&](const char* against, double field, double ex, double pa, double si) {
    return fmt("against %s: the field %.2f dB, the exact render of its rule %.2f (%.2f apart: %s 3), the "
               "highest-energy exact render %.2f (floor %.2f: %s), the single interface %.2f (%.2f above it: %s 10)",
               against, field, ex, ex - field, ex - field <= 3.0 ? "within" : "beyond", pa, pa - 3.0,
               field >= pa - 3.0 ? "above" : "under", si, field - si, field - si >= 10.0 ? "at least" : "under");
  };
  const uint32_t s = sc.samplesPerAxis, d = sc.denseSamplesPerAxis;
  return "\nThe default u8 field, " +
         line(fmt("the %ux%u reference", s, s).c_str(), def->psnrPhysical, exact->psnrPhysical, paper->psnrPhysical,
              single->psnrPhysical) +
         "; " + line(fmt("the %ux%u one", d, d).c_str(), def->psnrDense, exact->psnrDense, paper->psnrDense,
                     single->psnrDense) +
         fmt(". The %ux%u reference itself reads %.2f dB against the %ux%u.\n", s, s, physical->psnrDense, d, d);
}

std::string decompositionMarkdown(const Profile& p, const FidelityScene& sc) {
  (void)p;
  // The default row says what the scene's bake made of the default settings.
  const FidelityRow* def = nullptr;
  for (const FidelityRow& r : sc.rows)
    if (r.kind == "field" && r.series == "default u8" && r.error.empty()) def = &r;
  std::string md;
  md += fmt("\nError decomposition of the default field (%s): each step adds one approximation to the stage "
            "above it; *step* is the PSNR between the two stages, *cumulative* the new stage against the physical "
            "reference.\n\n",
            def ? fmt("%s %s, %s samples, %s path rule", def->encoding.c_str(), def->parameters.c_str(),
                      std::to_string(def->samples).c_str(), ruleName(def->pathRule)).c_str()
                : "not baked");
  md += "| step | compares | step PSNR dB | cumulative PSNR dB |\n|---|---|---|---|\n";
  for (const FidelityStep& st : sc.decomposition) {
    if (!st.error.empty())
      md += "| " + st.step + " | " + st.compares + " | error: " + st.error + " | |\n";
    else
      md += fmt("| %s | %s | %.2f | %.2f |\n", st.step.c_str(), st.compares.c_str(), st.psnr, st.cumulative);
  }
  if (sc.sampleTexels)
    md += fmt("\nExact paths at the sample texels: %" PRIu64 " sample texels, %" PRIu64
              " whose surface point the tracer did not find where the frame puts it.\n",
              sc.sampleTexels, sc.unmatchedTexels);
  return md;
}

std::string antialiasingMarkdown(const Profile& p, const FidelityScene& sc) {
  if (!p.antialiasing) return {};
  const uint32_t s = p.samplesPerAxis;
  const uint32_t dense = sc.denseSamplesPerAxis;
  const bake::ReferenceOptions cpu;  // the CPU modes' filtering, as measured
  std::string md;
  md += fmt("\nAnti-aliasing: each mode at 1 sample per pixel with filtered lookups (the CPU modes with "
            "ReferenceOptions::filtered: 4 probes, %ux%u taps at level bias %g; the full tree%s; the field also with the host's 4x MSAA: "
            "one shading sample per pixel, silhouettes covered at 4) and at %ux%u, against the physical "
            "reference (target: within 2 dB; the full tree at %ux%u is that reference itself) and against the full "
            "tree at %ux%u, which shares no sample positions with the %ux%u renders.\n\n",
            cpu.environmentTapsPerAxis, cpu.environmentTapsPerAxis, static_cast<double>(cpu.environmentLevelBias),
            cpu.refine ? " refined to four quarters where its probes see the colour change (ReferenceOptions::refine)"
                       : " not refined",
            s, s, s, s, dense, dense, s, s);
  md += fmt("| mode | 1 spp filtered dB | %ux%u dB | apart dB | vs %ux%u: 1 spp filtered dB | %ux%u dB | apart dB "
            "|\n|---|---|---|---|---|---|---|\n",
            s, s, dense, dense, s, s);
  for (const FidelityAntialiasing& a : sc.antialiasing)
    md += fmt("| %s | %.2f | %s | %s | %.2f | %.2f | %.2f |\n", a.mode.c_str(), a.psnrOneSample,
              number(a.psnrSupersampled).c_str(), number(a.psnrSupersampled - a.psnrOneSample).c_str(),
              a.denseOneSample, a.denseSupersampled, a.denseSupersampled - a.denseOneSample);
  return md;
}

std::string markdownOf(const Profile& p, const std::vector<FidelityScene>& scenes, uint32_t width, uint32_t height,
                       double seconds) {
  std::string md = introMarkdown(p, width, height, seconds);
  for (const FidelityScene& sc : scenes) {
    md += "### " + sc.scene + "\n\n";
    if (!sc.skipped.empty()) {
      md += "Skipped: " + sc.skipped + "\n\n";
      continue;
    }
    md += rowsMarkdown(sc);
    md += targetsMarkdown(sc);
    md += decompositionMarkdown(p, sc);
    if (!sc.antialiasing.empty()) md += antialiasingMarkdown(p, sc);
    const std::string name = "fidelity_" + sanitize(sceneTitle(sc.scene));
    md += "\n![error vs bytes per sample](" + name + "_psnr_vs_bytes.png)\n";
    md += "![error vs frame time](" + name + "_psnr_vs_frame_time.png)\n\n";
    md += "Side by side (physical | exact render of the default field's path rule | exact paths at the sample "
          "texels | default u8 field on the GPU | heat map of the field against the physical reference, |diff| "
          "summed over RGB, white = 0.5):\n\n";
    md += "![" + name + "_compare.png](" + name + "_compare.png)\n\n";
  }
  return md;
}

}  // namespace

Result<FidelityResult> runFidelity(const FidelityOptions& options, offscreen::Session& session,
                                   std::vector<std::string>& files) {
  const auto start = Clock::now();
  const Profile profile = profileFor(options.size, options.samples);
  const uint32_t width = options.width ? options.width : profile.width;
  const uint32_t height = options.height ? options.height : profile.height;
  const std::vector<std::string> specs = options.scenes.empty() ? profile.scenes : options.scenes;

  // Load every scene first: input errors before minutes of work. A default scene whose asset is
  // missing is skipped.
  std::vector<std::optional<bake::Scene>> scenes;
  FidelityResult result;
  for (const std::string& spec : specs) {
    FidelityScene placeholder;
    placeholder.scene = spec;
    if (options.scenes.empty() && spec == kBunny && !std::filesystem::exists(spec)) {
      placeholder.skipped = spec + " not found from the working directory (run from the repository root with "
                                   "../shared/assets present)";
      std::fprintf(stderr, "report: fidelity: %s\n", placeholder.skipped.c_str());
      scenes.emplace_back();
    } else {
      auto scene = cli::loadScene(spec, {}, nullptr);
      if (!scene) return scene.error();
      scenes.emplace_back(std::move(scene).value());
    }
    result.scenes.push_back(placeholder);
  }

  const bake::Image environment = bake::proceduralEnvironment(profile.environmentWidth);
  auto gpuEnvironment = offscreen::uploadEnvironment(session, environment);
  if (!gpuEnvironment) return gpuEnvironment.error();
  for (size_t i = 0; i < specs.size(); ++i) {
    if (!scenes[i]) continue;
    auto tracer = bake::Tracer::create(*scenes[i]);
    if (!tracer) return makeError(tracer.error().code, specs[i] + ": " + tracer.error().message);
    SceneContext c{profile, options, session, *gpuEnvironment.value(), environment, files, specs[i], *scenes[i],
                   *tracer.value()};
    c.name = sanitize(sceneTitle(specs[i]));
    c.width = width;
    c.height = height;
    c.frames = options.frames ? options.frames : profile.frames;
    c.camera = offscreen::defaultCamera(*scenes[i]);
    auto measured = measureScene(c);
    if (!measured) return measured.error();
    result.scenes[i] = std::move(measured).value();
    std::fprintf(stderr, "report: fidelity: %s done in %.1f s\n", specs[i].c_str(), result.scenes[i].seconds);
  }
  result.markdown = markdownOf(profile, result.scenes, width, height, since(start));
  return result;
}

}  // namespace shrefract::report
