// Decoding one sample of a field on the CPU: the hemi-octahedral grid of the Table and Pca
// encodings and the linear sum every encoding reduces to (field.h). The compute shaders mirror
// these operations (spirv/shaders), the bake measures its fits with them and the CPU reference
// (cpu_reference.cpp) builds on evaluateSample.
#include <shrefract/field.h>
#include <shrefract/sh.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace shrefract {

HemiOctCoordinates hemiOctFromDirection(float x, float y, float z) {
  z = std::max(z, 0.0f);
  const float l1 = std::fabs(x) + std::fabs(y) + z;
  if (!(l1 > 0.0f)) return {};  // no direction: the pole, as the SH path uses +z
  const float px = x / l1, py = y / l1;
  return {std::clamp((px + py + 1.0f) * 0.5f, 0.0f, 1.0f), std::clamp((px - py + 1.0f) * 0.5f, 0.0f, 1.0f)};
}

std::array<float, 3> hemiOctDirection(uint32_t i, uint32_t j, uint32_t n) {
  const float a = 2.0f * float(i) / float(n - 1) - 1.0f;  // p.x + p.y
  const float b = 2.0f * float(j) / float(n - 1) - 1.0f;  // p.x - p.y
  const float px = 0.5f * (a + b), py = 0.5f * (a - b);
  const float pz = std::max(0.0f, 1.0f - std::fabs(px) - std::fabs(py));
  const float len = std::sqrt(px * px + py * py + pz * pz);
  return {px / len, py / len, pz / len};
}

HemiOctBilinear hemiOctBilinear(float x, float y, float z, uint32_t n) {
  const HemiOctCoordinates uv = hemiOctFromDirection(x, y, z);
  const float last = float(n - 1);
  const float fx = uv.u * last, fy = uv.v * last;
  // The cell's lower corner; the top row and column belong to the cell below them.
  const uint32_t i = std::min(static_cast<uint32_t>(fx), n - 2), j = std::min(static_cast<uint32_t>(fy), n - 2);
  const float tx = fx - float(i), ty = fy - float(j);
  HemiOctBilinear b;
  b.node = {j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1};
  b.weight = {(1.0f - tx) * (1.0f - ty), tx * (1.0f - ty), (1.0f - tx) * ty, tx * ty};
  return b;
}

void evaluateCoefficients(const EncodingShape& shape, const float* a, const float* basis,
                          const std::array<float, 3>& w, float* out) {
  const uint32_t channels = shape.channels;
  std::fill(out, out + channels, 0.0f);
  const float z = std::max(w[2], 0.0f);
  if (shape.encoding == Encoding::Sh) {
    const int order = static_cast<int>(shape.order);
    thread_local std::vector<float> y;
    y.resize(static_cast<size_t>(sh::basisCount(order)));
    sh::evaluate(order, w[0], w[1], z, y.data());
    for (uint32_t i = 0; i < shape.layerCount(); ++i)
      for (uint32_t c = 0; c < channels; ++c) out[c] += a[size_t(i) * channels + c] * y[i];
    return;
  }
  const uint32_t n = shape.tableSize;
  const HemiOctBilinear b = hemiOctBilinear(w[0], w[1], z, n);
  if (shape.encoding == Encoding::Table) {
    for (int j = 0; j < 4; ++j)
      for (uint32_t c = 0; c < channels; ++c) out[c] += b.weight[j] * a[size_t(b.node[j]) * channels + c];
    return;
  }
  // Pca: the weights times the basis functions, each a table blended at the same four nodes.
  const size_t nodes = size_t(n) * n;
  for (uint32_t k = 0; k < shape.components; ++k)
    for (int j = 0; j < 4; ++j) {
      const float* f = &basis[(k * nodes + b.node[j]) * channels];
      for (uint32_t c = 0; c < channels; ++c) out[c] += a[k] * b.weight[j] * f[c];
    }
}

void evaluateSample(const Field& field, uint64_t texel, const std::array<float, 3>& w, float* out, uint32_t order) {
  EncodingShape shape = field.shape();
  if (shape.encoding == Encoding::Sh) shape.order = std::min(shape.order, order);
  const uint32_t layers = shape.layerCount(), values = shape.valuesPerLayer();
  thread_local std::vector<float> a;
  a.resize(size_t(layers) * values);
  for (uint32_t i = 0; i < layers; ++i)
    for (uint32_t v = 0; v < values; ++v) a[size_t(i) * values + v] = fieldCoefficient(field, i, texel, v);
  evaluateCoefficients(shape, a.data(), field.basis.data(), w, out);
}

}  // namespace shrefract
