// Finishing a bake from its traced parts: the Pca basis (basis.cpp), smoothing, the fit checks,
// quantization (refinement layers) and the statistics (bake_driver.h: finishBake).
#include "driver/bake_driver.h"

#include "parallel.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace shrefract::bake::detail {

namespace {

// Where the fit check decodes grid direction d. A node grid's border nodes are traced lifted to
// kNodeMinZ, which the table maps up to half a cell inside its border (N = 64): decoded there, the
// check measured the interpolation toward the next row, where grazing paths jump, as fit error
// (7.9 deg RMS on the torus's uncompressed 64x64 table). At the node's own direction the decode
// reads that node alone, so only the Pca truncation errs, as the summary says.
glm::vec3 fitCheckDirection(const EncodingShape& shape, const DirectionGrid& grid, uint32_t d) {
  if (!shape.jumpAware) return glm::vec3(grid.directions[d]);  // a fitted grid: its own directions
  const std::array<float, 3> node = hemiOctDirection(d % shape.tableSize, d / shape.tableSize, shape.tableSize);
  return {node[0], node[1], node[2]};
}

// Fit and held-out errors of the float encoding (grid: every kGridCheckStride-th sample), one
// sample per task: each writes only its own errors[s].
void measureFit(const EncodingShape& shape, const std::vector<float>& basis, const std::vector<float>& coeffs,
                const SampleAtlas& atlas, const DirectionGrid& grid, const TracedChecks& checks, uint32_t held,
                uint32_t threads, std::vector<SampleError>& errors) {
  const uint32_t nd = static_cast<uint32_t>(grid.directions.size());
  parallelFor(errors.size(), threads, [&](size_t s) {
    std::vector<float> out(shape.channels);
    SampleError& err = errors[s];
    const float* c = &coeffs[s * strideOf(shape)];
    if (s % kGridCheckStride == 0) {
      const ManyDirectionDecoder decoder(shape, basis.data(), c);
      const std::array<float, 12> rows = sampleRows(atlas.samples[s]);
      for (uint32_t d = 0; d < nd; ++d) {
        decoder.decode(fitCheckDirection(shape, grid, d), rows.data(), out.data());
        const glm::vec3 traced = checks.gridExits[s / kGridCheckStride * nd + d];
        const double a = angleDegrees(glm::vec3(out[0], out[1], out[2]), traced);
        err.gridSquares += a * a;
        err.gridMax = std::max(err.gridMax, a);
        ++err.gridCount;
      }
    }
    for (uint32_t h = 0; h < held; ++h) {
      decodeFloat(shape, basis, c, atlas.samples[s], checks.heldDirections[s * held + h], out.data());
      const double a = angleDegrees(glm::vec3(out[0], out[1], out[2]), checks.heldExits[s * held + h]);
      err.heldSquares += a * a;
      err.heldMax = std::max(err.heldMax, a);
      ++err.heldCount;
    }
  });
}

// encodeCoefficients straight from the per-sample fits (coeffs: stride floats a sample, layer i's
// values at i * valuesPerLayer): texels of kind kTexelSample read their sample's, the rest are
// zeros. No texel-ordered float copy of the atlas, which was the bake's largest allocation.
Result<void> encodeSamples(Field& field, const SampleAtlas& atlas, const EncodingShape& shape,
                           const std::vector<float>& coeffs) {
  const size_t stride = strideOf(shape);
  return encodeCoefficients(
      field,
      [&](uint64_t t) -> const float* {
        return atlas.texelKinds[t] == kTexelSample ? coeffs.data() + size_t(atlas.texelSample[t]) * stride : nullptr;
      },
      shape.valuesPerLayer());
}

}  // namespace

// The first texel of every sample (UINT64_MAX for a sample no texel holds).
std::vector<uint64_t> firstTexels(const SampleAtlas& atlas) {
  std::vector<uint64_t> texelOf(atlas.samples.size(), UINT64_MAX);
  for (size_t t = 0; t < size_t(atlas.width) * atlas.height; ++t)
    if (atlas.texelKinds[t] == kTexelSample && texelOf[atlas.texelSample[t]] == UINT64_MAX)
      texelOf[atlas.texelSample[t]] = t;
  return texelOf;
}

