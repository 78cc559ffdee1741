// The report sizes' fidelity profiles: image size, references, scenes, and the field variants each
// size bakes (the tool's default field, then sweeps over every encoding's parameters).
#include "report/fidelity_internal.h"

namespace shrefract::report::fidelity {
namespace {

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

}  // namespace

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

}  // namespace shrefract::report::fidelity
