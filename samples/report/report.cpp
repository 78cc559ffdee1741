#include "report/report.h"

#include <shrefract/bake/bake.h>
#include <shrefract/trace/image_metrics.h>
#include <shrefract/trace/reference_render.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>

#include "cli/scene_source.h"
#include "offscreen/offscreen.h"
#include "report/fidelity.h"
#include "report/flicker.h"
#include "report/plot.h"
#include "report/report_text.h"

namespace shrefract::report {
namespace {


struct SweepEntry {
  std::string group;
  std::string label;
  BakeSettings settings;
};

struct SizeProfile {
  BakeSettings base;
  std::vector<uint32_t> orders;
  std::vector<std::pair<uint32_t, uint32_t>> directions;
  uint32_t width, height, frames;
  std::vector<std::string> scenes;
  uint32_t environmentWidth;
};

SizeProfile profileFor(ReportSize size) {
  SizeProfile p;
  p.base.order = 8;
  p.base.layout = SampleLayout::Split;
  p.base.quantization = Quantization::U8;
  switch (size) {
    case ReportSize::Smoke:
      p.base.directionsTheta = 8;
      p.base.directionsPhi = 16;
      p.base.sampleBudget = 300;
      p.base.order = 4;
      p.orders = {1, 2, 4};
      p.directions = {{4, 8}, {8, 16}};
      p.width = 64;
      p.height = 48;
      p.frames = 2;
      p.scenes = {"builtin:sphere?tessellation=1"};
      p.environmentWidth = 128;
      break;
    case ReportSize::Default:  // the fidelity section alone (report_command.cpp): no sweeps
      p.width = 240;
      p.height = 180;
      p.frames = 3;
      p.environmentWidth = 1024;
      break;
    case ReportSize::Full:
      p.base.directionsTheta = 16;
      p.base.directionsPhi = 32;
      p.base.sampleBudget = 3000;
      p.orders = {1, 2, 4, 8, 12, 16};
      p.directions = {{8, 16}, {16, 32}, {32, 64}};
      p.width = 320;
      p.height = 240;
      p.frames = 5;
      p.scenes = {"builtin:sphere?tessellation=3", "builtin:glass-of-water?tessellation=2"};
      p.environmentWidth = 512;
      break;
  }
  return p;
}

std::string directionsText(const BakeSettings& s) { return fmt("%ux%u", s.directionsTheta, s.directionsPhi); }
std::string smoothingText(const BakeSettings& s) {
  std::string out = s.window == SmoothingWindow::None ? "" : toString(s.window);
  if (s.spatialNeighbours) out += (out.empty() ? "" : "+") + fmt("spatial%u", s.spatialNeighbours);
  return out.empty() ? "none" : out;
}
std::string key(const BakeSettings& s) {
  return fmt("%u|%s|%s|%s|%s", s.order, directionsText(s).c_str(), toString(s.quantization), toString(s.layout),
             smoothingText(s).c_str());
}

std::vector<SweepEntry> sweep(const SizeProfile& p) {
  std::vector<SweepEntry> out;
  for (uint32_t order : p.orders) {
    BakeSettings s = p.base;
    s.order = order;
    out.push_back({"order", fmt("L%u", order), s});
  }
  for (auto [r, c] : p.directions) {
    BakeSettings s = p.base;
    s.directionsTheta = r;
    s.directionsPhi = c;
    out.push_back({"directions", fmt("%ux%u", r, c), s});
  }
  {
    BakeSettings s = p.base;
    out.push_back({"quantization", "u8", s});
    s.quantization = Quantization::F16;
    out.push_back({"quantization", "f16", s});
  }
  {
    BakeSettings s = p.base;
    out.push_back({"layout", "split", s});
    s.layout = SampleLayout::Charts;
    out.push_back({"layout", "charts", s});
  }
  {
    BakeSettings s = p.base;
    out.push_back({"smoothing", "none", s});
    s.window = SmoothingWindow::Hann;
    out.push_back({"smoothing", "hann", s});
    s.window = SmoothingWindow::Lanczos;
    out.push_back({"smoothing", "lanczos", s});
    s.window = SmoothingWindow::None;
    s.spatialNeighbours = 3;
    out.push_back({"smoothing", "spatial3", s});
    s.spatialNeighbours = 5;
    out.push_back({"smoothing", "spatial5", s});
  }
  return out;
}

void setErrors(ReportRow& row, const bake::ImageErrors& e) {
  row.psnr = e.psnr;
  row.ssim = e.ssim;
  row.meanAngle = e.meanAngleDegrees;
  row.p95Angle = e.p95AngleDegrees;
  row.maxAngle = e.maxAngleDegrees;
  row.pixels = e.pixels;
}

Result<void> writeOut(const std::string& dir, const std::string& name, const bake::Image& image,
                      std::vector<std::string>& files) {
  if (auto r = bake::writeImage(dir + "/" + name, image); !r) return r;
  files.push_back(name);
  return {};
}


// Stiff and extreme cases: each is baked small, rendered on the GPU and checked against the exact
// reference; everything must stay finite (docs/stability.md has the per-case tests).
struct StabilityCase {
  std::string name;
  std::string scene;
  uint32_t order;
  std::array<float, 3> eyeDirection;  // from the scene's centre; {0,0,0}: the default camera
};

std::vector<StabilityCase> stabilityCases(ReportSize size) {
  // fmt() rather than operator+ on literals: GCC 12 -O3 reports a false -Wrestrict there.
  const int t = size == ReportSize::Smoke ? 1 : 2;
  return {
      {"IOR 1.0001 (almost air)", fmt("builtin:sphere?tessellation=%d&ior=1.0001", t), 4, {0, 0, 0}},
      {"IOR 1.33 in 1.5 (water in glass)", fmt("builtin:glass-of-water?tessellation=%d", t), 4, {0, 0, 0}},
      {"IOR 2.42 (diamond)", fmt("builtin:sphere?tessellation=%d&ior=2.42", t), 4, {0, 0, 0}},
      {"IOR 4.0", fmt("builtin:sphere?tessellation=%d&ior=4", t), 4, {0, 0, 0}},
      {"grazing view of a cube face", fmt("builtin:cube?tessellation=%d", t), 4, {1.0f, 0.02f, 0.0f}},
      {"SH order 20", fmt("builtin:sphere?tessellation=%d", t), 20, {0, 0, 0}},
      {"torus (re-entry)", fmt("builtin:torus?tessellation=%d", t), 4, {0, 0, 0}},
  };
}

struct StabilityRow {
  std::string name, scene;
  uint32_t order = 0;
  uint64_t nonFinite = 0;  // non-finite values in the direction image and the colour image
  uint64_t trapped = 0, paths = 0;
  double meanAngle = 0, p95Angle = 0, psnr = 0;
};

// What the sweeps, the stability cases and the sections after them share.
struct ReportRun {
  const ReportOptions& options;
  const SizeProfile& profile;
  uint32_t width, height, frames;
  const std::string& dir;
  offscreen::Session& session;
  const Environment& gpuEnvironment;
  const bake::Image& environment;
  ReportResult& result;
};

// One scene of the settings sweeps and its exact reference, which every row is measured against.
struct SweepScene {
  const std::string& spec;
  const bake::Scene& scene;
  std::string name;  // file name stem
  const bake::Tracer& tracer;
  bake::ReferenceOptions ro;
  bake::ReferenceImage exact;
};

Result<void> createOutputDirectory(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) return makeError(ErrorCode::Io, dir + ": cannot create the output directory");
  return {};
}

Result<std::vector<bake::Scene>> loadScenes(const std::vector<std::string>& specs) {
  std::vector<bake::Scene> loaded;
  for (const auto& spec : specs) {
    auto scene = cli::loadScene(spec, {}, nullptr);
    if (!scene) return scene.error();
    loaded.push_back(std::move(scene).value());
  }
  return loaded;
}

Result<std::unique_ptr<offscreen::Session>> openSession(const ReportOptions& options) {
  harness::HarnessOptions ho;
  ho.enableValidation = options.validation;
  ho.deviceIndex = options.deviceIndex;
  ho.echoMessages = true;
  return offscreen::createSession(ho);
}

// The bake of a sweep setting or a stability case; errors name the scene (s.source).
Result<Field> bakeSetting(const bake::Scene& scene, const BakeSettings& s) {
  bake::BakeOptions bo;
  bo.settings = s;
  bo.heldOutDirections = 0;
  auto field = bake::bakeField(scene, bo);
  if (!field) return makeError(field.error().code, s.source + ": " + field.error().message);
  return field;
}

offscreen::FrameSettings frameSettings(const bake::ReferenceOptions& ro, ShadingMode mode) {
  offscreen::FrameSettings fs;
  fs.width = ro.width;
  fs.height = ro.height;
  fs.camera = ro.camera;
  fs.mode = mode;
  return fs;
}

// The report's `frames` timed frames of `fs`; the image is the last one's.
Result<bake::Image> renderTimed(ReportRun& run, const std::vector<Object*>& list, offscreen::FrameSettings fs,
                                offscreen::FrameTimings& timings) {
  // One untimed frame first: pipeline creation and first-use costs are not frame time.
  fs.frames = 1;
  if (auto warm = offscreen::renderFrame(run.session, run.gpuEnvironment, list, fs, nullptr); !warm)
    return warm.error();
  fs.frames = run.frames;
  return offscreen::renderFrame(run.session, run.gpuEnvironment, list, fs, &timings);
}

// The exit directions a field render decoded, and the mask its errors are measured over.
struct ObjectDirections {
  std::vector<glm::vec3> dirs;
  std::vector<uint8_t> mask;
};

ObjectDirections objectDirections(const bake::Image& directionImage, const std::vector<uint8_t>& exactMask,
                                  size_t pixels) {
  ObjectDirections out{std::vector<glm::vec3>(pixels), std::vector<uint8_t>(pixels, 0)};
  for (size_t p = 0; p < pixels; ++p) {
    const float* d = &directionImage.rgba[p * 4];
    out.dirs[p] = glm::vec3(d[0], d[1], d[2]);
    // Pixels the exact tracer and the raster pass both see as the object.
    out.mask[p] = exactMask[p] && glm::dot(out.dirs[p], out.dirs[p]) > 0.25f ? 1 : 0;
  }
  return out;
}

ReportRow baselineRow(const std::string& spec, const std::string& label) {
  ReportRow row;
  row.scene = spec;
  row.group = "baseline";
  row.label = label;
  const std::string none(1, '-');
  row.directions = none;
  row.quantization = none;
  row.layout = none;
  row.smoothing = none;
  return row;
}

// Exact tracing as a per-frame renderer.
void addExactBaseline(ReportRun& run, const SweepScene& sc) {
  ReportRow row = baselineRow(sc.spec, "exact (CPU)");
  row.psnr = 100.0;
  row.ssim = 1.0;
  row.frameMs = sc.exact.seconds * 1000.0;
  row.gpu = false;
  row.pixels = static_cast<uint64_t>(std::count(sc.exact.mask.begin(), sc.exact.mask.end(), uint8_t(1)));
  run.result.rows.push_back(row);
}

// What pruning costs: the full Fresnel tree against the highest-energy path.
Result<void> measureFullTree(ReportRun& run, const SweepScene& sc) {
  const bake::ReferenceImage& ex = sc.exact;
  bake::ReferenceOptions to = sc.ro;
  to.mode = bake::ReferenceMode::FullTree;
  to.treeDepth = run.options.size == ReportSize::Smoke ? 3u : 6u;
  auto tree = bake::renderReference(sc.tracer, sc.scene, run.environment, to);
  if (!tree) return tree.error();
  auto e = bake::compareImages(tree.value().color, ex.color, ex.mask, tree.value().directions, ex.directions);
  if (!e) return e.error();
  ReportRow row = baselineRow(sc.spec, fmt("full tree d%u (CPU)", to.treeDepth));
  setErrors(row, e.value());
  row.frameMs = tree.value().seconds * 1000.0;
  row.gpu = false;
  run.result.rows.push_back(row);
  return {};
}

// Single-interface refraction on the GPU: what engines ship.
Result<void> measureSingleInterface(ReportRun& run, const SweepScene& sc) {
  const bake::ReferenceImage& ex = sc.exact;
  auto objects = offscreen::uploadScene(run.session, sc.scene);
  if (!objects) return objects.error();
  std::vector<Object*> list;
  for (auto& o : objects.value()) list.push_back(o.get());
  offscreen::FrameTimings timings;
  auto image = renderTimed(run, list, frameSettings(sc.ro, ShadingMode::SingleInterface), timings);
  if (!image) return image.error();
  bake::ReferenceOptions so = sc.ro;
  so.mode = bake::ReferenceMode::SingleInterface;
  auto single = bake::renderReference(sc.tracer, sc.scene, run.environment, so);
  if (!single) return single.error();
  auto e = bake::compareImages(image.value(), ex.color, ex.mask, single.value().directions, ex.directions);
  if (!e) return e.error();
  ReportRow row = baselineRow(sc.spec, "single interface (GPU)");
  setErrors(row, e.value());
  row.rasterMs = timings.rasterMs;
  row.frameMs = median(timings.wallMs);
  run.result.rows.push_back(row);
  if (auto w = writeOut(run.dir, sc.name + "_single_interface.png", image.value(), run.result.files); !w)
    return w.error();
  return {};
}

// The orders at the ends and at the base of the sweep, and the charts layout, get side-by-side images.
bool isShowcase(const SizeProfile& profile, const SweepEntry& entry, const BakeSettings& s) {
  return (entry.group == "order" &&
          (s.order == profile.orders.front() || s.order == profile.base.order || s.order == profile.orders.back())) ||
         (entry.group == "layout" && s.layout == SampleLayout::Charts);
}

Result<void> writeShowcase(ReportRun& run, const SweepScene& sc, const SweepEntry& entry, const bake::Image& image) {
  const bake::Image heat = bake::errorHeatMap(image, sc.exact.color, 0.5f);
  const bake::Image joined = sideBySide({&image, &sc.exact.color, &heat});
  const std::string name = sc.name + "_" + entry.group + "_" + sanitize(entry.label) + "_compare.png";
  return writeOut(run.dir, name, joined, run.result.files);
}

// One setting not measured before: baked, rendered on the GPU (timed) with its exit directions, and
// compared per pixel with the exact reference. `row` comes with its scene, group and label.
Result<ReportRow> measureField(ReportRun& run, const SweepScene& sc, const SweepEntry& entry, ReportRow row,
                               size_t index, size_t count) {
  BakeSettings s = entry.settings;
  s.source = sc.spec;
  s.threads = run.options.threads;
  auto field = bakeSetting(sc.scene, s);
  if (!field) return field.error();
  row.order = s.order;
  row.directions = directionsText(s);
  row.quantization = toString(s.quantization);
  row.layout = toString(s.layout);
  row.smoothing = smoothingText(s);
  row.bakeSeconds = field.value().statistics.bakeSeconds;
  row.memoryBytes = serializeField(field.value()).size();
  auto object = offscreen::uploadField(run.session, field.value());
  if (!object) return object.error();
  std::vector<Object*> list{object.value().get()};
  offscreen::FrameSettings fs = frameSettings(sc.ro, ShadingMode::Field);
  offscreen::FrameTimings timings;
  auto image = renderTimed(run, list, fs, timings);
  if (!image) return image.error();
  fs.mode = ShadingMode::FieldExitDirection;
  fs.frames = 1;
  auto directionImage = offscreen::renderFrame(run.session, run.gpuEnvironment, list, fs, nullptr);
  if (!directionImage) return directionImage.error();
  const ObjectDirections o = objectDirections(directionImage.value(), sc.exact.mask, size_t(run.width) * run.height);
  auto e = bake::compareImages(image.value(), sc.exact.color, o.mask, o.dirs, sc.exact.directions);
  if (!e) return e.error();
  setErrors(row, e.value());
  row.decompressionMs = timings.decompressionMs;
  row.rasterMs = timings.rasterMs;
  row.frameMs = median(timings.wallMs);
  std::fprintf(stderr,
               "report: %s: [%zu/%zu] %s %s: bake %.2f s, %s, mean angle %.2f deg, PSNR %.2f dB, "
               "GPU %.2f + %.2f ms\n",
               sc.spec.c_str(), index, count, entry.group.c_str(), entry.label.c_str(), row.bakeSeconds,
               fmt("%.2f MiB", double(row.memoryBytes) / (1024.0 * 1024.0)).c_str(), row.meanAngle, row.psnr,
               row.decompressionMs, row.rasterMs);
  if (isShowcase(run.profile, entry, s))
    if (auto w = writeShowcase(run, sc, entry, image.value()); !w) return w.error();
  run.session.context->releaseDeferred();
  return row;
}

// Every setting of the sweep in order; `measured` holds the rows by settings key: shared rows are baked once.
Result<void> measureSweep(ReportRun& run, const SweepScene& sc, const std::vector<SweepEntry>& entries) {
  std::map<std::string, ReportRow> measured;
  size_t index = 0;
  for (const SweepEntry& entry : entries) {
    ++index;
    ReportRow row;
    row.scene = sc.spec;
    row.group = entry.group;
    row.label = entry.label;
    const std::string k = key(entry.settings);
    if (auto it = measured.find(k); it != measured.end()) {
      row = it->second;
      row.group = entry.group;
      row.label = entry.label;
      run.result.rows.push_back(row);
      continue;
    }
    auto fresh = measureField(run, sc, entry, row, index, entries.size());
    if (!fresh) return fresh.error();
    measured[k] = fresh.value();
    run.result.rows.push_back(fresh.value());
  }
  return {};
}

// One plot of a scene's rows: the mean angle against xOf(row), a series per group.
template <class XOf>
bake::Image sweepPlot(const ReportRun& run, const std::string& spec, const std::string& title,
                      const std::string& xLabel, XOf xOf, bool withBaselines, bool logX) {
  const std::vector<std::string> groups = {"order", "directions", "quantization", "layout", "smoothing", "baseline"};
  const std::vector<std::array<float, 3>> colors = {
      {0.10f, 0.30f, 0.85f}, {0.10f, 0.60f, 0.20f}, {0.90f, 0.50f, 0.00f},
      {0.55f, 0.20f, 0.70f}, {0.85f, 0.10f, 0.15f}, {0.20f, 0.20f, 0.20f}};
  Plot plot;
  plot.title = title;
  plot.xLabel = xLabel;
  plot.yLabel = "mean angle (deg)";
  plot.logX = logX;
  for (size_t g = 0; g < groups.size(); ++g)
    plot.series.push_back({groups[g], colors[g], groups[g] != "baseline" && groups[g] != "quantization" &&
                                                     groups[g] != "layout"});
  for (const ReportRow& r : run.result.rows) {
    if (r.scene != spec || (!withBaselines && r.group == "baseline")) continue;
    const auto g = std::find(groups.begin(), groups.end(), r.group) - groups.begin();
    plot.points.push_back({xOf(r), r.meanAngle, r.group == "baseline" ? r.label.substr(0, r.label.find(' ')) : r.label,
                           static_cast<int>(g)});
  }
  return renderPlot(plot);
}

// Plots: error against frame time, memory and bake time.
Result<void> writeSweepPlots(ReportRun& run, const SweepScene& sc) {
  const std::string title = sc.spec.substr(0, sc.spec.find('?'));
  const bake::Image p1 = sweepPlot(run, sc.spec, title + ": error vs frame time", "frame time (ms, log)",
                                   [](const ReportRow& r) { return r.frameMs; }, true, true);
  const bake::Image p2 = sweepPlot(run, sc.spec, title + ": error vs memory", "field memory (MiB)",
                                   [](const ReportRow& r) { return double(r.memoryBytes) / (1024.0 * 1024.0); },
                                   false, false);
  const bake::Image p3 = sweepPlot(run, sc.spec, title + ": error vs bake time", "bake time (s)",
                                   [](const ReportRow& r) { return r.bakeSeconds; }, false, false);
  for (auto [name, img] : {std::pair{"_error_vs_frame_time.png", &p1}, std::pair{"_error_vs_memory.png", &p2},
                           std::pair{"_error_vs_bake_time.png", &p3}})
    if (auto w = writeOut(run.dir, sc.name + name, *img, run.result.files); !w) return w.error();
  return {};
}

// One scene of the sweeps: the exact reference, the baselines, every setting, the plots.
Result<void> measureSweepScene(ReportRun& run, const std::string& spec, const bake::Scene& scene,
                               const std::vector<SweepEntry>& entries) {
  const std::string sceneName = sanitize(spec.substr(0, spec.find('?')));
  std::fprintf(stderr, "report: %s: exact reference %ux%u\n", spec.c_str(), run.width, run.height);
  auto tracer = bake::Tracer::create(scene);
  if (!tracer) return tracer.error();
  SweepScene sc{spec, scene, sceneName, *tracer.value(), {}, {}};
  sc.ro.width = run.width;
  sc.ro.height = run.height;
  sc.ro.camera = offscreen::defaultCamera(scene);
  sc.ro.threads = run.options.threads;
  auto exact = bake::renderReference(sc.tracer, scene, run.environment, sc.ro);
  if (!exact) return exact.error();
  sc.exact = std::move(exact).value();
  if (auto w = writeOut(run.dir, sceneName + "_exact.png", sc.exact.color, run.result.files); !w) return w.error();
  addExactBaseline(run, sc);
  if (auto r = measureFullTree(run, sc); !r) return r;
  if (auto r = measureSingleInterface(run, sc); !r) return r;
  if (auto r = measureSweep(run, sc, entries); !r) return r;
  return writeSweepPlots(run, sc);
}

// The case's view at half the report's size; an eye direction moves the default camera around the
// scene's centre at the same distance.
bake::ReferenceOptions stabilityView(const ReportRun& run, const bake::Scene& scene, const StabilityCase& sc) {
  bake::ReferenceOptions ro;
  ro.width = std::max(32u, run.width / 2);
  ro.height = std::max(24u, run.height / 2);
  ro.camera = offscreen::defaultCamera(scene);
  if (sc.eyeDirection != std::array<float, 3>{0, 0, 0}) {
    const std::array<float, 3> t = ro.camera.target;
    const float dist = std::sqrt(std::pow(ro.camera.eye[0] - t[0], 2.0f) + std::pow(ro.camera.eye[1] - t[1], 2.0f) +
                                 std::pow(ro.camera.eye[2] - t[2], 2.0f));
    const glm::vec3 d = glm::normalize(glm::vec3(sc.eyeDirection[0], sc.eyeDirection[1], sc.eyeDirection[2]));
    ro.camera.eye = {t[0] + d.x * dist, t[1] + d.y * dist, t[2] + d.z * dist};
  }
  ro.threads = run.options.threads;
  return ro;
}

uint64_t countNonFinite(const bake::Image& a, const bake::Image& b, size_t pixels) {
  uint64_t n = 0;
  for (size_t i = 0; i < pixels * 4; ++i) {
    n += std::isfinite(a.rgba[i]) ? 0u : 1u;
    n += std::isfinite(b.rgba[i]) ? 0u : 1u;
  }
  return n;
}

Result<StabilityRow> measureStabilityCase(ReportRun& run, const StabilityCase& sc) {
  auto scene = cli::loadScene(sc.scene, {}, nullptr);
  if (!scene) return scene.error();
  auto tracer = bake::Tracer::create(scene.value());
  if (!tracer) return tracer.error();
  const bake::ReferenceOptions ro = stabilityView(run, scene.value(), sc);
  auto exact = bake::renderReference(*tracer.value(), scene.value(), run.environment, ro);
  if (!exact) return exact.error();
  BakeSettings bs = run.profile.base;
  bs.order = sc.order;
  bs.sampleBudget = std::min<uint64_t>(run.profile.base.sampleBudget, 1500);
  bs.source = sc.scene;
  bs.threads = run.options.threads;
  auto field = bakeSetting(scene.value(), bs);
  if (!field) return field.error();
  auto object = offscreen::uploadField(run.session, field.value());
  if (!object) return object.error();
  std::vector<Object*> list{object.value().get()};
  offscreen::FrameSettings fs = frameSettings(ro, ShadingMode::Field);
  auto image = offscreen::renderFrame(run.session, run.gpuEnvironment, list, fs, nullptr);
  if (!image) return image.error();
  fs.mode = ShadingMode::FieldExitDirection;
  auto directionImage = offscreen::renderFrame(run.session, run.gpuEnvironment, list, fs, nullptr);
  if (!directionImage) return directionImage.error();
  StabilityRow row;
  row.name = sc.name;
  row.scene = sc.scene;
  row.order = sc.order;
  row.trapped = field.value().statistics.trappedPaths;
  row.paths = field.value().statistics.paths;
  const size_t pixels = size_t(fs.width) * fs.height;
  row.nonFinite = countNonFinite(directionImage.value(), image.value(), pixels);
  const ObjectDirections o = objectDirections(directionImage.value(), exact.value().mask, pixels);
  auto e = bake::compareImages(image.value(), exact.value().color, o.mask, o.dirs, exact.value().directions);
  if (!e) return e.error();
  row.meanAngle = e.value().meanAngleDegrees;
  row.p95Angle = e.value().p95AngleDegrees;
  row.psnr = e.value().psnr;
  std::fprintf(stderr, "report: stability: %s: %" PRIu64 " non-finite, mean angle %.2f deg, PSNR %.2f dB\n",
               sc.name.c_str(), row.nonFinite, row.meanAngle, row.psnr);
  if (row.nonFinite != 0)
    return makeError(ErrorCode::CorruptData, "report: stability case '" + sc.name + "' produced " +
                                                 std::to_string(row.nonFinite) + " non-finite values");
  run.session.context->releaseDeferred();
  return row;
}

Result<std::vector<StabilityRow>> measureStability(ReportRun& run) {
  std::vector<StabilityRow> stability;
  for (const StabilityCase& sc :
       run.options.fidelityOnly ? std::vector<StabilityCase>{} : stabilityCases(run.options.size)) {
    auto row = measureStabilityCase(run, sc);
    if (!row) return row.error();
    stability.push_back(row.value());
  }
  return stability;
}

Result<std::vector<FlickerScene>> measureFlicker(ReportRun& run) {
  if (run.options.fidelityOnly) return std::vector<FlickerScene>{};
  FlickerOptions fl;
  fl.size = run.options.size;
  fl.outputDirectory = run.dir;
  fl.threads = run.options.threads;
  return runFlicker(fl, run.session, run.gpuEnvironment, run.environment, run.result.files);
}

Result<FidelityResult> measureFidelity(ReportRun& run) {
  FidelityOptions fo = run.options;  // the report's own options, less what only the report reads
  fo.outputDirectory = run.dir;
  return runFidelity(fo, run.session, run.result.files);
}

std::string headerMarkdown(const ReportRun& run, const std::string& deviceName) {
  std::string md = "# shrefract report: error against run time\n\n";
  md += fmt("Device: %s. Images %ux%u, %u GPU frames timed per setting (median wall time per frame; GPU "
            "times are timestamps of the last frame). Environment: built-in procedural, %u px wide. Total %.1f s.\n\n",
            deviceName.c_str(), run.width, run.height, run.frames, run.profile.environmentWidth, run.result.seconds);
  md += "Errors are measured over the object's pixels against the exact per-pixel reference (Embree, highest-energy "
        "path, with parallax): PSNR and SSIM of the colour, and the angle between the decoded and the exact "
        "exit direction. Memory is the field file size. Sweeps vary one setting from the base "
        "(marked by the shared values).\n\n";
  return md;
}

std::string sweepMarkdown(const ReportResult& result, const std::string& spec) {
  const std::string sceneName = sanitize(spec.substr(0, spec.find('?')));
  std::string md = "## " + spec + "\n\n";
  md += "| group | setting | order | directions | quant | layout | smoothing | PSNR dB | SSIM | mean deg | p95 deg | "
        "max deg | memory MiB | bake s | decompress ms | raster ms | frame ms |\n";
  md += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const ReportRow& r : result.rows) {
    if (r.scene != spec) continue;
    md += fmt("| %s | %s | %s | %s | %s | %s | %s | %.2f | %.4f | %.2f | %.2f | %.2f | %s | %s | %s | %s | %.2f%s |\n",
              r.group.c_str(), r.label.c_str(), r.group == "baseline" ? "-" : std::to_string(r.order).c_str(),
              r.directions.c_str(), r.quantization.c_str(), r.layout.c_str(), r.smoothing.c_str(), r.psnr, r.ssim,
              r.meanAngle, r.p95Angle, r.maxAngle,
              r.memoryBytes ? fmt("%.2f", double(r.memoryBytes) / (1024.0 * 1024.0)).c_str() : "-",
              r.bakeSeconds > 0 ? fmt("%.2f", r.bakeSeconds).c_str() : "-",
              r.decompressionMs > 0 ? fmt("%.3f", r.decompressionMs).c_str() : "-",
              r.rasterMs > 0 ? fmt("%.3f", r.rasterMs).c_str() : "-", r.frameMs, r.gpu ? "" : " (CPU)");
  }
  md += "\n";
  md += "![error vs frame time](" + sceneName + "_error_vs_frame_time.png)\n";
  md += "![error vs memory](" + sceneName + "_error_vs_memory.png)\n";
  md += "![error vs bake time](" + sceneName + "_error_vs_bake_time.png)\n\n";
  md += "Side by side (SH on the GPU | exact | error heat map, |diff| summed over RGB, white = 0.5):\n\n";
  for (const auto& f : result.files)
    if (f.rfind(sceneName + "_", 0) == 0 && f.find("_compare.png") != std::string::npos)
      md += "![" + f + "](" + f + ")\n";
  md += "\n";
  return md;
}

