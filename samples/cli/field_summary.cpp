#include "cli/field_summary.h"

#include <shrefract/bake/table_fit.h>

#include <cinttypes>
#include <cstdio>

#include "report/report_text.h"

namespace shrefract::cli {

std::string jsonEscape(const std::string& s) {
  std::string out;
  for (char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += ch;
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += ch;
    }
  }
  return out;
}

namespace {

// The report's printf into a string: one formatter in the tool.
using report::fmt;

std::string bytesText(uint64_t b) {
  if (b >= (1ull << 30)) return fmt("%.2f GiB", double(b) / double(1ull << 30));
  if (b >= (1ull << 20)) return fmt("%.2f MiB", double(b) / double(1ull << 20));
  if (b >= (1ull << 10)) return fmt("%.1f KiB", double(b) / double(1ull << 10));
  return fmt("%" PRIu64 " B", b);
}

}  // namespace

static size_t refinementLayers(const Field& f) {
  if (f.encoding != Encoding::Pca || f.clustered) return 0;
  return bake::refinedComponentsOf(f.basis, f.components, size_t(f.tableSize) * f.tableSize * f.channels).size();
}

static std::string encodingText(const Field& f) {
  switch (f.encoding) {
    case Encoding::Sh: return fmt("SH order %u (%u functions)", f.order, f.layerCount());
    case Encoding::Table: return fmt("table %ux%u (hemi-octahedral, bilinear)", f.tableSize, f.tableSize);
    case Encoding::Pca: {
      if (f.clustered)
        return fmt("pca clustered: %u tables of %ux%u, one index per sample", f.components, f.tableSize, f.tableSize);
      const size_t refined = refinementLayers(f);
      const std::string layers = refined ? fmt(" (%zu of them u8 refinement layers)", refined) : std::string();
      return fmt("pca %u components%s over %ux%u tables", f.components, layers.c_str(), f.tableSize, f.tableSize);
    }
    case Encoding::Volume: {
      const uint32_t n = f.volume.size;
      return fmt("volume %ux%ux%u voxels (spacing %.4g, %s), paths traced through it per eye%s", n, n, n,
                    static_cast<double>(f.volume.spacing), bytesText(volumeGridBytes(f.volume)).c_str(),
                    f.volume.convex ? " (convex: each stops at its first way out)" : "");
    }
  }
  return "unknown encoding";
}

std::string fieldSummaryText(const Field& f, uint64_t fileBytes) {
  const BakeRecord& s = f.settings;
  const BakeStatistics& st = f.statistics;
  std::string out;
  out += fmt("field: %ux%u texels, %s, %u channels%s%s%s, %s, layout %s, %u bytes per sample\n", f.width,
                f.height, encodingText(f).c_str(), f.channels, f.hasOpticalDepth() ? "" : " (no absorption)",
                f.throughput ? " (with throughput)" : "", f.jumpDistance ? " (with jump distance)" : "",
                f.clustered ? "16-bit indices" : toString(f.quantization), toString(s.layout),
                f.bytesPerSample());
  out += fmt("path rule: %s; exits stored in %s\n", toString(s.pathRule),
                f.sampleFrameExits ? "each sample's frame" : "object space");
  out += fmt("source: %s; %zu media; mesh %zu vertices, %zu triangles\n", s.source.c_str(), f.media.size(),
                f.mesh.positions.size() / 3, f.mesh.indices.size() / 3);
  const std::string directions = f.encoding == Encoding::Volume ? std::string("none (traced per eye)")
                                 : s.directionSampling == DirectionSampling::Nodes
                                     ? fmt("the %ux%u table nodes", f.tableSize, f.tableSize)
                                     : fmt("%ux%u grid", s.directionsTheta, s.directionsPhi);
  const std::string fit = f.encoding == Encoding::Sh ? fmt(", %s fit", toString(s.shFit)) : "";
  out += fmt("settings: directions %s, max bounces %u, window %s, spatial %u, regularization %g%s, threads %u\n",
                directions.c_str(), s.maxBounces, toString(s.window), s.spatialNeighbours,
                static_cast<double>(s.regularization), fit.c_str(), s.threads);
  out += fmt("samples: %" PRIu64 " texels, %" PRIu64 " unique points, %" PRIu64 " directions\n", st.samples,
                st.uniqueSamples, st.directions);
  out += fmt("traced: %" PRIu64 " paths, %" PRIu64 " rays (%" PRIu64 " trapped at the cap), %.2f s, %.3g rays/s\n",
                st.paths, st.rays, st.trappedPaths, st.traceSeconds, st.raysPerSecond);
  out += fmt("bake: %.2f s wall, peak memory %s, file %s\n", st.bakeSeconds, bytesText(st.peakMemoryBytes).c_str(),
                bytesText(fileBytes).c_str());
  // At the traced directions: the grid's, or the nodes' (where only the Pca truncation errs).
  out += fmt("fit error (exit direction): %s RMS %.3f deg, max %.2f deg; held-out RMS %.3f deg, max %.2f deg\n",
                f.encoding == Encoding::Volume ? "cosine-weighted views"
                : s.directionSampling == DirectionSampling::Nodes ? "nodes" : "grid", static_cast<double>(st.fitRmsDegrees), static_cast<double>(st.fitMaxDegrees),
                static_cast<double>(st.heldOutRmsDegrees), static_cast<double>(st.heldOutMaxDegrees));
  out += fmt("quantization error: RMS %.4f deg, max %.3f deg\n", static_cast<double>(st.quantizationRmsDegrees),
                static_cast<double>(st.quantizationMaxDegrees));
  return out;
}

