// The fidelity section's images: PSNR against bytes per sample and against frame time, and the side
// by side of the default field against its references.
#include "report/fidelity_internal.h"

namespace shrefract::report::fidelity {
namespace {

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

}  // namespace

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

}  // namespace shrefract::report::fidelity
