// Measuring one scene of the fidelity section: the physical and exact references on the CPU, each
// variant baked in f16 and u8 and drawn on the GPU, the decomposition of the default field's error
// and its anti-aliasing at 1 spp.
#include "report/fidelity_internal.h"

namespace shrefract::report::fidelity {
namespace {

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

// PSNR over the physical reference's object pixels.
Result<double> psnrOf(const SceneContext& c, const bake::Image& approx, const bake::Image& reference) {
  auto e = bake::compareImages(approx, reference, c.physical.mask, {}, {});
  if (!e) return e.error();
  return e.value().psnr;
}

// One figure: the PSNR of `image` against `reference`, stored in `psnr`.
struct PsnrFigure {
  const bake::Image* image;
  const bake::Image* reference;
  double* psnr;
};

// Each figure in order, or the first error.
Result<void> measurePsnrs(const SceneContext& c, std::initializer_list<PsnrFigure> figures) {
  for (const PsnrFigure& f : figures) {
    auto r = psnrOf(c, *f.image, *f.reference);
    if (!r) return r.error();
    *f.psnr = r.value();
  }
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

// Both PSNRs of a row: against the physical reference and against the exact render it approximates.
Result<void> scoreRow(const SceneContext& c, const bake::Image& image, const bake::Image& sameRule, FidelityRow& row) {
  return measurePsnrs(c, {{&image, &c.physical.color, &row.psnrPhysical},
                         {&image, &sameRule, &row.psnrSameRule},
                         {&image, &c.dense.color, &row.psnrDense}});
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
  auto measured =
      measurePsnrs(c, {{&coarser, &finer, &st.psnr}, {&coarser, &c.physical.color, &st.cumulative}});
  if (!measured) return measured;
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
    auto measured = measurePsnrs(c, {{&one, &c.physical.color, &a.psnrOneSample},
                                     {&supersampled, &c.physical.color, &a.psnrSupersampled},
                                     {&one, &c.dense.color, &a.denseOneSample},
                                     {&supersampled, &c.dense.color, &a.denseSupersampled}});
    if (!measured) return measured;
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

}  // namespace

std::string sceneTitle(const std::string& spec) {
  std::string t = spec.substr(0, spec.find('?'));
  const size_t slash = t.find_last_of('/');
  return slash == std::string::npos ? t : t.substr(slash + 1);
}

Result<void> writeOut(SceneContext& c, const std::string& name, const bake::Image& image) {
  if (auto r = bake::writeImage(c.options.outputDirectory + "/" + name, image); !r) return r;
  c.files.push_back(name);
  return {};
}

PathRule defaultRule(const Profile& p, const DefaultField& def) {
  if (def.f16) return def.f16->settings.pathRule;
  for (const Variant& v : p.variants)
    if (v.isDefault) return v.settings.pathRule;
  return PathRule::HighestEnergy;
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

}  // namespace shrefract::report::fidelity
