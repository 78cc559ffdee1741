#include "report/flicker.h"

#include <shrefract/bake/bake.h>
#include <shrefract/bake/layout.h>
#include <shrefract/trace/reference_render.h>
#include <shrefract/object.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>

#include "cli/scene_source.h"
#include "report/fidelity.h"
#include "report/report_text.h"

namespace shrefract::report {
namespace {

struct OrbitProfile {
  uint32_t frames = 16, width = 160, height = 120;
  uint64_t samples = 4000;  // sample budget of the default bake, as scripts/measure/flicker-measure.sh
  std::vector<std::string> scenes{"builtin:sphere", "builtin:cube", "builtin:torus", "builtin:glass-of-water"};
};

OrbitProfile orbitFor(ReportSize size) {
  OrbitProfile p;
  if (size == ReportSize::Smoke) {
    p.frames = 3;
    p.width = 32;
    p.height = 24;
    p.samples = 300;
    p.scenes = {"builtin:sphere?tessellation=1"};
  } else if (size == ReportSize::Full) {
    p.frames = 32;
    p.width = 320;
    p.height = 240;
    p.samples = bake::kDefaultSampleBudget;
  }
  return p;
}

// The eye of frame t: turning about the vertical axis by 3 degrees a frame, 4 units out and 1.2 up,
// looking at the origin (the built-in scenes are centred there).
Camera orbitCamera(uint32_t t) {
  const double a = 3.0 * double(t) * std::numbers::pi / 180.0;
  Camera c;
  c.eye = {float(4.0 * std::sin(a)), 1.2f, float(4.0 * std::cos(a))};
  c.target = {0.0f, 0.0f, 0.0f};
  c.verticalFovDegrees = 40.0f;  // as `shrefract render`
  return c;
}

// The tool's default field for `spec`, at the profile's sample budget.
bake::BakeOptions orbitBakeOptions(const FlickerOptions& options, const OrbitProfile& p, const std::string& spec) {
  bake::BakeOptions bo;
  bo.settings = defaultFieldSettings();
  bo.settings.source = spec;
  bo.settings.sampleBudget = p.samples;
  bo.settings.volumeDensify = false;  // a budget given, as `bake --samples`
  bo.settings.threads = options.threads;
  bo.heldOutDirections = 0;
  return bo;
}

offscreen::FrameSettings orbitFrameSettings(const OrbitProfile& p, uint32_t t) {
  offscreen::FrameSettings fs;
  fs.width = p.width;
  fs.height = p.height;
  fs.camera = orbitCamera(t);
  fs.mode = ShadingMode::Field;
  return fs;
}

bake::ReferenceOptions orbitReferenceOptions(const FlickerOptions& options, const OrbitProfile& p,
                                             const Camera& camera) {
  bake::ReferenceOptions ro;
  ro.mode = bake::ReferenceMode::FullTree;
  ro.width = p.width;
  ro.height = p.height;
  ro.camera = camera;
  ro.samplesPerAxis = 4;
  ro.threads = options.threads;
  return ro;
}

// Writes frame t's field and reference images as FOLDER/field_TT.png and FOLDER/reference_TT.png.
Result<void> writeOrbitFrame(const FlickerOptions& options, const std::string& folder, uint32_t t,
                             const bake::Image& field, const bake::Image& reference, std::vector<std::string>& files) {
  for (const auto& [name, image] : {std::pair{"field", &field}, std::pair{"reference", &reference}}) {
    const std::string file = folder + fmt("/%s_%02u.png", name, t);
    if (auto w = bake::writeImage(options.outputDirectory + "/" + file, *image); !w) return w.error();
    files.push_back(file);
  }
  return {};
}

Result<FlickerScene> orbitScene(const FlickerOptions& options, const OrbitProfile& p, const std::string& spec,
                                offscreen::Session& session, const Environment& gpuEnvironment,
                                const bake::Image& environment, std::vector<std::string>& files) {
  const auto start = std::chrono::steady_clock::now();
  auto scene = cli::loadScene(spec, {}, nullptr);
  if (!scene) return scene.error();
  auto tracer = bake::Tracer::create(scene.value());
  if (!tracer) return makeError(tracer.error().code, spec + ": " + tracer.error().message);
  const bake::BakeOptions bo = orbitBakeOptions(options, p, spec);
  auto field = bake::bakeField(scene.value(), bo);
  if (!field) return makeError(field.error().code, spec + ": bake: " + field.error().message);
  auto object = offscreen::uploadField(session, field.value());
  if (!object) return object.error();

  const std::string folder = "flicker_" + sanitize(spec.substr(0, spec.find('?')));
  std::filesystem::create_directories(options.outputDirectory + "/" + folder);
  std::vector<bake::Image> fieldFrames, referenceFrames;
  std::vector<std::vector<uint8_t>> masks;
  for (uint32_t t = 0; t < p.frames; ++t) {
    const offscreen::FrameSettings fs = orbitFrameSettings(p, t);
    auto frame = offscreen::renderFrame(session, gpuEnvironment, {object.value().get()}, fs);
    if (!frame) return frame.error();
    const bake::ReferenceOptions ro = orbitReferenceOptions(options, p, fs.camera);
    auto reference = bake::renderReference(*tracer.value(), scene.value(), environment, ro);
    if (!reference) return makeError(reference.error().code, spec + ": reference: " + reference.error().message);
    if (auto w = writeOrbitFrame(options, folder, t, frame.value(), reference.value().color, files); !w)
      return w.error();
    fieldFrames.push_back(std::move(frame).value());
    masks.push_back(reference.value().mask);
    referenceFrames.push_back(std::move(reference.value().color));
    std::fprintf(stderr, "report: flicker: %s: frame %u of %u\n", spec.c_str(), t + 1, p.frames);
  }
  FlickerScene out;
  out.scene = spec;
  out.frames = p.frames;
  out.width = p.width;
  out.height = p.height;
  out.samples = field.value().statistics.samples;
  out.fieldFlicker = flickerOf(fieldFrames, masks);
  out.referenceFlicker = flickerOf(referenceFrames, masks);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  session.context->releaseDeferred();
  return out;
}

}  // namespace

double flickerOf(const std::vector<bake::Image>& frames, const std::vector<std::vector<uint8_t>>& masks) {
  double total = 0.0;
  for (size_t t = 1; t < frames.size(); ++t) {
    double change = 0.0;
    uint64_t pixels = 0;
    for (size_t i = 0; i < masks[t].size(); ++i) {
      if (!masks[t][i] && !masks[t - 1][i]) continue;
      ++pixels;
      for (size_t k = 0; k < 3; ++k) {
        const float a = std::clamp(frames[t].rgba[i * 4 + k], 0.0f, 1.0f);
        const float b = std::clamp(frames[t - 1].rgba[i * 4 + k], 0.0f, 1.0f);
        change += std::fabs(double(a) - double(b));
      }
    }
    total += pixels ? change / (3.0 * double(pixels)) : 0.0;
  }
  return frames.size() > 1 ? total / double(frames.size() - 1) : 0.0;
}

Result<std::vector<FlickerScene>> runFlicker(const FlickerOptions& options, offscreen::Session& session,
                                             const Environment& gpuEnvironment, const bake::Image& environment,
                                             std::vector<std::string>& files) {
  const OrbitProfile p = orbitFor(options.size);
  std::vector<FlickerScene> out;
  for (const std::string& spec : p.scenes) {
    auto scene = orbitScene(options, p, spec, session, gpuEnvironment, environment, files);
    if (!scene) return scene.error();
    std::fprintf(stderr, "report: flicker: %s: field %.5f, reference %.5f, ratio %.2f (%.1f s)\n", spec.c_str(),
                 scene.value().fieldFlicker, scene.value().referenceFlicker,
                 scene.value().fieldFlicker / scene.value().referenceFlicker, scene.value().seconds);
    out.push_back(scene.value());
  }
  return out;
}

std::string flickerMarkdown(const std::vector<FlickerScene>& scenes) {
  std::string md = "## Temporal stability\n\n";
  md += "An orbit about the vertical axis (3 degrees a frame, the eye 4 units out and 1.2 up, looking at the "
        "origin) around each built-in scene: the tool's default field (Pca K=324, u8) at one sample per pixel on "
        "the GPU, with its filtered environment lookups, against the physical reference (full Fresnel tree, "
        "depth 8, 4x4 supersampled, CPU). Flicker: the mean absolute frame-to-frame change of the colour "
        "(clamped to [0, 1]) over the pixels that are the object's in either frame; the target is a field at most "
        "1.5x the reference's (docs/technique.md). The frames are in each scene's folder (field_TT.png, "
        "reference_TT.png).\n\n";
  md += "| scene | frames | size | field samples | field flicker | reference flicker | field / reference |\n";
  md += "|---|---|---|---|---|---|---|\n";
  for (const FlickerScene& s : scenes)
    md += fmt("| %s | %u | %ux%u | %llu | %.5f | %.5f | %.2f |\n", s.scene.c_str(), s.frames, s.width, s.height,
              static_cast<unsigned long long>(s.samples), s.fieldFlicker, s.referenceFlicker,
              s.referenceFlicker > 0.0 ? s.fieldFlicker / s.referenceFlicker : 0.0);
  return md + "\n";
}

}  // namespace shrefract::report
