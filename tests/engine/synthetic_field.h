// Synthetic refraction fields for the engine tests: a band of a sphere (theta in [0.2 pi, 0.8 pi],
// so no degenerate pole triangles) whose atlas texel (x, y) is the surface point at
// phi = 2 pi (x + 0.5) / width, theta between the band's limits at (y + 0.5) / height, with the
// frame of that point's outward normal, and smooth pseudo-random coefficients in any encoding
// (field.h) whose decoded direction is dominated by the direction into the sphere, so that the
// decoded sums never come near zero: Sh (a dominant band-0 term), Table (every node near it) or
// Pca (a mean component and three axis components weighted by it, plus random components).
// Optional empty texels (last column) and gutter texels (last row, each filled by a rule from
// sample texels above it), optical depth and throughput channels. Deterministic for a given seed;
// for Table and Pca, the x, y, z and tau values do not depend on the channel layout, so fields
// that differ only in their throughput channel decode to the same directions.
#pragma once

#include <shrefract/field.h>
#include <shrefract/gpu_layout.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

namespace shrefract::testing {

struct SyntheticFieldOptions {
  uint32_t width = 24;
  uint32_t height = 16;
  Encoding encoding = Encoding::Sh;
  uint32_t order = 2;       // Sh
  uint32_t tableSize = 5;   // Table, Pca: N
  uint32_t components = 6;  // Pca: K
  // 3 (x, y, z) or 4 (and tau) without throughput; 4 (x, y, z, throughput) or 5 with it.
  uint32_t channels = 4;
  bool throughput = false;
  // >= 0: the throughput channel holds this value at every layer's node (Table), as the mean
  // component (Pca) or in band 0 (Sh), so that it decodes to it (up to rounding) everywhere.
  // < 0: a smooth pseudo-random throughput around 0.7 that leaves [0, 1] in places.
  float constantThroughput = -1.0f;
  Quantization quantization = Quantization::U8;
  bool emptyAndGutters = false;  // last column empty, last row gutters
  // Table, Pca: traced at the nodes (settings.directionSampling), so decoded jump-aware
  // (EncodingShape::jumpAware); `jumps`: every fifth node's direction points the other way.
  bool nodeSampled = false;
  bool jumps = false;
  // With nodeSampled and N >= 12: a last channel of jump distances (EncodingShape::jumpDistance),
  // 0.1 to 0.9 cells varying by node and texel, so that the side of each disagreeing cell moves.
  bool jumpDistance = false;
  // Channels 0..2 are read as exits in each sample's frame (EncodingShape::sampleFrameExits).
  bool sampleFrameExits = false;
  // Pca: clustered (EncodingShape::clustered): function j is the decoded table of the j-th of K
  // sample texels spread over the atlas, and every sample texel stores the index of the one whose
  // direction into the sphere is nearest its own.
  bool clustered = false;
  // > 0: the dominant direction of each texel in every other block of 4 columns moved by a
  // pseudo-random vector of components up to this (per texel, from the seed): there neighbouring
  // texels disagree as a chaotic field's do, and they meet smooth texels along many edges.
  float texelScatter = 0.0f;
  // Volume: voxels per side of the grid, the sphere of `radius` at `center` (syntheticSphereVolume),
  // and the rule its trace follows.
  uint32_t volumeSize = 32;
  PathRule pathRule = PathRule::HighestEnergy;
  uint32_t seed = 1;
  float radius = 1.0f;
  std::array<float, 3> center{0.0f, 0.0f, 0.0f};
  uint32_t meshSegments = 24;  // quads around; meshSegments / 2 quads from top to bottom of the band
  float frontIor = 1.5f;
};

inline constexpr float kBandTheta0 = 0.2f * std::numbers::pi_v<float>;
inline constexpr float kBandTheta1 = 0.8f * std::numbers::pi_v<float>;

// Surface point and outward normal of the band at normalized atlas coordinates (u, v).
inline void bandPoint(const SyntheticFieldOptions& o, float u, float v, float* position, float* normal) {
  const float phi = 2.0f * std::numbers::pi_v<float> * u;
  const float theta = kBandTheta0 + (kBandTheta1 - kBandTheta0) * v;
  // y up: theta from +Y, phi around it starting at +Z toward +X.
  normal[0] = std::sin(theta) * std::sin(phi);
  normal[1] = std::cos(theta);
  normal[2] = std::sin(theta) * std::cos(phi);
  for (int k = 0; k < 3; ++k) position[k] = o.center[size_t(k)] + o.radius * normal[k];
}

// The channel roles of a field with these options.
inline bool syntheticHasTau(const SyntheticFieldOptions& o) { return o.channels == (o.throughput ? 5u : 4u); }
inline bool isThroughputChannel(const SyntheticFieldOptions& o, uint32_t c) {
  return o.throughput && c == o.channels - 1;
}

// Sh: per (layer, channel) an amplitude and two phases, band 0 dominant. The throughput channel
// (not drawn from the generator, so that the other channels stay as they were before it existed)
// is about 0.7 + 0.35 sin(...) in band 0 with small higher bands.
inline std::vector<float> syntheticShCoefficients(const SyntheticFieldOptions& o, const Field& f,
                                                  const std::vector<float>& directions) {
  constexpr float kY0 = 0.282094792f;
  const uint32_t texels = o.width * o.height;
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  const uint32_t layers = f.layerCount();
  std::vector<float> amplitude(size_t(layers) * 4), phaseX(size_t(layers) * 4), phaseY(size_t(layers) * 4);
  for (size_t i = 0; i < amplitude.size(); ++i) {
    amplitude[i] = uniform(rng);
    phaseX[i] = 3.0f * uniform(rng);
    phaseY[i] = 3.0f * uniform(rng);
  }
  std::vector<float> coefficients(size_t(layers) * texels * o.channels, 0.0f);
  for (uint32_t layer = 0; layer < layers; ++layer) {
    const int l = static_cast<int>(std::sqrt(float(layer)));
    const float bandScale = 0.25f / float(1 + l);
    for (uint32_t t = 0; t < texels; ++t) {
      if (f.texelKinds[t] != kTexelSample) continue;
      const float x = float(t % o.width), y = float(t / o.width);
      for (uint32_t c = 0; c < o.channels; ++c) {
        float value = 0.0f;
        if (isThroughputChannel(o, c)) {
          if (o.constantThroughput >= 0.0f) value = layer == 0 ? o.constantThroughput / kY0 : 0.0f;
          else if (layer == 0) value = (0.7f + 0.35f * std::sin(0.23f * x + 0.19f * y)) / kY0;
          else value = 0.3f * bandScale * std::sin(0.37f * x + 1.3f * float(layer)) * std::cos(0.29f * y);
        } else {
          const size_t k = size_t(layer) * 4 + c;
          value = bandScale * amplitude[k] * (1.0f + 0.5f * std::sin(0.31f * x + phaseX[k]) * std::cos(0.27f * y + phaseY[k]));
          // Band 0 carries the dominant direction (into the sphere) and a positive optical depth.
          if (layer == 0) value += c < 3 ? 3.0f * directions[size_t(t) * 3 + c] : 2.0f + 0.5f * std::sin(0.2f * x);
        }
        coefficients[(size_t(layer) * texels + t) * o.channels + c] = value;
      }
    }
  }
  return coefficients;
}

// Table and Pca: per (layer, role) an amplitude and two phases, role 0..2 the direction, 3 tau,
// 4 the throughput (drawn whether or not the field has the channel: see the top of this file).
struct SyntheticNoise {
  std::vector<float> amplitude, phaseX, phaseY;
  SyntheticNoise(uint32_t layers, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    for (size_t i = 0; i < size_t(layers) * 5; ++i) {
      amplitude.push_back(uniform(rng));
      phaseX.push_back(3.0f * uniform(rng));
      phaseY.push_back(3.0f * uniform(rng));
    }
  }
  // A smooth function of the texel (x, y) with the amplitude of (layer, role), in [-1.5, 1.5].
  float at(uint32_t layer, uint32_t role, float x, float y) const {
    const size_t k = size_t(layer) * 5 + role;
    return amplitude[k] * (1.0f + 0.5f * std::sin(0.31f * x + phaseX[k]) * std::cos(0.27f * y + phaseY[k]));
  }
};

// The role (0..2 direction, 3 tau, 4 throughput) of channel c.
inline uint32_t syntheticRole(const SyntheticFieldOptions& o, uint32_t c) { return isThroughputChannel(o, c) ? 4 : c; }

// Table: every node near the direction into the sphere, tau near 2, throughput near 0.7 (or the
// constant), with noise that differs between nodes so that the decoded value follows the eye.
inline std::vector<float> syntheticTableCoefficients(const SyntheticFieldOptions& o, const Field& f,
                                                     const std::vector<float>& directions) {
  const uint32_t texels = o.width * o.height, layers = f.layerCount();
  const SyntheticNoise noise(layers, o.seed);
  std::vector<float> coefficients(size_t(layers) * texels * o.channels, 0.0f);
  for (uint32_t node = 0; node < layers; ++node)
    for (uint32_t t = 0; t < texels; ++t) {
      if (f.texelKinds[t] != kTexelSample) continue;
      const float x = float(t % o.width), y = float(t / o.width);
      for (uint32_t c = 0; c < o.channels; ++c) {
        const uint32_t role = syntheticRole(o, c);
        const float n = noise.at(node, role, x, y);
        const float flip = o.jumps && node % 5 == 2 ? -1.0f : 1.0f;
        float value = role < 3 ? flip * 3.0f * directions[size_t(t) * 3 + role] + 0.6f * n
                      : role == 3 ? 2.0f + 0.5f * std::sin(0.2f * x) + 0.3f * n
                      : o.constantThroughput >= 0.0f ? o.constantThroughput
                                                     : 0.7f + 0.45f * n;
        coefficients[(size_t(node) * texels + t) * o.channels + c] = value;
      }
    }
  return coefficients;
}

// Pca: component 0 a mean (weight 1; basis: small direction, tau near 2, throughput near
// 0.7 or the constant), components 1..3 the axes weighted by 3 x the direction into the sphere,
// the others random; every basis function has per-node noise. Fills f.basis; returns the weights.
inline std::vector<float> syntheticPcaCoefficients(const SyntheticFieldOptions& o, Field& f,
                                                   const std::vector<float>& directions) {
  const uint32_t texels = o.width * o.height, nodes = o.tableSize * o.tableSize;
  const SyntheticNoise noise(o.components, o.seed);
  const SyntheticNoise basisNoise(o.components * nodes, o.seed + 1000);
  f.basis.assign(size_t(o.components) * nodes * o.channels, 0.0f);
  for (uint32_t k = 0; k < o.components; ++k)
    for (uint32_t n = 0; n < nodes; ++n)
      for (uint32_t c = 0; c < o.channels; ++c) {
        const uint32_t role = syntheticRole(o, c);
        const float r = basisNoise.amplitude[(size_t(k) * nodes + n) * 5 + role];
        const float axis = o.jumps && n % 5 == 2 ? -1.0f : 1.0f;
        float value = k == 0 ? (role < 3 ? 0.3f * r : role == 3 ? 2.0f + 0.3f * r : 0.7f + 0.2f * r)
                      : k < 4 ? (role == k - 1 ? axis : 0.0f) + 0.2f * r
                              : 0.5f * r;
        if (role == 4 && o.constantThroughput >= 0.0f) value = k == 0 ? o.constantThroughput : 0.0f;
        f.basis[(size_t(k) * nodes + n) * o.channels + c] = value;
      }
  std::vector<float> weights(size_t(o.components) * texels, 0.0f);
  for (uint32_t k = 0; k < o.components; ++k)
    for (uint32_t t = 0; t < texels; ++t) {
      if (f.texelKinds[t] != kTexelSample) continue;
      const float x = float(t % o.width), y = float(t / o.width);
      // The mean's weight is exactly 1 (U8: a zero-range layer decodes to its bias), so that a
      // constant throughput decodes to the constant.
      weights[size_t(k) * texels + t] = k == 0  ? 1.0f
                                        : k < 4 ? 3.0f * directions[size_t(t) * 3 + k - 1]
                                                : 0.3f * noise.at(k, 0, x, y);
    }
  return weights;
}

// Appends the jump distance channel to the coefficients (Table) or the basis (Pca) built for
// o.channels: in grid cells times kJumpDistanceScale / (N - 1), as the bake stores it.
inline std::vector<float> withJumpDistance(const SyntheticFieldOptions& o, Field& f, const std::vector<float>& in) {
  const uint32_t from = o.channels, to = o.channels + 1, nodes = o.tableSize * o.tableSize;
  const float unit = gpu::kJumpDistanceScale / float(o.tableSize - 1);
  f.channels = to;
  f.jumpDistance = f.settings.jumpDistance = true;
  auto widen = [&](const std::vector<float>& v, auto distance) {
    std::vector<float> out(v.size() / from * to);
    for (size_t i = 0; i < v.size() / from; ++i) {
      std::copy(&v[i * from], &v[i * from] + from, &out[i * to]);
      out[i * to + from] = unit * distance(i);
    }
    return out;
  };
  if (o.encoding == Encoding::Pca) {  // the mean component carries it; the others add a little
    f.basis = widen(f.basis, [&](size_t i) {
      const size_t k = i / nodes, n = i % nodes;
      return k == 0 ? 0.5f + 0.4f * std::sin(1.3f * float(n)) : 0.05f * std::sin(0.7f * float(k) + 0.9f * float(n));
    });
    return in;
  }
  const uint32_t texels = o.width * o.height;
  return widen(in, [&](size_t i) {
    const size_t node = i / texels, t = i % texels;
    return 0.5f + 0.4f * std::sin(1.7f * float(node) + 0.3f * float(t % o.width) + 0.2f * float(t / o.width));
  });
}

// Pca, clustered: replaces f.basis (built with `weights`) by K tables as SyntheticFieldOptions::
// clustered says, and returns each texel's index (0 where no sample is).
inline std::vector<float> clusteredCoefficients(const SyntheticFieldOptions& o, Field& f,
                                                const std::vector<float>& weights,
                                                const std::vector<float>& directions) {
  const uint32_t texels = o.width * o.height;
  const size_t table = size_t(o.tableSize) * o.tableSize * f.channels;
  std::vector<uint32_t> samples;
  for (uint32_t t = 0; t < texels; ++t)
    if (f.texelKinds[t] == kTexelSample) samples.push_back(t);
  std::vector<uint32_t> representative(o.components);
  std::vector<float> tables(o.components * table, 0.0f);
  for (uint32_t j = 0; j < o.components; ++j) {
    representative[j] = samples[size_t(j) * samples.size() / o.components];
    for (uint32_t k = 0; k < o.components; ++k)
      for (size_t i = 0; i < table; ++i)
        tables[j * table + i] += weights[size_t(k) * texels + representative[j]] * f.basis[k * table + i];
  }
  f.basis = std::move(tables);
  f.clustered = true;
  std::vector<float> index(texels, 0.0f);
  for (uint32_t t : samples) {
    float best = -2.0f;
    for (uint32_t j = 0; j < o.components; ++j) {
      const float* a = &directions[size_t(t) * 3];
      const float* b = &directions[size_t(representative[j]) * 3];
      const float d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
      if (d > best) {
        best = d;
        index[t] = float(j);
      }
    }
  }
  return index;
}

// A Volume field's grid for the sphere the band lies on: exact distances (in voxels, clamped to the
// band) and outward normals at the voxel centres, the sphere's box plus 2 voxels on every side.
inline FieldVolume syntheticSphereVolume(const SyntheticFieldOptions& o) {
  FieldVolume v;
  v.size = o.volumeSize;
  v.spacing = 2.0f * o.radius / float(o.volumeSize - 5);
  for (int k = 0; k < 3; ++k) v.origin[size_t(k)] = o.center[size_t(k)] - 0.5f * float(o.volumeSize - 1) * v.spacing;
  const uint32_t n = o.volumeSize;
  std::vector<uint32_t> dense(size_t(n) * n * n);
  for (uint32_t z = 0; z < n; ++z)
    for (uint32_t y = 0; y < n; ++y)
      for (uint32_t x = 0; x < n; ++x) {
        const float p[3] = {v.origin[0] + v.spacing * float(x) - o.center[0],
                            v.origin[1] + v.spacing * float(y) - o.center[1],
                            v.origin[2] + v.spacing * float(z) - o.center[2]};
        const float r = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        const std::array<float, 3> normal = r > 0.0f ? std::array<float, 3>{p[0] / r, p[1] / r, p[2] / r}
                                                     : std::array<float, 3>{0.0f, 0.0f, 1.0f};
        dense[(size_t(z) * n + y) * n + x] = packVolumeVoxel((r - o.radius) / v.spacing, normal);
      }
  setVolumeVoxels(v, dense);
  return v;
}

inline Field makeSyntheticField(const SyntheticFieldOptions& o) {
  Field f;
  f.width = o.width;
  f.height = o.height;
  f.encoding = o.encoding;
  f.order = o.encoding == Encoding::Sh ? o.order : 0;
  f.tableSize = o.encoding == Encoding::Sh || o.encoding == Encoding::Volume ? 0 : o.tableSize;
  f.components = o.encoding == Encoding::Pca ? o.components : 0;
  f.channels = o.channels;
  f.throughput = o.throughput;
  f.quantization = o.quantization;
  f.settings.order = f.order;
  f.settings.encoding = f.encoding;
  f.settings.tableSize = f.tableSize;
  f.settings.components = f.components;
  f.settings.throughput = f.throughput;
  f.settings.quantization = o.quantization;
  f.settings.source = "synthetic";
  f.settings.pathRule = o.pathRule;
  f.sampleFrameExits = o.sampleFrameExits;
  f.settings.exitFrame = o.sampleFrameExits ? ExitFrame::Sample : ExitFrame::Object;
  if (o.nodeSampled) f.settings.directionSampling = DirectionSampling::Nodes;
  f.media.push_back(FieldMedium{"air", 1.0f, 0.0f, {1.0f, 1.0f, 1.0f}});
  f.media.push_back(FieldMedium{"glass", o.frontIor, syntheticHasTau(o) ? 0.5f : 0.0f, {1.0f, 1.0f, 1.0f}});

  const uint32_t texels = o.width * o.height;
  f.texelKinds.assign(texels, kTexelSample);
  f.frames.assign(size_t(texels) * 12, 0.0f);
  std::vector<float> directions(size_t(texels) * 3);
  for (uint32_t y = 0; y < o.height; ++y)
    for (uint32_t x = 0; x < o.width; ++x) {
      const uint32_t t = y * o.width + x;
      if (o.emptyAndGutters && x == o.width - 1) {
        f.texelKinds[t] = kTexelEmpty;
        continue;
      }
      if (o.emptyAndGutters && y == o.height - 1) {
        f.texelKinds[t] = kTexelGutter;
        continue;
      }
      float p[3], n[3];
      bandPoint(o, (float(x) + 0.5f) / float(o.width), (float(y) + 0.5f) / float(o.height), p, n);
      // Duff et al. orthonormal basis around n.
      const float sign = std::copysign(1.0f, n[2]);
      const float a = -1.0f / (sign + n[2]);
      const float b = n[0] * n[1] * a;
      const float tangent[3] = {1.0f + sign * n[0] * n[0] * a, sign * b, -sign * n[0]};
      const float bitangent[3] = {b, sign + n[1] * n[1] * a, -n[1]};
      const float* axes[3] = {tangent, bitangent, n};
      for (int r = 0; r < 3; ++r) {
        float* row = &f.frames[size_t(t) * 12 + size_t(r) * 4];
        for (int k = 0; k < 3; ++k) row[k] = axes[r][k];
        row[3] = -(axes[r][0] * p[0] + axes[r][1] * p[1] + axes[r][2] * p[2]);
      }
      for (int k = 0; k < 3; ++k) directions[size_t(t) * 3 + size_t(k)] = -n[k];
    }
  if (o.texelScatter > 0.0f) {  // its own generator: the coefficients' draws stay as they were
    std::mt19937 rng(o.seed + 7919u);
    std::uniform_real_distribution<float> uniform(-o.texelScatter, o.texelScatter);
    for (uint32_t t = 0; t < texels; ++t)
      for (uint32_t k = 0; k < 3; ++k) {
        const float move = uniform(rng);  // drawn for every texel, so that a block's moves do not depend on the others
        if ((t % o.width) / 4 % 2 == 1) directions[size_t(t) * 3 + k] += move;
      }
  }
  if (o.emptyAndGutters)
    for (uint32_t x = 0; x + 2 < o.width; ++x) {
      const uint32_t y = o.height - 1;
      f.gutters.push_back(GutterTexel{y * o.width + x, (y - 1) * o.width + x, (y - 1) * o.width + x + 1,
                                      (y - 2) * o.width + x + 1});
    }
  if (o.emptyAndGutters) {
    // The last row's texel at x = width - 2 has no rule in the loop above (x + 1 is empty).
    const uint32_t y = o.height - 1, x = o.width - 2;
    f.gutters.push_back(GutterTexel{y * o.width + x, (y - 1) * o.width + x, (y - 1) * o.width + x - 1,
                                    (y - 2) * o.width + x - 1});
  }

  if (o.encoding == Encoding::Volume) {
    f.volume = syntheticSphereVolume(o);
    f.settings.volumeSize = o.volumeSize;
  } else {
    std::vector<float> coefficients = o.encoding == Encoding::Sh      ? syntheticShCoefficients(o, f, directions)
                                      : o.encoding == Encoding::Table ? syntheticTableCoefficients(o, f, directions)
                                                                      : syntheticPcaCoefficients(o, f, directions);
    if (o.jumpDistance) coefficients = withJumpDistance(o, f, coefficients);
    if (o.clustered) coefficients = clusteredCoefficients(o, f, coefficients, directions);
    (void)encodeCoefficients(f, coefficients);
  }

  // Render mesh: the band as (segments) x (segments / 2) quads, atlas coordinates at the corners.
  const uint32_t nu = o.meshSegments, nv = std::max(1u, o.meshSegments / 2);
  const float uMax = o.emptyAndGutters ? float(o.width - 1) / float(o.width) : 1.0f;
  const float vMax = o.emptyAndGutters ? float(o.height - 1) / float(o.height) : 1.0f;
  for (uint32_t j = 0; j <= nv; ++j)
    for (uint32_t i = 0; i <= nu; ++i) {
      const float u = uMax * float(i) / float(nu), v = vMax * float(j) / float(nv);
      float p[3], n[3];
      bandPoint(o, u, v, p, n);
      f.mesh.positions.insert(f.mesh.positions.end(), {p[0], p[1], p[2]});
      f.mesh.normals.insert(f.mesh.normals.end(), {n[0], n[1], n[2]});
      f.mesh.uvs.insert(f.mesh.uvs.end(), {u, v});
      f.mesh.frontIor.push_back(o.frontIor);
    }
  for (uint32_t j = 0; j < nv; ++j)
    for (uint32_t i = 0; i < nu; ++i) {
      const uint32_t a = j * (nu + 1) + i, b = a + 1, c = a + nu + 1, d = c + 1;
      // Counter-clockwise seen from outside: v grows downward (theta), u grows toward +X from +Z.
      f.mesh.indices.insert(f.mesh.indices.end(), {a, c, b, b, c, d});
    }
  return f;
}

}  // namespace shrefract::testing