namespace {

// A u8 Pca field's refinement layers (table_fit.h): quantizes the field once with them at zero,
// fills them with what each refined layer lost, and quantizes again (each layer has its own
// range, so the refined layers' codes do not change).
Result<void> encodeWithRefinement(Field& field, const SampleAtlas& atlas, const EncodingShape& shape,
                                  const std::vector<float>& fitted, const std::vector<uint32_t>& refined) {
  if (auto r = encodeSamples(field, atlas, shape, fitted); !r || refined.empty()) return r;
  // The weights are filled into a copy: the statistics that follow compare the field with the fit.
  std::vector<float> coeffs = fitted;
  const std::vector<uint64_t> texelOf = firstTexels(atlas);
  fillRefinementWeights(coeffs, atlas.samples.size(), shape.components, refined, [&](size_t s, uint32_t k) {
    return texelOf[s] == UINT64_MAX ? coeffs[s * shape.components + k] : fieldCoefficient(field, k, texelOf[s], 0);
  });
  return encodeSamples(field, atlas, shape, coeffs);
}

// Quantization error: the decoded direction from quantized coefficients against the float
// encoding, at every third grid direction of every 7th sample (deterministic subset; the sums run
// in sample order whatever the threads).
void measureQuantization(const Field& field, const SampleAtlas& atlas, const std::vector<float>& basis,
                         const std::vector<float>& coeffs, const DirectionGrid& grid, uint32_t threads,
                         BakeStatistics& st) {
  constexpr size_t kSampleStride = 7;
  const EncodingShape shape = field.shape();
  const std::vector<uint64_t> texelOf = firstTexels(atlas);
  // One slot per checked sample; its grid* fields hold the quantization angles (the held* stay 0).
  std::vector<SampleError> errors((atlas.samples.size() + kSampleStride - 1) / kSampleStride);
  parallelFor(errors.size(), threads, [&](size_t i) {
    const size_t s = i * kSampleStride;
    if (texelOf[s] == UINT64_MAX) return;
    std::vector<float> a(shape.channels), b(shape.channels), quantized;
    // Once per sample, not per direction: a 64x64 table has 4096 layers to dequantize.
    dequantizeSample(field, texelOf[s], quantized);
    const ManyDirectionDecoder exact(shape, basis.data(), &coeffs[s * strideOf(shape)]);
    const ManyDirectionDecoder stored(shape, field.basis.data(), quantized.data());
    const std::array<float, 12> sampleFrame = sampleRows(atlas.samples[s]);
    const float* rows = &field.frames[texelOf[s] * 12];
    for (size_t d = 0; d < grid.directions.size(); d += 3) {
      const glm::vec3 w(grid.directions[d]);
      exact.decode(w, sampleFrame.data(), a.data());
      stored.decode(w, rows, b.data());
      const double angle = angleDegrees(glm::vec3(a[0], a[1], a[2]), glm::vec3(b[0], b[1], b[2]));
      errors[i].gridSquares += angle * angle;
      errors[i].gridMax = std::max(errors[i].gridMax, angle);
      ++errors[i].gridCount;
    }
  });
  double squares = 0.0, maxAngle = 0.0;
  uint64_t count = 0;
  for (const SampleError& e : errors) {
    squares += e.gridSquares;
    maxAngle = std::max(maxAngle, e.gridMax);
    count += e.gridCount;
  }
  st.quantizationRmsDegrees = count ? static_cast<float>(std::sqrt(squares / double(count))) : 0.0f;
  st.quantizationMaxDegrees = static_cast<float>(maxAngle);
}

}  // namespace

