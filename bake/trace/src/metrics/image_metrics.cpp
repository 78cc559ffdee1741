#include <shrefract/trace/image_metrics.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include <glm/geometric.hpp>

namespace shrefract::bake {
namespace {

double clamp01(float v) { return std::clamp(static_cast<double>(v), 0.0, 1.0); }

double luminance(const Image& img, size_t p) {
  return 0.2126 * clamp01(img.rgba[p * 4]) + 0.7152 * clamp01(img.rgba[p * 4 + 1]) +
         0.0722 * clamp01(img.rgba[p * 4 + 2]);
}

// The angle between two directions in degrees; 180 where either is zero (no direction).
double angleDegrees(glm::vec3 a, glm::vec3 b) {
  const float la = glm::length(a), lb = glm::length(b);
  if (!(la > 0.0f && lb > 0.0f)) return 180.0;
  return std::acos(std::clamp(static_cast<double>(glm::dot(a, b) / (la * lb)), -1.0, 1.0)) *
         (180.0 / 3.14159265358979323846);
}

// Mean, 95th percentile and maximum of the angles (sorted in place).
void angleStatistics(std::vector<double>& angles, ImageErrors& e) {
  if (angles.empty()) return;
  double sum = 0.0;
  for (double v : angles) sum += v;
  e.meanAngleDegrees = sum / double(angles.size());
  std::sort(angles.begin(), angles.end());
  e.p95AngleDegrees = angles[std::min(angles.size() - 1, size_t(0.95 * double(angles.size())))];
  e.maxAngleDegrees = angles.back();
}

// The SSIM of the 8x8 luminance window at (x0, y0), or nothing where no masked pixel lies in it.
std::optional<double> windowSsim(const Image& a, const Image& b, const std::vector<uint8_t>& mask, uint32_t x0,
                                 uint32_t y0) {
  constexpr double c1 = 0.01 * 0.01, c2 = 0.03 * 0.03;
  bool touches = false;
  double ma = 0, mb = 0;
  for (uint32_t y = y0; y < y0 + 8; ++y)
    for (uint32_t x = x0; x < x0 + 8; ++x) {
      const size_t p = size_t(y) * a.width + x;
      touches = touches || mask[p];
      ma += luminance(a, p);
      mb += luminance(b, p);
    }
  if (!touches) return std::nullopt;
  ma /= 64.0;
  mb /= 64.0;
  double va = 0, vb = 0, cov = 0;
  for (uint32_t y = y0; y < y0 + 8; ++y)
    for (uint32_t x = x0; x < x0 + 8; ++x) {
      const size_t p = size_t(y) * a.width + x;
      const double xa = luminance(a, p) - ma, xb = luminance(b, p) - mb;
      va += xa * xa;
      vb += xb * xb;
      cov += xa * xb;
    }
  va /= 63.0;
  vb /= 63.0;
  cov /= 63.0;
  return ((2 * ma * mb + c1) * (2 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
}

// SSIM (Wang et al. 2004) on luminance, 8x8 windows with stride 4, constants for range 1, over the
// windows that touch the mask; 1 where none does.
double maskedSsim(const Image& a, const Image& b, const std::vector<uint8_t>& mask) {
  double ssimSum = 0.0;
  uint64_t windows = 0;
  for (uint32_t y0 = 0; y0 + 8 <= a.height; y0 += 4)
    for (uint32_t x0 = 0; x0 + 8 <= a.width; x0 += 4)
      if (const std::optional<double> w = windowSsim(a, b, mask, x0, y0)) {
        ssimSum += *w;
        ++windows;
      }
  return windows ? ssimSum / double(windows) : 1.0;
}

}  // namespace

double psnrFromMeanSquaredError(double mse) {
  return mse > 1e-10 ? std::min(100.0, 10.0 * std::log10(1.0 / mse)) : 100.0;
}

Result<ImageErrors> compareImages(const Image& a, const Image& b, const std::vector<uint8_t>& mask,
                                  const std::vector<glm::vec3>& da, const std::vector<glm::vec3>& db) {
  const size_t n = size_t(a.width) * a.height;
  if (a.width != b.width || a.height != b.height || a.rgba.size() != n * 4 || b.rgba.size() != n * 4 ||
      mask.size() != n)
    return makeError(ErrorCode::InvalidArgument, "compareImages: image sizes disagree");
  const bool angles = !da.empty() || !db.empty();
  if (angles && (da.size() != n || db.size() != n))
    return makeError(ErrorCode::InvalidArgument, "compareImages: direction arrays disagree with the image size");
  ImageErrors e;
  double squares = 0.0;
  std::vector<double> angleList;
  for (size_t p = 0; p < n; ++p) {
    if (!mask[p]) continue;
    ++e.pixels;
    for (int k = 0; k < 3; ++k) {
      const double d = clamp01(a.rgba[p * 4 + k]) - clamp01(b.rgba[p * 4 + k]);
      squares += d * d;
    }
    if (angles) angleList.push_back(angleDegrees(da[p], db[p]));
  }
  if (e.pixels == 0) return e;
  const double mse = squares / double(e.pixels * 3);
  e.psnr = psnrFromMeanSquaredError(mse);
  angleStatistics(angleList, e);
  e.ssim = maskedSsim(a, b, mask);
  return e;
}

Image errorHeatMap(const Image& a, const Image& b, float scale) {
  Image out;
  out.width = a.width;
  out.height = a.height;
  const size_t n = size_t(a.width) * a.height;
  out.rgba.assign(n * 4, 1.0f);
  if (b.rgba.size() != a.rgba.size()) return out;
  for (size_t p = 0; p < n; ++p) {
    float d = 0.0f;
    for (int k = 0; k < 3; ++k) d += std::fabs(a.rgba[p * 4 + k] - b.rgba[p * 4 + k]);
    const float t = std::clamp(scale > 0.0f ? d / scale : 0.0f, 0.0f, 1.0f);
    // Black -> red -> yellow -> white.
    out.rgba[p * 4 + 0] = std::clamp(3.0f * t, 0.0f, 1.0f);
    out.rgba[p * 4 + 1] = std::clamp(3.0f * t - 1.0f, 0.0f, 1.0f);
    out.rgba[p * 4 + 2] = std::clamp(3.0f * t - 2.0f, 0.0f, 1.0f);
  }
  return out;
}

}  // namespace shrefract::bake