std::string stabilityMarkdown(const SizeProfile& profile, const std::vector<StabilityRow>& stability) {
  std::string md = "## Stability\n\n";
  md += "Stiff and extreme cases, each baked small (order as given, " + directionsText(profile.base) +
        " directions, up to 1500 samples), rendered on the GPU and compared with the exact reference. "
        "The report fails if any value in the distortion or colour image is not finite. The test suite "
        "checks more cases (thin shells, open meshes, slivers, extreme scales, zero-range coefficients, "
        "vanishing direction sums, overlapping media): docs/stability.md.\n\n";
  md += "| case | scene | order | non-finite values | trapped paths | mean deg | p95 deg | PSNR dB |\n";
  md += "|---|---|---|---|---|---|---|---|\n";
  for (const StabilityRow& r : stability)
    md += fmt("| %s | %s | %u | %" PRIu64 " | %" PRIu64 " of %" PRIu64 " | %.2f | %.2f | %.2f |\n", r.name.c_str(),
              r.scene.c_str(), r.order, r.nonFinite, r.trapped, r.paths, r.meanAngle, r.p95Angle, r.psnr);
  md += "\n";
  return md;
}

// Written beside and renamed into place: a failed write leaves no partial report.md.
Result<void> writeMarkdown(const std::string& dir, const std::string& md) {
  namespace fs = std::filesystem;
  const std::string mdPath = dir + "/report.md";
  const std::string tmp = mdPath + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    out << md;
    if (!out) return makeError(ErrorCode::Io, mdPath + ": cannot write");
  }
  std::error_code ec;
  fs::rename(tmp, mdPath, ec);
  if (ec) return makeError(ErrorCode::Io, mdPath + ": cannot write: " + ec.message());
  return {};
}

}  // namespace