// The atlas's texels of kind kTexelSample: the field's samples, as its statistics count them.
uint64_t sampleTexelCount(const SampleAtlas& atlas) {
  uint64_t samples = 0;
  for (uint8_t kind : atlas.texelKinds) samples += kind == kTexelSample ? 1u : 0u;
  return samples;
}

namespace {

// Counts, fit errors and timings. Parts may have run at the same time on different machines: the
// longest one is the bake's wall time, the thread times of all apportion it between trace and fit.
void fillStatistics(const SampleAtlas& atlas, const std::vector<BakePart>& parts, const std::vector<SampleError>& errors,
                    uint32_t nd, double finishSeconds, BakeStatistics& st) {
  st.uniqueSamples = atlas.samples.size();
  st.samples = sampleTexelCount(atlas);
  st.directions = nd;
  double gridSquares = 0, heldSquares = 0, traceWall = 0, partSeconds = 0, threadTrace = 0, threadFit = 0;
  uint64_t gridCount = 0, heldCount = 0, peak = peakResidentBytes();
  for (const BakePart& p : parts) {
    st.rays += p.rays;
    st.paths += p.paths;
    st.trappedPaths += p.trappedPaths;
    traceWall = std::max(traceWall, p.timings.traceWallSeconds);
    partSeconds = std::max(partSeconds, p.timings.bakeSeconds);
    threadTrace += p.timings.threadTraceSeconds;
    threadFit += p.timings.threadFitSeconds;
    peak = std::max(peak, p.timings.peakMemoryBytes);
  }
  for (const SampleError& e : errors) {  // in sample order: deterministic sums
    gridSquares += e.gridSquares;
    heldSquares += e.heldSquares;
    gridCount += e.gridCount;
    heldCount += e.heldCount;
    st.fitMaxDegrees = std::max(st.fitMaxDegrees, static_cast<float>(e.gridMax));
    st.heldOutMaxDegrees = std::max(st.heldOutMaxDegrees, static_cast<float>(e.heldMax));
  }
  st.fitRmsDegrees = gridCount ? static_cast<float>(std::sqrt(gridSquares / double(gridCount))) : 0.0f;
  st.heldOutRmsDegrees = heldCount ? static_cast<float>(std::sqrt(heldSquares / double(heldCount))) : 0.0f;
  const double traceShare = threadTrace + threadFit > 0.0 ? threadTrace / (threadTrace + threadFit) : 1.0;
  st.traceSeconds = traceWall * traceShare;
  st.fitSeconds = traceWall * (1.0 - traceShare) + finishSeconds;
  st.bakeSeconds = partSeconds + finishSeconds;
  st.raysPerSecond = traceWall > 0.0 ? double(st.rays) / traceWall : 0.0;
  st.peakMemoryBytes = peak;
}

// Spatial smoothing (--spatial) of every sample's floats, then the SH band window.
void smoothSamples(const BakePlan& plan, const BakeSettings& settings, size_t stride, std::vector<float>& coeffs) {
  const SampleAtlas& atlas = plan.atlas;
  const size_t sampleCount = atlas.samples.size();
  if (settings.spatialNeighbours != 0) {
    std::vector<glm::vec3> positions(sampleCount);
    for (size_t s = 0; s < sampleCount; ++s) positions[s] = atlas.samples[s].position;
    smoothSpatially(coeffs, stride, positions, atlas.neighbours, settings.spatialNeighbours);
  }
  if (settings.window != SmoothingWindow::None && settings.encoding == Encoding::Sh) {
    const std::vector<double> weights = bandWindow(settings.window, static_cast<int>(settings.order));
    for (size_t s = 0; s < sampleCount; ++s)
      sh::applyWindow(static_cast<int>(settings.order), weights.data(), &coeffs[s * stride],
                      static_cast<int>(plan.channels));
  }
}

}  // namespace

