// The fidelity section's text: how it was measured, then per scene its rows, the targets, the
// decomposition of the default field's error and the anti-aliasing table.
#include "report/fidelity_internal.h"

namespace shrefract::report::fidelity {
namespace {

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

}  // namespace

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

}  // namespace shrefract::report::fidelity
