// The float (unquantized) form of a sample's encoded functions, for the bake's own measurements:
// the same sums as evaluateSample (field.h) on coefficients that have not been quantized yet.
#pragma once

#include <shrefract/bake/fit.h>
#include <shrefract/field.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace shrefract::bake {

struct EncodingModel {
  Encoding encoding = Encoding::Sh;
  int order = 0;
  uint32_t tableSize = 0;
  uint32_t components = 0;
  uint32_t channels = 3;
  const std::vector<float>* basis = nullptr;  // Pca

  uint32_t layers() const {
    return encoding == Encoding::Sh ? uint32_t((order + 1) * (order + 1))
                                    : encoding == Encoding::Table ? tableSize * tableSize : components;
  }
  uint32_t values() const { return encoding == Encoding::Pca ? 1u : channels; }
  size_t stride() const { return size_t(layers()) * values(); }
};

// out[c] for c < channels at local direction w (z clamped to >= 0, as the engine does).
inline void decodeFloat(const EncodingModel& m, const float* coeffs, glm::vec3 w, float* out) {
  if (m.encoding == Encoding::Sh) {
    evaluateExpansion(m.order, coeffs, m.channels, w, out);
    return;
  }
  for (uint32_t c = 0; c < m.channels; ++c) out[c] = 0.0f;
  const HemiOctBilinear b = hemiOctBilinear(w.x, w.y, w.z, m.tableSize);
  if (m.encoding == Encoding::Table) {
    for (int j = 0; j < 4; ++j)
      for (uint32_t c = 0; c < m.channels; ++c) out[c] += b.weight[j] * coeffs[size_t(b.node[j]) * m.channels + c];
    return;
  }
  const size_t nodes = size_t(m.tableSize) * m.tableSize;
  for (uint32_t k = 0; k < m.components; ++k)
    for (int j = 0; j < 4; ++j) {
      const float* f = &(*m.basis)[(k * nodes + b.node[j]) * m.channels];
      for (uint32_t c = 0; c < m.channels; ++c) out[c] += coeffs[k] * b.weight[j] * f[c];
    }
}

}  // namespace shrefract::bake