Result<ReportResult> runReport(const ReportOptions& options) {
  const auto start = Clock::now();
  SizeProfile profile = profileFor(options.size);
  if (options.samples != 0) profile.base.sampleBudget = options.samples;
  // The settings sweeps' scenes (none when only the fidelity section runs; it has its own defaults).
  const std::vector<std::string> scenes = options.fidelityOnly     ? std::vector<std::string>{}
                                          : options.scenes.empty() ? profile.scenes
                                                                   : options.scenes;
  const std::string& dir = options.outputDirectory;
  if (auto r = createOutputDirectory(dir); !r) return r.error();

  // Load every scene first: input errors before minutes of work.
  auto loaded = loadScenes(scenes);
  if (!loaded) return loaded.error();

  auto sessionResult = openSession(options);
  if (!sessionResult) return sessionResult.error();
  offscreen::Session& session = *sessionResult.value();
  const bake::Image environment = bake::proceduralEnvironment(profile.environmentWidth);
  auto gpuEnvironment = offscreen::uploadEnvironment(session, environment);
  if (!gpuEnvironment) return gpuEnvironment.error();

  ReportResult result;
  const uint32_t width = options.width ? options.width : profile.width;
  const uint32_t height = options.height ? options.height : profile.height;
  const uint32_t frames = options.frames ? options.frames : profile.frames;
  ReportRun run{options, profile, width, height, frames, dir, session, *gpuEnvironment.value(), environment, result};
  const std::vector<SweepEntry> entries = sweep(profile);
  for (size_t si = 0; si < scenes.size(); ++si)
    if (auto r = measureSweepScene(run, scenes[si], loaded.value()[si], entries); !r) return r.error();
  auto stability = measureStability(run);
  if (!stability) return stability.error();
  auto flicker = measureFlicker(run);
  if (!flicker) return flicker.error();
  auto fidelity = measureFidelity(run);
  if (!fidelity) return fidelity.error();
  result.fidelity = fidelity.value().scenes;

  // Counted through the teardown too: a leak is reported only while the device goes.
  const std::string deviceName = session.harness->deviceName();
  gpuEnvironment.value().reset();
  if (const uint32_t messages = offscreen::endSession(std::move(sessionResult).value()); messages != 0)
    return makeError(ErrorCode::Vulkan, "report: " + std::to_string(messages) + " Vulkan validation message(s)");
  result.seconds = since(start);

  // report.md
  std::string md = headerMarkdown(run, deviceName);
  for (const std::string& spec : scenes) md += sweepMarkdown(result, spec);
  if (!options.fidelityOnly) md += stabilityMarkdown(profile, stability.value()) + flickerMarkdown(flicker.value());
  md += fidelity.value().markdown;
  if (auto w = writeMarkdown(dir, md); !w) return w.error();
  result.files.push_back("report.md");
  return result;
}

}  // namespace shrefract::report
