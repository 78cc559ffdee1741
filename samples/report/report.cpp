#include "report/report.h"

#include <shrefract/bake/bake.h>
#include <shrefract/bake/image_metrics.h>
#include <shrefract/bake/reference_render.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
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
    case ReportSize::Default:
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
    case ReportSize::Full:
      p.base.directionsTheta = 32;
      p.base.directionsPhi = 64;
      p.base.sampleBudget = 35000;
      p.orders = {1, 2, 4, 8, 12, 16};
      p.directions = {{8, 16}, {16, 32}, {32, 64}, {64, 128}};
      p.width = 640;
      p.height = 480;
      p.frames = 10;
      p.scenes = {"builtin:sphere?tessellation=4", "builtin:glass-of-water?tessellation=3", "builtin:torus"};
      p.environmentWidth = 1024;
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

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
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
}  // namespace

Result<ReportResult> runReport(const ReportOptions& options) {
  namespace fs = std::filesystem;
  const auto start = Clock::now();
  SizeProfile profile = profileFor(options.size);
  if (options.samples != 0) profile.base.sampleBudget = options.samples;
  const uint32_t width = options.width ? options.width : profile.width;
  const uint32_t height = options.height ? options.height : profile.height;
  const uint32_t frames = options.frames ? options.frames : profile.frames;
  // The settings sweeps' scenes (none when only the fidelity section runs; it has its own defaults).
  const std::vector<std::string> scenes = options.fidelityOnly     ? std::vector<std::string>{}
                                          : options.scenes.empty() ? profile.scenes
                                                                   : options.scenes;
  const std::string& dir = options.outputDirectory;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) return makeError(ErrorCode::Io, dir + ": cannot create the output directory");

  // Load every scene first: input errors before minutes of work.
  std::vector<bake::Scene> loaded;
  for (const auto& spec : scenes) {
    auto scene = cli::loadScene(spec, {}, nullptr);
    if (!scene) return scene.error();
    loaded.push_back(std::move(scene).value());
  }

  harness::HarnessOptions ho;
  ho.enableValidation = options.validation;
  ho.deviceIndex = options.deviceIndex;
  ho.echoMessages = true;
  auto sessionResult = offscreen::createSession(ho);
  if (!sessionResult) return sessionResult.error();
  offscreen::Session& session = *sessionResult.value();
  const bake::Image environment = bake::proceduralEnvironment(profile.environmentWidth);
  auto gpuEnvironment = offscreen::uploadEnvironment(session, environment);
  if (!gpuEnvironment) return gpuEnvironment.error();

  ReportResult result;
  const std::vector<SweepEntry> entries = sweep(profile);
  for (size_t si = 0; si < scenes.size(); ++si) {
    const bake::Scene& scene = loaded[si];
    const std::string sceneName = sanitize(scenes[si].substr(0, scenes[si].find('?')));
    std::fprintf(stderr, "report: %s: exact reference %ux%u\n", scenes[si].c_str(), width, height);
    auto tracer = bake::Tracer::create(scene);
    if (!tracer) return tracer.error();
    bake::ReferenceOptions ro;
    ro.width = width;
    ro.height = height;
    ro.camera = offscreen::defaultCamera(scene);
    ro.threads = options.threads;
    auto exact = bake::renderReference(*tracer.value(), scene, environment, ro);
    if (!exact) return exact.error();
    const bake::ReferenceImage& ex = exact.value();
    if (auto w = writeOut(dir, sceneName + "_exact.png", ex.color, result.files); !w) return w.error();

    auto baselineRow = [&](const std::string& label) {
      ReportRow row;
      row.scene = scenes[si];
      row.group = "baseline";
      row.label = label;
      const std::string none(1, '-');
      row.directions = none;
      row.quantization = none;
      row.layout = none;
      row.smoothing = none;
      return row;
    };
    {  // Exact tracing as a per-frame renderer.
      ReportRow row = baselineRow("exact (CPU)");
      row.psnr = 100.0;
      row.ssim = 1.0;
      row.frameMs = ex.seconds * 1000.0;
      row.gpu = false;
      row.pixels = static_cast<uint64_t>(std::count(ex.mask.begin(), ex.mask.end(), uint8_t(1)));
      result.rows.push_back(row);
    }
    {  // What pruning costs: the full Fresnel tree against the highest-energy path.
      bake::ReferenceOptions to = ro;
      to.mode = bake::ReferenceMode::FullTree;
      to.treeDepth = options.size == ReportSize::Smoke ? 3u : 6u;
      auto tree = bake::renderReference(*tracer.value(), scene, environment, to);
      if (!tree) return tree.error();
      auto e = bake::compareImages(tree.value().color, ex.color, ex.mask, tree.value().directions, ex.directions);
      if (!e) return e.error();
      ReportRow row = baselineRow(fmt("full tree d%u (CPU)", to.treeDepth));
      setErrors(row, e.value());
      row.frameMs = tree.value().seconds * 1000.0;
      row.gpu = false;
      result.rows.push_back(row);
    }
    {  // Single-interface refraction on the GPU: what engines ship.
      auto objects = offscreen::uploadScene(session, scene);
      if (!objects) return objects.error();
      std::vector<Object*> list;
      for (auto& o : objects.value()) list.push_back(o.get());
      offscreen::FrameSettings fs;
      fs.width = width;
      fs.height = height;
      fs.camera = ro.camera;
      fs.mode = ShadingMode::SingleInterface;
      fs.frames = frames;
      offscreen::FrameTimings timings;
      // One untimed frame first: pipeline creation and first-use costs are not frame time.
      fs.frames = 1;
      if (auto warm = offscreen::renderFrame(session, *gpuEnvironment.value(), list, fs, nullptr); !warm)
        return warm.error();
      fs.frames = frames;
      auto image = offscreen::renderFrame(session, *gpuEnvironment.value(), list, fs, &timings);
      if (!image) return image.error();
      bake::ReferenceOptions so = ro;
      so.mode = bake::ReferenceMode::SingleInterface;
      auto single = bake::renderReference(*tracer.value(), scene, environment, so);
      if (!single) return single.error();
      auto e = bake::compareImages(image.value(), ex.color, ex.mask, single.value().directions, ex.directions);
      if (!e) return e.error();
      ReportRow row = baselineRow("single interface (GPU)");
      setErrors(row, e.value());
      row.rasterMs = timings.rasterMs;
      row.frameMs = median(timings.wallMs);
      result.rows.push_back(row);
      if (auto w = writeOut(dir, sceneName + "_single_interface.png", image.value(), result.files); !w)
        return w.error();
    }

    std::map<std::string, ReportRow> measured;  // by settings key: shared rows are baked once
    size_t index = 0;
    for (const SweepEntry& entry : entries) {
      ++index;
      ReportRow row;
      row.scene = scenes[si];
      row.group = entry.group;
      row.label = entry.label;
      const std::string k = key(entry.settings);
      if (auto it = measured.find(k); it != measured.end()) {
        row = it->second;
        row.group = entry.group;
        row.label = entry.label;
        result.rows.push_back(row);
        continue;
      }
      BakeSettings s = entry.settings;
      s.source = scenes[si];
      s.threads = options.threads;
      bake::BakeOptions bo;
      bo.settings = s;
      bo.heldOutDirections = 0;
      auto field = bake::bakeField(scene, bo);
      if (!field) return makeError(field.error().code, scenes[si] + ": " + field.error().message);
      row.order = s.order;
      row.directions = directionsText(s);
      row.quantization = toString(s.quantization);
      row.layout = toString(s.layout);
      row.smoothing = smoothingText(s);
      row.bakeSeconds = field.value().statistics.bakeSeconds;
      row.memoryBytes = serializeField(field.value()).size();
      auto object = offscreen::uploadField(session, field.value());
      if (!object) return object.error();
      std::vector<Object*> list{object.value().get()};
      offscreen::FrameSettings fs;
      fs.width = width;
      fs.height = height;
      fs.camera = ro.camera;
      fs.mode = ShadingMode::Field;
      fs.frames = frames;
      offscreen::FrameTimings timings;
      fs.frames = 1;
      if (auto warm = offscreen::renderFrame(session, *gpuEnvironment.value(), list, fs, nullptr); !warm)
        return warm.error();
      fs.frames = frames;
      auto image = offscreen::renderFrame(session, *gpuEnvironment.value(), list, fs, &timings);
      if (!image) return image.error();
      fs.mode = ShadingMode::FieldExitDirection;
      fs.frames = 1;
      auto directionImage = offscreen::renderFrame(session, *gpuEnvironment.value(), list, fs, nullptr);
      if (!directionImage) return directionImage.error();
      const size_t pixels = size_t(width) * height;
      std::vector<glm::vec3> dirs(pixels);
      std::vector<uint8_t> mask(pixels, 0);
      for (size_t p = 0; p < pixels; ++p) {
        const float* d = &directionImage.value().rgba[p * 4];
        dirs[p] = glm::vec3(d[0], d[1], d[2]);
        // Pixels the exact tracer and the raster pass both see as the object.
        mask[p] = ex.mask[p] && glm::dot(dirs[p], dirs[p]) > 0.25f ? 1 : 0;
      }
      auto e = bake::compareImages(image.value(), ex.color, mask, dirs, ex.directions);
      if (!e) return e.error();
      setErrors(row, e.value());
      row.decompressionMs = timings.decompressionMs;
      row.rasterMs = timings.rasterMs;
      row.frameMs = median(timings.wallMs);
      std::fprintf(stderr,
                   "report: %s: [%zu/%zu] %s %s: bake %.2f s, %s, mean angle %.2f deg, PSNR %.2f dB, "
                   "GPU %.2f + %.2f ms\n",
                   scenes[si].c_str(), index, entries.size(), entry.group.c_str(), entry.label.c_str(),
                   row.bakeSeconds, fmt("%.2f MiB", double(row.memoryBytes) / (1024.0 * 1024.0)).c_str(),
                   row.meanAngle, row.psnr, row.decompressionMs, row.rasterMs);
      const bool showcase = (entry.group == "order" &&
                             (s.order == profile.orders.front() || s.order == profile.base.order ||
                              s.order == profile.orders.back())) ||
                            (entry.group == "layout" && s.layout == SampleLayout::Charts);
      if (showcase) {
        const bake::Image heat = bake::errorHeatMap(image.value(), ex.color, 0.5f);
        const bake::Image joined = sideBySide({&image.value(), &ex.color, &heat});
        const std::string name = sceneName + "_" + entry.group + "_" + sanitize(entry.label) + "_compare.png";
        if (auto w = writeOut(dir, name, joined, result.files); !w) return w.error();
      }
      measured[k] = row;
      result.rows.push_back(row);
      session.context->releaseDeferred();
    }

    // Plots: error against frame time, memory and bake time.
    const std::vector<std::string> groups = {"order", "directions", "quantization", "layout", "smoothing", "baseline"};
    const std::vector<std::array<float, 3>> colors = {
        {0.10f, 0.30f, 0.85f}, {0.10f, 0.60f, 0.20f}, {0.90f, 0.50f, 0.00f},
        {0.55f, 0.20f, 0.70f}, {0.85f, 0.10f, 0.15f}, {0.20f, 0.20f, 0.20f}};
    auto makePlot = [&](const std::string& title, const std::string& xLabel, auto xOf, bool withBaselines,
                        bool logX) {
      Plot plot;
      plot.title = title;
      plot.xLabel = xLabel;
      plot.yLabel = "mean angle (deg)";
      plot.logX = logX;
      for (size_t g = 0; g < groups.size(); ++g)
        plot.series.push_back({groups[g], colors[g], groups[g] != "baseline" && groups[g] != "quantization" &&
                                                         groups[g] != "layout"});
      for (const ReportRow& r : result.rows) {
        if (r.scene != scenes[si] || (!withBaselines && r.group == "baseline")) continue;
        const auto g = std::find(groups.begin(), groups.end(), r.group) - groups.begin();
        plot.points.push_back({xOf(r), r.meanAngle, r.group == "baseline" ? r.label.substr(0, r.label.find(' ')) : r.label,
                               static_cast<int>(g)});
      }
      return renderPlot(plot);
    };
    const std::string title = scenes[si].substr(0, scenes[si].find('?'));
    const bake::Image p1 = makePlot(title + ": error vs frame time", "frame time (ms, log)",
                                    [](const ReportRow& r) { return r.frameMs; }, true, true);
    const bake::Image p2 = makePlot(title + ": error vs memory", "field memory (MiB)",
                                    [](const ReportRow& r) { return double(r.memoryBytes) / (1024.0 * 1024.0); },
                                    false, false);
    const bake::Image p3 = makePlot(title + ": error vs bake time", "bake time (s)",
                                    [](const ReportRow& r) { return r.bakeSeconds; }, false, false);
    for (auto [name, img] : {std::pair{"_error_vs_frame_time.png", &p1}, std::pair{"_error_vs_memory.png", &p2},
                             std::pair{"_error_vs_bake_time.png", &p3}})
      if (auto w = writeOut(dir, sceneName + name, *img, result.files); !w) return w.error();
  }

  std::vector<StabilityRow> stability;
  for (const StabilityCase& sc : options.fidelityOnly ? std::vector<StabilityCase>{} : stabilityCases(options.size)) {
    auto scene = cli::loadScene(sc.scene, {}, nullptr);
    if (!scene) return scene.error();
    auto tracer = bake::Tracer::create(scene.value());
    if (!tracer) return tracer.error();
    bake::ReferenceOptions ro;
    ro.width = std::max(32u, width / 2);
    ro.height = std::max(24u, height / 2);
    ro.camera = offscreen::defaultCamera(scene.value());
    if (sc.eyeDirection != std::array<float, 3>{0, 0, 0}) {
      const std::array<float, 3> t = ro.camera.target;
      const float dist = std::sqrt(std::pow(ro.camera.eye[0] - t[0], 2.0f) + std::pow(ro.camera.eye[1] - t[1], 2.0f) +
                                   std::pow(ro.camera.eye[2] - t[2], 2.0f));
      const glm::vec3 d = glm::normalize(glm::vec3(sc.eyeDirection[0], sc.eyeDirection[1], sc.eyeDirection[2]));
      ro.camera.eye = {t[0] + d.x * dist, t[1] + d.y * dist, t[2] + d.z * dist};
    }
    ro.threads = options.threads;
    auto exact = bake::renderReference(*tracer.value(), scene.value(), environment, ro);
    if (!exact) return exact.error();
    BakeSettings bs = profile.base;
    bs.order = sc.order;
    bs.sampleBudget = std::min<uint64_t>(profile.base.sampleBudget, 1500);
    bs.source = sc.scene;
    bs.threads = options.threads;
    bake::BakeOptions bo;
    bo.settings = bs;
    bo.heldOutDirections = 0;
    auto field = bake::bakeField(scene.value(), bo);
    if (!field) return makeError(field.error().code, sc.scene + ": " + field.error().message);
    auto object = offscreen::uploadField(session, field.value());
    if (!object) return object.error();
    std::vector<Object*> list{object.value().get()};
    offscreen::FrameSettings fs;
    fs.width = ro.width;
    fs.height = ro.height;
    fs.camera = ro.camera;
    fs.mode = ShadingMode::Field;
    auto image = offscreen::renderFrame(session, *gpuEnvironment.value(), list, fs, nullptr);
    if (!image) return image.error();
    fs.mode = ShadingMode::FieldExitDirection;
    auto directionImage = offscreen::renderFrame(session, *gpuEnvironment.value(), list, fs, nullptr);
    if (!directionImage) return directionImage.error();
    StabilityRow row;
    row.name = sc.name;
    row.scene = sc.scene;
    row.order = sc.order;
    row.trapped = field.value().statistics.trappedPaths;
    row.paths = field.value().statistics.paths;
    const size_t pixels = size_t(fs.width) * fs.height;
    std::vector<glm::vec3> dirs(pixels);
    std::vector<uint8_t> mask(pixels, 0);
    for (size_t p = 0; p < pixels; ++p) {
      const float* d = &directionImage.value().rgba[p * 4];
      for (int k = 0; k < 4; ++k) {
        row.nonFinite += std::isfinite(d[k]) ? 0u : 1u;
        row.nonFinite += std::isfinite(image.value().rgba[p * 4 + size_t(k)]) ? 0u : 1u;
      }
      dirs[p] = glm::vec3(d[0], d[1], d[2]);
      mask[p] = exact.value().mask[p] && glm::dot(dirs[p], dirs[p]) > 0.25f ? 1 : 0;
    }
    auto e = bake::compareImages(image.value(), exact.value().color, mask, dirs, exact.value().directions);
    if (!e) return e.error();
    row.meanAngle = e.value().meanAngleDegrees;
    row.p95Angle = e.value().p95AngleDegrees;
    row.psnr = e.value().psnr;
    std::fprintf(stderr, "report: stability: %s: %" PRIu64 " non-finite, mean angle %.2f deg, PSNR %.2f dB\n",
                 sc.name.c_str(), row.nonFinite, row.meanAngle, row.psnr);
    if (row.nonFinite != 0)
      return makeError(ErrorCode::CorruptData, "report: stability case '" + sc.name + "' produced " +
                                                   std::to_string(row.nonFinite) + " non-finite values");
    stability.push_back(row);
    session.context->releaseDeferred();
  }

  std::vector<FlickerScene> flicker;
  if (!options.fidelityOnly) {
    FlickerOptions fl;
    fl.size = options.size;
    fl.outputDirectory = dir;
    fl.threads = options.threads;
    auto orbit = runFlicker(fl, session, *gpuEnvironment.value(), environment, result.files);
    if (!orbit) return orbit.error();
    flicker = std::move(orbit).value();
  }

  FidelityOptions fo;
  fo.size = options.size;
  fo.scenes = options.scenes;
  fo.outputDirectory = dir;
  fo.width = options.width;
  fo.height = options.height;
  fo.frames = options.frames;
  fo.threads = options.threads;
  fo.samples = options.samples;
  auto fidelity = runFidelity(fo, session, result.files);
  if (!fidelity) return fidelity.error();
  result.fidelity = fidelity.value().scenes;

  // Counted through the teardown too: a leak is reported only while the device goes.
  const std::string deviceName = session.harness->deviceName();
  gpuEnvironment.value().reset();
  if (const uint32_t messages = offscreen::endSession(std::move(sessionResult).value()); messages != 0)
    return makeError(ErrorCode::Vulkan, "report: " + std::to_string(messages) + " Vulkan validation message(s)");
  result.seconds = since(start);

  // report.md
  std::string md;
  md += "# shrefract report: error against run time\n\n";
  md += fmt("Device: %s. Images %ux%u, %u GPU frames timed per setting (median wall time per frame; GPU "
            "times are timestamps of the last frame). Environment: built-in procedural, %u px wide. Total %.1f s.\n\n",
            deviceName.c_str(), width, height, frames, profile.environmentWidth, result.seconds);
  md += "Errors are measured over the object's pixels against the exact per-pixel reference (Embree, highest-energy "
        "path, with parallax): PSNR and SSIM of the colour, and the angle between the decoded and the exact "
        "exit direction. Memory is the field file size. Sweeps vary one setting from the base "
        "(marked by the shared values).\n\n";
  for (size_t si = 0; si < scenes.size(); ++si) {
    const std::string sceneName = sanitize(scenes[si].substr(0, scenes[si].find('?')));
    md += "## " + scenes[si] + "\n\n";
    md += "| group | setting | order | directions | quant | layout | smoothing | PSNR dB | SSIM | mean deg | p95 deg | "
          "max deg | memory MiB | bake s | decompress ms | raster ms | frame ms |\n";
    md += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const ReportRow& r : result.rows) {
      if (r.scene != scenes[si]) continue;
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
  }
  if (!options.fidelityOnly) {
    md += "## Stability\n\n";
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
    md += flickerMarkdown(flicker);
  }
  md += fidelity.value().markdown;
  const std::string mdPath = dir + "/report.md";
  const std::string tmp = mdPath + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    out << md;
    if (!out) return makeError(ErrorCode::Io, mdPath + ": cannot write");
  }
  fs::rename(tmp, mdPath, ec);
  if (ec) return makeError(ErrorCode::Io, mdPath + ": cannot write: " + ec.message());
  result.files.push_back("report.md");
  return result;
}

}  // namespace shrefract::report
