// The coefficients of a field (docs/field-format.md, "Dequantizing" and "How the encoder
// quantizes"): reading one back, and encoding float coefficients as u8, binary16 or cluster indices.
#include <shrefract/field.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "core/half.h"
#include "field/field_file.h"
#include "field/field_validation.h"

namespace shrefract {
using namespace fieldfile;  // the layout and helpers every part of the format shares (field_file.h)

float fieldCoefficient(const Field& field, uint32_t layer, uint64_t texel, uint32_t value) {
  if (field.clustered) return static_cast<float>(field.clusterIndices[texel]);
  const uint32_t values = field.valuesPerLayer();
  const size_t index = static_cast<size_t>((uint64_t(layer) * field.texelCount() + texel) * values + value);
  if (field.quantization == Quantization::F16) return halfToFloat(field.coefficientsF16[index]);
  const size_t table = size_t(layer) * values + value;
  return field.bias[table] + field.scale[table] * (static_cast<float>(field.coefficientsU8[index]) / 255.0f);
}

namespace {

// What encodeCoefficients needs of the field before it reads a coefficient. A clustered field's
// tables are stored as binary16: they are rounded first, so that the checks read what is stored.
Result<void> checkEncodable(Field& field) {
  if (field.clustered)
    for (float& v : field.basis) v = halfToFloat(floatToHalf(v));
  if (auto r = validateEncoding(field); !r)
    return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: " + r.error().message);
  if (field.width > kMaxAtlasSize || field.height > kMaxAtlasSize)
    return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: order " + std::to_string(field.order) + " or atlas " +
                                                     std::to_string(field.width) + "x" + std::to_string(field.height) +
                                                     " beyond the format's limits");
  if (field.quantization != Quantization::U8 && field.quantization != Quantization::F16)
    return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: unknown quantization " +
                                                     std::to_string(static_cast<uint32_t>(field.quantization)));
  return {};
}

}  // namespace

Result<void> encodeCoefficients(Field& field, const std::vector<float>& coefficients) {
  if (auto r = checkEncodable(field); !r) return r;
  const uint64_t values = field.valuesPerLayer(), perLayer = field.texelCount() * values;
  const uint64_t count = perLayer * field.layerCount();
  if (coefficients.size() != count)
    return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: " + std::to_string(coefficients.size()) +
                                                     " coefficients, expected " + std::to_string(count) +
                                                     " (layers x texels x values)");
  const float* data = coefficients.data();
  return encodeCoefficients(field, [data, values](uint64_t t) { return data + t * values; }, perLayer);
}

namespace {

// The coefficients encodeCoefficients reads: value c of layer `layer` at texel t, zero for a texel
// without values. Every loop over them below visits them in the quantized arrays' order (layers x
// texels x values); i is the index there.
struct CoefficientSource {
  std::vector<const float*> rows;  // per texel
  uint64_t layerStride = 0;
  uint32_t layers = 0;
  uint64_t texels = 0;
  uint32_t channels = 0;  // the stored values per layer (Pca: one weight)

  float value(uint32_t layer, uint64_t t, uint32_t c) const {
    return rows[t] ? rows[t][layer * layerStride + c] : 0.0f;
  }
};

// Every coefficient finite, within the format's magnitude and, for F16, the half-float range.
Result<void> checkCoefficients(const Field& field, const CoefficientSource& src) {
  for (size_t i = 0, layer = 0; layer < src.layers; ++layer)
    for (uint64_t t = 0; t < src.texels; ++t)
      for (uint32_t c = 0; c < src.channels; ++c, ++i) {
        const float v = src.value(uint32_t(layer), t, c);
        const auto refuse = [&](const std::string& why) {
          return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: coefficient " + std::to_string(i) +
                                                           " (layer " + std::to_string(layer) + ", channel " +
                                                           std::to_string(c) + ")" + why);
        };
        if (!std::isfinite(v)) return refuse(" is not finite");
        if (!(std::fabs(v) <= kMaxCoefficientMagnitude))
          return refuse(" = " + formatFloat(v) + " is beyond +-" + formatFloat(kMaxCoefficientMagnitude));
        if (field.quantization == Quantization::F16 && !(std::fabs(v) < kHalfOverflow))
          return refuse(" = " + formatFloat(v) + " is beyond the half-float range (|v| < 65520)");
      }
  return {};
}