// The field as the plan lays it out, before its coefficients are encoded: header, texels, mesh
// and every sample texel's frame.
Field fieldLayout(const BakePlan& plan, const BakeSettings& settings, const EncodingShape& shape,
                  const std::vector<float>& basis) {
  const SampleAtlas& atlas = plan.atlas;
  Field field;
  field.width = atlas.width;
  field.height = atlas.height;
  field.encoding = settings.encoding;
  field.order = settings.order;
  field.tableSize = settings.tableSize;
  field.components = settings.components;
  field.channels = plan.channels;
  field.throughput = settings.throughput;
  field.jumpDistance = settings.jumpDistance;
  field.sampleFrameExits = shape.sampleFrameExits;
  field.clustered = shape.clustered;
  field.settings = settings;  // before encoding: its validation reads the direction sampling
  field.basis = basis;
  field.quantization = settings.quantization;
  field.texelKinds = atlas.texelKinds;
  field.gutters = atlas.gutters;
  field.mesh = atlas.mesh;
  const size_t texels = size_t(atlas.width) * atlas.height;
  field.frames.assign(texels * 12, 0.0f);
  for (size_t t = 0; t < texels; ++t) {
    if (atlas.texelKinds[t] != kTexelSample) continue;
    const auto rows = sampleRows(atlas.samples[atlas.texelSample[t]]);
    std::copy(rows.begin(), rows.end(), &field.frames[t * 12]);
  }
  return field;
}

// The steps that need every sample, the same for a single-process bake, a merge of part files and
// rank 0 of an MPI bake: the Pca basis, smoothing, the window, the error statistics, quantization.
// `parts` passed checkParts and match the plan.
Result<Field> finishBake(const BakePlan& plan, std::vector<BakePart> parts) {
  const auto finishStart = Clock::now();
  BakeSettings settings = plan.settings;
  const SampleAtlas& atlas = plan.atlas;
  const DirectionGrid& grid = plan.grid;
  const size_t sampleCount = atlas.samples.size();
  const uint32_t nd = static_cast<uint32_t>(grid.directions.size()), held = parts.front().heldOutDirections;
  EncodingShape shape = shapeOf(settings, plan.channels);
  Gathered g = gatherParts(parts, parts.front().stride, nd, held);
  std::vector<float>& coeffs = g.coeffs;

  std::vector<float> basis;
  if (settings.encoding == Encoding::Pca) {
    if (auto learned = learnBasisInItsFrame(plan, shape, coeffs, basis); !learned) return learned.error();
    settings.components = shape.components;  // what the field stores: the clusters, where it keeps them
  }
  settings.exitFrame = shape.sampleFrameExits ? ExitFrame::Sample : ExitFrame::Object;  // what the field stores
  smoothSamples(plan, settings, strideOf(shape), coeffs);
  std::vector<uint32_t> refined;
  // A clustered field stores one index a sample: nothing for refinement layers to refine.
  if (settings.encoding == Encoding::Pca && settings.quantization == Quantization::U8 && !shape.clustered) {
    refined = chooseRefinedComponents(coeffs, sampleCount, shape.components);
    makeRefinementLayers(coeffs, sampleCount, shape.components, basis,
                         tableValues(shape), refined);
  }
  std::vector<SampleError> errors(sampleCount);
  plan.begin("checking the fit against the traced directions");
  measureFit(shape, basis, coeffs, atlas, grid, g.checks, held, settings.threads, errors);

  Field field = fieldLayout(plan, settings, shape, basis);
  plan.begin("quantizing " + std::to_string(sampleCount) + " samples");
  if (auto encoded = encodeWithRefinement(field, atlas, shape, coeffs, refined); !encoded) return encoded.error();
  measureQuantization(field, atlas, basis, coeffs, grid, settings.threads, field.statistics);
  field.media = plan.media;
  field.settings = settings;
  for (const BakePart& p : parts) field.settings.threads = std::max(field.settings.threads, p.settings.threads);
  fillStatistics(atlas, parts, errors, nd, secondsSince(finishStart), field.statistics);

  if (auto valid = validateField(field); !valid)
    return makeError(ErrorCode::CorruptData, "bake produced an invalid field: " + valid.error().message);
  return field;
}

}  // namespace shrefract::bake::detail
