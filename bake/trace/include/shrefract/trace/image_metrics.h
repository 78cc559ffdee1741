// Error metrics between an approximation and a reference, over the object's pixels.
#pragma once

#include <shrefract/assets/image.h>
#include <shrefract/result.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <vector>

namespace shrefract::bake {

// The PSNR of a mean squared error of colours in [0, 1], in dB: 10 log10(1 / mse), and 100 dB
// where mse <= 1e-10 or is not a number (never infinite). Every PSNR of the bake and the tools.
double psnrFromMeanSquaredError(double mse);

struct ImageErrors {
  uint64_t pixels = 0;          // pixels in the mask
  double psnr = 0.0;            // dB, colours clamped to [0, 1]; +inf-free: capped at 100 dB
  double ssim = 0.0;            // mean SSIM of the luminance over 8x8 windows that touch the mask
  double meanAngleDegrees = 0;  // between the approximate and the exact exit directions
  double p95AngleDegrees = 0;
  double maxAngleDegrees = 0;
};

// `mask` selects the pixels compared (1 = object). Direction arrays may be empty (angles then 0).
// Errors: sizes that disagree.
Result<ImageErrors> compareImages(const Image& approx, const Image& reference, const std::vector<uint8_t>& mask,
                                  const std::vector<glm::vec3>& approxDirections,
                                  const std::vector<glm::vec3>& referenceDirections);

// A heat map of the per-pixel colour difference (|a - b| summed over RGB, scaled so `scale` maps
// to the top of the colour ramp), for side-by-side images.
Image errorHeatMap(const Image& a, const Image& b, float scale);

}  // namespace shrefract::bake