void encodeF16(Field& field, const CoefficientSource& src) {
  std::vector<uint16_t> out(size_t(src.layers) * src.texels * src.channels);
  for (size_t i = 0, layer = 0; layer < src.layers; ++layer)
    for (uint64_t t = 0; t < src.texels; ++t)
      for (uint32_t c = 0; c < src.channels; ++c) out[i++] = floatToHalf(src.value(uint32_t(layer), t, c));
  field.coefficientsF16 = std::move(out);
  field.coefficientsU8.clear();
  field.scale.clear();
  field.bias.clear();
}

// U8: per (layer, channel) range over all texels, into `scale` and `bias`. The range is taken in
// double so that a span wider than float can be reported instead of turning into Inf.
Result<void> u8Ranges(const CoefficientSource& src, std::vector<float>& scale, std::vector<float>& bias) {
  const size_t tables = size_t(src.layers) * src.channels;
  scale.assign(tables, 0.0f);
  bias.assign(tables, 0.0f);
  for (uint32_t layer = 0; layer < src.layers; ++layer) {
    for (uint32_t c = 0; c < src.channels; ++c) {
      float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
      for (uint64_t t = 0; t < src.texels; ++t) {
        const float v = src.value(layer, t, c);
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
      const float range = static_cast<float>(static_cast<double>(hi) - static_cast<double>(lo));
      if (!std::isfinite(range) || !std::isfinite(lo + range))
        return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: layer " + std::to_string(layer) + " channel " +
                                                         std::to_string(c) + ": range [" + formatFloat(lo) + ", " +
                                                         formatFloat(hi) + "] does not fit a float scale");
      scale[size_t(layer) * src.channels + c] = range;
      bias[size_t(layer) * src.channels + c] = lo;
    }
  }
  return {};
}

Result<void> encodeU8(Field& field, const CoefficientSource& src) {
  std::vector<float> scale, bias;
  if (auto r = u8Ranges(src, scale, bias); !r) return r;
  std::vector<uint8_t> out(size_t(src.layers) * src.texels * src.channels);
  for (size_t i = 0, layer = 0; layer < src.layers; ++layer)
    for (uint64_t t = 0; t < src.texels; ++t)
      for (uint32_t c = 0; c < src.channels; ++c, ++i) {
        const size_t table = layer * src.channels + c;
        if (scale[table] == 0.0f) {
          out[i] = 0;
          continue;
        }
        const double level = (static_cast<double>(src.value(uint32_t(layer), t, c)) - static_cast<double>(bias[table])) /
                             static_cast<double>(scale[table]) * 255.0;
        out[i] = static_cast<uint8_t>(std::clamp(std::floor(level + 0.5), 0.0, 255.0));
      }
  field.coefficientsU8 = std::move(out);
  field.scale = std::move(scale);
  field.bias = std::move(bias);
  field.coefficientsF16.clear();
  return {};
}

// A clustered field: each texel's one value is its function's index, stored exactly.
Result<void> encodeIndices(Field& field, const CoefficientSource& src) {
  std::vector<uint16_t> out(src.texels);
  for (uint64_t t = 0; t < src.texels; ++t) {
    const float v = src.value(0, t, 0);
    if (!(v >= 0.0f && v < float(field.components) && v == std::floor(v)))
      return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: texel " + std::to_string(t) + "'s value " +
                                                       formatFloat(v) + " is not a function index below " +
                                                       std::to_string(field.components));
    out[t] = static_cast<uint16_t>(v);
  }
  field.clusterIndices = std::move(out);
  field.coefficientsU8.clear();
  field.coefficientsF16.clear();
  field.scale.clear();
  field.bias.clear();
  return {};
}

}  // namespace

Result<void> encodeCoefficients(Field& field, const std::function<const float*(uint64_t texel)>& texelValues,
                                uint64_t layerStride) {
  if (auto r = checkEncodable(field); !r) return r;
  CoefficientSource src;
  src.layerStride = layerStride;
  src.layers = field.layerCount();
  src.texels = field.texelCount();
  src.channels = field.valuesPerLayer();
  if (layerStride < src.channels)
    return makeError(ErrorCode::InvalidArgument, "encodeCoefficients: layer stride " + std::to_string(layerStride) +
                                                     " is below the " + std::to_string(src.channels) +
                                                     " values per layer");
  src.rows.resize(src.texels);
  for (uint64_t t = 0; t < src.texels; ++t) src.rows[t] = texelValues(t);
  if (auto r = checkCoefficients(field, src); !r) return r;
  if (field.clustered) return encodeIndices(field, src);
  field.clusterIndices.clear();
  if (field.quantization == Quantization::F16) {
    encodeF16(field, src);
    return {};
  }
  return encodeU8(field, src);
}

}  // namespace shrefract