std::string fieldSummaryJson(const Field& f, uint64_t fileBytes) {
  const BakeRecord& s = f.settings;
  const BakeStatistics& st = f.statistics;
  std::string media = "[";
  for (size_t i = 0; i < f.media.size(); ++i) {
    const auto& m = f.media[i];
    media += fmt("%s{\"name\": \"%s\", \"ior\": %.9g, \"absorption\": %.9g, \"color\": [%.6g, %.6g, %.6g]}",
                    i ? ", " : "", jsonEscape(m.name).c_str(), static_cast<double>(m.ior),
                    static_cast<double>(m.absorption), static_cast<double>(m.color[0]),
                    static_cast<double>(m.color[1]), static_cast<double>(m.color[2]));
  }
  media += "]";
  std::string out = "{";
  out += fmt("\"format_version\": %u, \"width\": %u, \"height\": %u, \"order\": %u, \"basis_functions\": %u, ",
                kFieldFormatVersion, f.width, f.height, f.order, f.basisCount());
  out += fmt("\"channels\": %u, \"quantization\": \"%s\", \"file_bytes\": %" PRIu64 ", ", f.channels,
                toString(f.quantization), fileBytes);
  out += fmt("\"encoding\": \"%s\", \"table_size\": %u, \"components\": %u, \"clustered\": %s, \"refinement_layers\": %zu, "
                "\"throughput\": %s, \"jump_distance\": %s, \"bytes_per_sample\": %u, \"path_rule\": \"%s\", "
                "\"direction_sampling\": \"%s\", \"exit_frame\": \"%s\", \"volume_size\": %u, ",
                toString(f.encoding), f.tableSize, f.components, f.clustered ? "true" : "false", refinementLayers(f), f.throughput ? "true" : "false",
                f.jumpDistance ? "true" : "false", f.bytesPerSample(), toString(s.pathRule), toString(s.directionSampling),
                toString(f.sampleFrameExits ? ExitFrame::Sample : ExitFrame::Object), f.volume.size);
  out += fmt("\"mesh\": {\"vertices\": %zu, \"triangles\": %zu}, \"media\": %s, ", f.mesh.positions.size() / 3,
                f.mesh.indices.size() / 3, media.c_str());
  out += "\"settings\": {";
  out += fmt("\"source\": \"%s\", \"layout\": \"%s\", \"directions\": [%u, %u], \"sample_budget\": %" PRIu64 ", ",
                jsonEscape(s.source).c_str(), toString(s.layout), s.directionsTheta, s.directionsPhi, s.sampleBudget);
  out += fmt("\"samples_per_unit_area\": %.9g, \"max_bounces\": %u, \"window\": \"%s\", \"spatial\": %u, ",
                static_cast<double>(s.samplesPerUnitArea), s.maxBounces, toString(s.window), s.spatialNeighbours);
  out += fmt("\"regularization\": %.9g, \"sh_fit\": \"%s\", \"threads\": %u}, ",
                static_cast<double>(s.regularization), toString(s.shFit), s.threads);
  out += "\"statistics\": {";
  out += fmt("\"samples\": %" PRIu64 ", \"unique_samples\": %" PRIu64 ", \"directions\": %" PRIu64 ", ", st.samples,
                st.uniqueSamples, st.directions);
  out += fmt("\"paths\": %" PRIu64 ", \"rays\": %" PRIu64 ", \"trapped_paths\": %" PRIu64 ", ", st.paths, st.rays,
                st.trappedPaths);
  out += fmt("\"bake_seconds\": %.6g, \"trace_seconds\": %.6g, \"fit_seconds\": %.6g, \"rays_per_second\": %.6g, ",
                st.bakeSeconds, st.traceSeconds, st.fitSeconds, st.raysPerSecond);
  out += fmt("\"peak_memory_bytes\": %" PRIu64 ", ", st.peakMemoryBytes);
  out += fmt("\"fit_rms_degrees\": %.6g, \"fit_max_degrees\": %.6g, \"held_out_rms_degrees\": %.6g, "
                "\"held_out_max_degrees\": %.6g, ",
                static_cast<double>(st.fitRmsDegrees), static_cast<double>(st.fitMaxDegrees),
                static_cast<double>(st.heldOutRmsDegrees), static_cast<double>(st.heldOutMaxDegrees));
  out += fmt("\"quantization_rms_degrees\": %.6g, \"quantization_max_degrees\": %.6g}",
                static_cast<double>(st.quantizationRmsDegrees), static_cast<double>(st.quantizationMaxDegrees));
  out += "}";
  return out;
}

}  // namespace shrefract::cli
