// Hand-made fields for the stability tests (CPU: stability_field_test.cpp, GPU:
// stability_gpu_test.cpp), built on the synthetic sphere band of tests/engine/synthetic_field.h:
//  - zero-range channels: (layer, channel) pairs whose value is the same in every texel, so U8
//    stores scale 0 and the decode must give the bias exactly;
//  - direction sums of zero and near-zero length, around the kMinDirectionLength2 rule of
//    gpu_layout.h (a sum with |s.xyz|^2 <= 1e-20 decodes to the zero vector, and the raster pass
//    then uses the view direction);
//  - coefficients at the largest magnitude validateField accepts.
#pragma once

#include <shrefract/cpu_reference.h>
#include <shrefract/field.h>
#include <shrefract/sh.h>

#include <algorithm>
#include <cmath>
#include <tuple>
#include <vector>

#include "engine/synthetic_field.h"

namespace shrefract::stability {

// Eyes around the synthetic band (centre at the origin, radius 1): in front, to the side, above.
inline std::vector<reference::Vec3> testEyes() { return {{0.3f, 0.5f, 4.0f}, {4.0f, 0.2f, 0.0f}, {0.5f, 3.0f, 0.5f}}; }

inline Camera bandCamera() {
  Camera c;
  c.eye = {0.3f, 0.5f, 4.0f};
  c.target = {0.0f, 0.0f, 0.0f};
  c.verticalFovDegrees = 40.0f;
  return c;
}

// All coefficients of a field as floats, in the quantized arrays' order.
inline std::vector<float> decodedCoefficients(const Field& f) {
  std::vector<float> out(size_t(f.basisCount()) * f.texelCount() * f.channels);
  for (uint32_t layer = 0; layer < f.basisCount(); ++layer)
    for (uint64_t t = 0; t < f.texelCount(); ++t)
      for (uint32_t c = 0; c < f.channels; ++c)
        out[(size_t(layer) * f.texelCount() + t) * f.channels + c] = fieldCoefficient(f, layer, t, c);
  return out;
}

inline float& coefficientAt(std::vector<float>& c, const Field& f, uint32_t layer, uint64_t texel, uint32_t channel) {
  return c[(size_t(layer) * f.texelCount() + texel) * f.channels + channel];
}

struct ZeroRangeField {
  Field field;
  std::vector<std::tuple<uint32_t, uint32_t, float>> constants;  // (layer, channel, value)
};

// The synthetic band (order 2, four channels, empty and gutter texels) with five (layer, channel)
// pairs made constant: the optical depth's DC term and every higher tau layer (so tau is the same
// everywhere), a zero and a negative constant in direction layers.
inline ZeroRangeField makeZeroRangeField(Quantization q) {
  testing::SyntheticFieldOptions o;
  o.order = 2;
  o.quantization = q;
  o.channels = 4;
  o.emptyAndGutters = true;
  ZeroRangeField z;
  z.field = testing::makeSyntheticField(o);
  z.constants = {{0, 3, 1.25f}, {1, 0, 0.0f}, {4, 1, -0.5f}, {8, 2, 0.0f}};
  for (uint32_t layer = 1; layer < z.field.basisCount(); ++layer) z.constants.emplace_back(layer, 3, 0.0f);
  std::vector<float> c = decodedCoefficients(z.field);
  for (const auto& [layer, channel, value] : z.constants)
    for (uint64_t t = 0; t < z.field.texelCount(); ++t) coefficientAt(c, z.field, layer, t, channel) = value;
  (void)encodeCoefficients(z.field, c);
  return z;
}

// Texel classes of makeNearZeroField.
enum NearZeroKind : uint8_t {
  kZeroSum = 0,         // every xyz coefficient is 0: the sum is exactly zero -> zero vector
  kTinySum = 1,         // only the DC term, at the smallest binary16 subnormal (6e-8): normalized
  kCancellingSum = 2,   // DC and the l = 1, m = 0 term cancel at the eye to a few binary16 steps
  kRegular = 3,         // unchanged synthetic data
};

struct NearZeroField {
  Field field;
  std::vector<uint8_t> kind;  // per texel (meaningful for sample texels)
  reference::Vec3 eye{};
  Camera camera;
};

// F16 (no shared scale: every texel's values are its own). Texel t of the band gets class t % 4.
inline NearZeroField makeNearZeroField() {
  testing::SyntheticFieldOptions o;
  o.order = 2;
  o.quantization = Quantization::F16;
  o.channels = 4;
  NearZeroField z;
  z.field = testing::makeSyntheticField(o);
  z.camera = bandCamera();
  z.eye = z.camera.eye;
  z.kind.assign(z.field.texelCount(), kRegular);
  std::vector<float> c = decodedCoefficients(z.field);
  const float tinyHalf = std::ldexp(1.0f, -24);  // the smallest binary16 subnormal
  for (uint64_t t = 0; t < z.field.texelCount(); ++t) {
    if (z.field.texelKinds[t] != kTexelSample) continue;
    const auto kind = static_cast<NearZeroKind>(t % 4);
    z.kind[t] = kind;
    if (kind == kRegular) continue;
    for (uint32_t layer = 0; layer < z.field.basisCount(); ++layer)
      for (uint32_t ch = 0; ch < 3; ++ch) coefficientAt(c, z.field, layer, t, ch) = 0.0f;
    if (kind == kTinySum) {
      coefficientAt(c, z.field, 0, t, 0) = tinyHalf;
    } else if (kind == kCancellingSum) {
      // w as the decompression computes it, then c2 = -c0 Y0 / Y2(w) (rounded to binary16).
      const float* m = &z.field.frames[t * 12];
      float w[3];
      for (int k = 0; k < 3; ++k)
        w[k] = m[4 * k] * z.eye[0] + m[4 * k + 1] * z.eye[1] + m[4 * k + 2] * z.eye[2] + m[4 * k + 3];
      w[2] = std::max(w[2], 0.0f);
      float y[9];
      sh::evaluate(2, w[0], w[1], w[2], y);
      if (std::fabs(y[2]) < 0.05f) {  // the eye is near this sample's horizon: nothing to cancel
        z.kind[t] = kZeroSum;
        continue;
      }
      for (uint32_t ch = 0; ch < 3; ++ch) {
        const float c0 = 0.5f + 0.25f * float(ch);
        coefficientAt(c, z.field, 0, t, ch) = c0;
        coefficientAt(c, z.field, 2, t, ch) = -c0 * y[0] / y[2];
      }
    }
  }
  (void)encodeCoefficients(z.field, c);
  return z;
}

// A U8 field whose direction layers all decode to the constant `value`: with value = 1e-11 the
// sum of order 0 is 2.8e-12 per component, |s|^2 = 2.4e-23 <= 1e-20: every sample texel decodes to
// the zero vector (a sum below the threshold that is not exactly zero).
inline Field makeConstantDirectionField(float value) {
  testing::SyntheticFieldOptions o;
  o.order = 0;
  o.quantization = Quantization::U8;
  o.channels = 4;
  Field f = testing::makeSyntheticField(o);
  std::vector<float> c = decodedCoefficients(f);
  for (uint64_t t = 0; t < f.texelCount(); ++t)
    for (uint32_t ch = 0; ch < 3; ++ch) coefficientAt(c, f, 0, t, ch) = value;
  (void)encodeCoefficients(f, c);
  return f;
}

// A U8 field of the given order whose every (layer, channel) decodes to `magnitude` (scale 0,
// bias = magnitude), alternating in sign by layer for tau: the largest sums the tables can express.
inline Field makeHugeField(uint32_t order, float magnitude) {
  testing::SyntheticFieldOptions o;
  o.order = order;
  o.quantization = Quantization::U8;
  o.channels = 4;
  Field f = testing::makeSyntheticField(o);
  for (uint32_t layer = 0; layer < f.basisCount(); ++layer)
    for (uint32_t ch = 0; ch < 4; ++ch) {
      const size_t k = size_t(layer) * 4 + ch;
      f.scale[k] = 0.0f;
      f.bias[k] = (ch == 3 && layer % 2 == 1) ? -magnitude : magnitude;
    }
  return f;
}

}  // namespace shrefract::stability
