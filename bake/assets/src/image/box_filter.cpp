#include <shrefract/assets/image.h>

#include <cstddef>

namespace shrefract::bake {

Image boxFilter(const Image& image, uint32_t s) {
  if (s <= 1) return image;
  Image out;
  out.width = image.width / s;
  out.height = image.height / s;
  out.rgba.assign(size_t(out.width) * out.height * 4, 0.0f);
  const float n = float(s * s);
  for (uint32_t y = 0; y < out.height; ++y)
    for (uint32_t x = 0; x < out.width; ++x) {
      float sum[4] = {0.0f, 0.0f, 0.0f, 0.0f};
      for (uint32_t j = 0; j < s; ++j)
        for (uint32_t i = 0; i < s; ++i) {
          const float* p = &image.rgba[((size_t(y) * s + j) * image.width + size_t(x) * s + i) * 4];
          for (int c = 0; c < 4; ++c) sum[c] += p[c];
        }
      for (int c = 0; c < 4; ++c) out.rgba[(size_t(y) * out.width + x) * 4 + size_t(c)] = sum[c] / n;
    }
  return out;
}

}  // namespace shrefract::bake
