#include "viewer/field_order.h"

#include <cstddef>
#include <string>

namespace shrefract::viewer {

Result<Field> truncateOrder(const Field& field, uint32_t order) {
  if (field.encoding != Encoding::Sh)
    return makeError(ErrorCode::InvalidArgument, std::string("a ") + toString(field.encoding) +
                                                     " field has no SH order to truncate");
  if (order > field.order)
    return makeError(ErrorCode::InvalidArgument, "cannot raise a field's SH order from " + std::to_string(field.order) +
                                                     " to " + std::to_string(order) + " (it holds only the baked bands)");
  Field out;
  // Copy the small parts member by member so that the coefficient arrays are never copied whole.
  out.width = field.width;
  out.height = field.height;
  out.order = order;
  out.channels = field.channels;
  out.throughput = field.throughput;
  out.quantization = field.quantization;
  out.frames = field.frames;
  out.texelKinds = field.texelKinds;
  out.gutters = field.gutters;
  out.mesh = field.mesh;
  out.media = field.media;
  out.settings = field.settings;
  out.settings.order = order;
  out.statistics = field.statistics;

  // Layer-major storage: the first `layers` layers are a prefix of the arrays.
  const size_t layers = out.basisCount();
  const size_t perLayer = static_cast<size_t>(field.texelCount()) * field.channels;
  const size_t stored = field.quantization == Quantization::U8 ? field.coefficientsU8.size() : field.coefficientsF16.size();
  const bool tablesShort = field.quantization == Quantization::U8 &&
                           (field.scale.size() < layers * field.channels || field.bias.size() < layers * field.channels);
  if (stored < layers * perLayer || tablesShort)
    return makeError(ErrorCode::CorruptData, "the field holds fewer coefficients than its order says (validateField)");
  if (field.quantization == Quantization::U8) {
    out.coefficientsU8.assign(field.coefficientsU8.begin(),
                              field.coefficientsU8.begin() + static_cast<std::ptrdiff_t>(layers * perLayer));
    out.scale.assign(field.scale.begin(), field.scale.begin() + static_cast<std::ptrdiff_t>(layers * field.channels));
    out.bias.assign(field.bias.begin(), field.bias.begin() + static_cast<std::ptrdiff_t>(layers * field.channels));
  } else {
    out.coefficientsF16.assign(field.coefficientsF16.begin(),
                               field.coefficientsF16.begin() + static_cast<std::ptrdiff_t>(layers * perLayer));
  }
  return out;
}

}  // namespace shrefract::viewer
