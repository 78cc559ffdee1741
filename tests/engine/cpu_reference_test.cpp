// The CPU reference on cases with an analytic answer: the GPU tests compare against it, so it
// must be right on its own. Decoding (frame, horizon clamp, SH sum, Table and Pca grids,
// normalization, throughput), gutter rules, bilinear sampling at texel centres and clamp-to-edge,
// field shading (with throughput), and the ray caster.
#include <gtest/gtest.h>
#include <shrefract/cpu_reference.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <vector>

#include "engine/synthetic_field.h"

namespace shrefract {
namespace {

constexpr float kY0 = 0.28209479f;  // Y_0
constexpr float kY1 = 0.48860251f;  // sqrt(3 / (4 pi)), the band-1 constant

// A 2x1 atlas, both texels samples with the identity frame at the origin (w = eye), order 1, U8.
// Coefficient layer i, channel c as given, the same in both texels: every (layer, channel) has zero
// range, so it decodes exactly to its bias (field.h).
Field identityField(const std::vector<std::array<float, 4>>& layers, uint32_t order = 1) {
  Field f;
  f.width = 2;
  f.height = 1;
  f.order = order;
  f.channels = 4;
  f.quantization = Quantization::U8;
  f.settings.order = order;
  f.settings.quantization = Quantization::U8;
  f.media.push_back(FieldMedium{"air", 1.0f, 0.0f, {1, 1, 1}});
  f.texelKinds = {kTexelSample, kTexelSample};
  const float identity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  f.frames.assign(identity, identity + 12);
  f.frames.insert(f.frames.end(), identity, identity + 12);
  std::vector<float> coefficients(size_t(f.basisCount()) * 2 * 4, 0.0f);
  for (size_t i = 0; i < layers.size(); ++i)
    for (size_t t = 0; t < 2; ++t)
      for (size_t c = 0; c < 4; ++c) coefficients[(i * 2 + t) * 4 + c] = layers[i][c];
  EXPECT_TRUE(encodeCoefficients(f, coefficients).ok());
  f.mesh.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  f.mesh.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  f.mesh.uvs = {0, 0, 1, 0, 0, 1};
  f.mesh.frontIor = {1.5f, 1.5f, 1.5f};
  f.mesh.indices = {0, 1, 2};
  EXPECT_TRUE(validateField(f).ok()) << validateField(f).error().message;
  return f;
}

TEST(CpuReference, ConstantFieldDecodesToItsDirection) {
  // Band 0 only: the decoded direction does not depend on the eye.
  const Field f = identityField({{1.0f, 2.0f, 2.0f, 4.0f}, {0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}});
  for (const reference::Vec3 eye : {reference::Vec3{0, 0, 3}, reference::Vec3{5, -1, 0.1f}, reference::Vec3{0, 0, -2}}) {
    const reference::Vec4 d = reference::decodeTexel(f, 1, eye);
    EXPECT_NEAR(d[0], 1.0f / 3.0f, 1e-6f);
    EXPECT_NEAR(d[1], 2.0f / 3.0f, 1e-6f);
    EXPECT_NEAR(d[2], 2.0f / 3.0f, 1e-6f);
    EXPECT_NEAR(d[3], 4.0f * kY0, 1e-6f);
  }
}

TEST(CpuReference, BandOneFollowsTheEyeAndClampsAtTheHorizon) {
  // x of the exit direction = c_0 Y_0 + c_2 Y_2(w) with Y_2 = kY1 * w.z (index 2 is (l=1, m=0)).
  // y = constant 1 keeps the sum away from zero.
  const Field f = identityField({{0.0f, 1.0f / kY0, 0.0f, 0.0f}, {0, 0, 0, 0}, {1.0f, 0, 0, 0}, {0, 0, 0, 0}});
  // Eye on the normal: w = +z, x = kY1, y = 1.
  reference::Vec4 d = reference::decodeTexel(f, 0, {0, 0, 2});
  const float len = std::sqrt(kY1 * kY1 + 1.0f);
  EXPECT_NEAR(d[0], kY1 / len, 1e-6f);
  EXPECT_NEAR(d[1], 1.0f / len, 1e-6f);
  // Eye below the tangent plane: w.z is clamped to 0 (the horizon), so x = 0.
  d = reference::decodeTexel(f, 0, {1, 0, -3});
  EXPECT_NEAR(d[0], 0.0f, 1e-6f);
  EXPECT_NEAR(d[1], 1.0f, 1e-6f);
  // Eye exactly on the sample point below the plane: w = 0 after the clamp counts as +z.
  d = reference::decodeTexel(f, 0, {0, 0, -1});
  EXPECT_NEAR(d[0], kY1 / len, 1e-6f);
}

TEST(CpuReference, ZeroSumHasNoDirection) {
  const Field f = identityField({{0, 0, 0, 1.0f}, {0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}});
  const reference::Vec4 d = reference::decodeTexel(f, 0, {0, 0, 1});
  EXPECT_EQ(d[0], 0.0f);
  EXPECT_EQ(d[1], 0.0f);
  EXPECT_EQ(d[2], 0.0f);
  EXPECT_NEAR(d[3], kY0, 1e-6f);
}

// A 1x1 atlas holding one sample with the identity frame at the origin (w = eye), of a Table or
// Pca encoding on a 2x2 grid (nodes (0,0), (1,0), (0,1), (1,1) at u, v in {0, 1}; or N x N), U8. `values`
// are the coefficients in encodeCoefficients' order (Table: node-major, every channel; Pca: one
// weight per component). With a single texel every value has zero range and decodes exactly.
Field gridField(Encoding encoding, uint32_t channels, bool throughput, const std::vector<float>& values,
                const std::vector<float>& basis = {}, uint32_t tableSize = 2,
                DirectionSampling sampling = DirectionSampling::Grid) {
  Field f;
  f.width = f.height = 1;
  f.encoding = encoding;
  f.tableSize = tableSize;
  f.settings.directionSampling = sampling;
  f.components = encoding == Encoding::Pca ? static_cast<uint32_t>(values.size()) : 0;
  f.channels = channels;
  f.throughput = throughput;
  f.quantization = Quantization::U8;
  f.basis = basis;
  f.settings.order = 0;
  f.settings.encoding = encoding;
  f.settings.tableSize = f.tableSize;
  f.settings.components = f.components;
  f.settings.throughput = throughput;
  f.settings.quantization = Quantization::U8;
  f.media.push_back(FieldMedium{"air", 1.0f, 0.0f, {1, 1, 1}});
  f.texelKinds = {kTexelSample};
  f.frames = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  EXPECT_TRUE(encodeCoefficients(f, values).ok());
  f.mesh.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  f.mesh.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  f.mesh.uvs = {0, 0, 1, 0, 0, 1};
  f.mesh.frontIor = {1.5f, 1.5f, 1.5f};
  f.mesh.indices = {0, 1, 2};
  EXPECT_TRUE(validateField(f).ok()) << validateField(f).error().message;
  return f;
}

TEST(CpuReference, TableBlendsNodesAndScalesByTheClampedThroughput) {
  // Nodes (x, y, z, tau, throughput). The eye on the normal lies at u = v = 1/2: all four nodes
  // weigh 1/4. Along +x it lies at (u, v) = (1, 1), node 3; along -y at (0, 1), node 2.
  const Field f = gridField(Encoding::Table, 5, true,
                            {1, 0, 0, 1, 0.2f, 0, 1, 0, 2, 0.4f, 0, 0, 1, 3, 0.6f, 1, 1, 1, 4, 1.6f});
  const float s = 1.0f / std::sqrt(3.0f);
  reference::Vec4 d = reference::decodeTexel(f, 0, {0, 0, 2});
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(d[size_t(k)], s * 0.7f, 1e-6f) << k;  // (0.5, 0.5, 0.5) scaled by 0.7
  EXPECT_NEAR(d[3], 2.5f, 1e-6f);
  d = reference::decodeTexel(f, 0, {3, 0, 0});
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(d[size_t(k)], s, 1e-6f) << k;  // throughput 1.6 clamped to 1
  EXPECT_NEAR(d[3], 4.0f, 1e-6f);
  d = reference::decodeTexel(f, 0, {0, -1, 0});
  EXPECT_NEAR(d[0], 0.0f, 1e-6f);
  EXPECT_NEAR(d[2], 0.6f, 1e-6f);
  EXPECT_NEAR(d[3], 3.0f, 1e-6f);
  // Without throughput (4 channels: x, y, z, tau) the same nodes decode to unit directions.
  const Field g = gridField(Encoding::Table, 4, false, {1, 0, 0, 1, 0, 1, 0, 2, 0, 0, 1, 3, 1, 1, 1, 4});
  d = reference::decodeTexel(g, 0, {0, 0, 2});
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(d[size_t(k)], s, 1e-6f) << k;
}

TEST(CpuReference, PcaSumsWeightedBasisFunctions) {
  // Two components of 3 channels, weights 2 and -1. At node 3 (eye along +x): 2 B0 - B1.
  const std::vector<float> basis{0, 0, 1, 0, 0, 1, 0, 0, 1, 1, 0, 1,   // B0 at nodes 0..3
                                 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0};  // B1 at nodes 0..3
  const Field f = gridField(Encoding::Pca, 3, false, {2.0f, -1.0f}, basis);
  reference::Vec4 d = reference::decodeTexel(f, 0, {5, 0, 0});
  const float len = std::sqrt(4.0f + 4.0f + 4.0f);  // (2, -2, 2)
  EXPECT_NEAR(d[0], 2.0f / len, 1e-6f);
  EXPECT_NEAR(d[1], -2.0f / len, 1e-6f);
  EXPECT_NEAR(d[2], 2.0f / len, 1e-6f);
  EXPECT_EQ(d[3], 0.0f);  // no optical depth channel
  // On the normal: the mean of the nodes, (0.5, -0.5, 2) after the weights.
  d = reference::decodeTexel(f, 0, {0, 0, 1});
  const float len2 = std::sqrt(0.25f + 0.25f + 4.0f);
  EXPECT_NEAR(d[0], 0.5f / len2, 1e-6f);
  EXPECT_NEAR(d[1], -0.5f / len2, 1e-6f);
  EXPECT_NEAR(d[2], 2.0f / len2, 1e-6f);
}

// A node-sampled 16x16 table holding the straight-through exit (a slab's: the view ray's own
// direction, -w with the identity frame) at every node but one, which points the other way (+d,
// its node's direction d). In the cell whose corner it is, every other corner estimates exactly
// -w and leaves it out, it leaves them out and estimates d + (-w) - (-d) = 2d - w. The views are
// averaged with weights w_m^p (p = 4, gpu_layout.h kJumpDominancePower) and, with at least a
// quarter of the weight left out, replace the bilinear result: the decode is -w + 2 pi d with pi
// the odd corner's share w_odd^4 / sum w_m^4. Plain bilinear interpolation (the same values,
// grid-fitted) blends the odd node in instead.
TEST(CpuReference, JumpAwareCornersLeaveOutANodeAcrossAJump) {
  constexpr uint32_t n = 16, odd = 8 * n + 8;
  constexpr double kPower = 4.0;  // gpu_layout.h kJumpDominancePower
  std::vector<float> nodes;
  for (uint32_t k = 0; k < n * n; ++k) {
    const std::array<float, 3> d = hemiOctDirection(k % n, k / n, n);
    for (int c = 0; c < 3; ++c) nodes.push_back(k == odd ? d[size_t(c)] : -d[size_t(c)]);
  }
  const std::array<float, 3> d = hemiOctDirection(odd % n, odd / n, n);
  const Field jumpAware = gridField(Encoding::Table, 3, false, nodes, {}, n, DirectionSampling::Nodes);
  const Field bilinear = gridField(Encoding::Table, 3, false, nodes, {}, n, DirectionSampling::Grid);
  ASSERT_TRUE(jumpAware.shape().jumpAware);
  ASSERT_FALSE(bilinear.shape().jumpAware);
  auto angle = [](const reference::Vec4& a, const std::array<double, 3>& b) {
    const double x = a[0], y = a[1], z = a[2];
    const double dot = x * b[0] + y * b[1] + z * b[2];
    const double lb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    return std::acos(std::clamp(dot / (std::sqrt(x * x + y * y + z * z) * lb), -1.0, 1.0)) * 180.0 / std::numbers::pi;
  };
  double worstJumpAware = 0.0, leastBilinear = 180.0;
  int checked = 0;
  for (double tx = 0.05; tx < 1.0; tx += 0.1)
    for (double ty = 0.05; ty < 1.0; ty += 0.1) {
      // In the cell whose lower corner is the odd node.
      const double weights[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
      if (weights[0] < 0.26) continue;
      double total = 0.0;
      for (double wm : weights) total += std::pow(wm, kPower);
      const double share = std::pow(weights[0], kPower) / total;
      const double a = 2.0 * (8.0 + tx) / double(n - 1) - 1.0, b = 2.0 * (8.0 + ty) / double(n - 1) - 1.0;
      const double px = 0.5 * (a + b), py = 0.5 * (a - b), pz = 1.0 - std::fabs(px) - std::fabs(py);
      const double len = std::sqrt(px * px + py * py + pz * pz);
      const std::array<double, 3> w{px / len, py / len, pz / len};
      std::array<double, 3> expected{}, straight{};
      for (size_t c = 0; c < 3; ++c) expected[c] = -w[c] + 2.0 * share * double(d[c]), straight[c] = -w[c];
      const reference::Vec3 eye{float(3.0 * w[0]), float(3.0 * w[1]), float(3.0 * w[2])};
      worstJumpAware = std::max(worstJumpAware, angle(reference::decodeTexel(jumpAware, 0, eye), expected));
      leastBilinear = std::min(leastBilinear, angle(reference::decodeTexel(bilinear, 0, eye), straight));
      ++checked;
    }
  std::printf("%d eyes: jump-aware within %.4f deg of the closed form, bilinear at least %.1f deg off the straight "
              "path\n", checked, worstJumpAware, leastBilinear);
  EXPECT_GE(checked, 20);
  EXPECT_LT(worstJumpAware, 0.05);  // binary16 rounding of the stored direction
  EXPECT_GT(leastBilinear, 3.0);  // measured 5.9 deg: the same check fails without the jump-aware rule
}

TEST(CpuReference, GutterRulesAndEmptyTexels) {
  testing::SyntheticFieldOptions o;
  o.emptyAndGutters = true;
  const Field f = testing::makeSyntheticField(o);
  ASSERT_TRUE(validateField(f).ok()) << validateField(f).error().message;
  const reference::Vec3 eye{0.5f, 0.5f, 3.0f};
  const reference::DistortionImage image = reference::decompress(f, eye);
  for (uint64_t t = 0; t < f.texelCount(); ++t) {
    if (f.texelKinds[t] == kTexelEmpty) {
      for (int c = 0; c < 4; ++c) EXPECT_EQ(image.rgba[t * 4 + c], 0.0f);
    }
    if (f.texelKinds[t] == kTexelSample) {
      const reference::Vec4 d = reference::decodeTexel(f, t, eye);
      for (int c = 0; c < 4; ++c) EXPECT_EQ(image.rgba[t * 4 + c], reference::roundToBinary16(d[size_t(c)]));
    }
  }
  ASSERT_FALSE(f.gutters.empty());
  for (const GutterTexel& g : f.gutters)
    for (int c = 0; c < 4; ++c)
      EXPECT_EQ(image.rgba[g.target * 4 + c],
                reference::roundToBinary16(image.rgba[g.a * 4 + c] + image.rgba[g.b * 4 + c] - image.rgba[g.c * 4 + c]));
}

TEST(CpuReference, BilinearSamplingAtCentresBetweenThemAndBeyondTheEdge) {
  reference::DistortionImage image;
  image.width = 2;
  image.height = 2;
  image.rgba = {0, 0, 0, 0, 1, 2, 3, 4, 10, 20, 30, 40, 11, 22, 33, 44};
  auto at = [&](float u, float v) { return reference::sampleBilinear(image, u, v); };
  EXPECT_EQ(at(0.25f, 0.25f)[0], 0.0f);   // centre of texel (0, 0)
  EXPECT_EQ(at(0.75f, 0.25f)[1], 2.0f);   // centre of texel (1, 0)
  EXPECT_EQ(at(0.25f, 0.75f)[2], 30.0f);  // centre of texel (0, 1)
  EXPECT_NEAR(at(0.5f, 0.5f)[3], (0 + 4 + 40 + 44) / 4.0f, 1e-5f);
  EXPECT_NEAR(at(0.5f, 0.25f)[0], 0.5f, 1e-6f);
  EXPECT_EQ(at(0.0f, 0.0f)[1], 0.0f);      // clamp to edge: the corner texel only
  EXPECT_EQ(at(1.0f, 1.0f)[2], 33.0f);
  EXPECT_NEAR(at(1.0f, 0.5f)[0], 6.0f, 1e-5f);  // right edge: between (1,0) and (1,1)
}

// Closed forms of the unpolarized dielectric reflectance: ((n1 - n2) / (n1 + n2))^2 at normal
// incidence (eta = n1 / n2 either way), 1 at grazing incidence and beyond the critical angle
// (sin theta > 1 / eta leaving glass), the average of the s and p terms in between, and cosI
// clamped to [0, 1].
TEST(CpuReference, FresnelMatchesItsClosedForms) {
  EXPECT_NEAR(reference::fresnelDielectric(1.0f, 1.0f / 1.5f), 0.04f, 1e-6f);
  EXPECT_NEAR(reference::fresnelDielectric(1.0f, 1.5f), 0.04f, 1e-6f);
  EXPECT_NEAR(reference::fresnelDielectric(1.0f, 1.0f), 0.0f, 1e-7f);
  EXPECT_FLOAT_EQ(reference::fresnelDielectric(0.0f, 1.0f / 1.5f), 1.0f);
  const double critical = std::asin(1.0 / 1.5);  // glass to air
  EXPECT_FLOAT_EQ(reference::fresnelDielectric(float(std::cos(critical + 0.01)), 1.5f), 1.0f);
  EXPECT_LT(reference::fresnelDielectric(float(std::cos(critical - 0.01)), 1.5f), 1.0f);
  // 45 degrees from air into n = 1.5, from the s and p amplitudes in double.
  const double ci = std::sqrt(0.5), eta = 1.0 / 1.5, ct = std::sqrt(1.0 - eta * eta * 0.5);
  const double rs = (eta * ci - ct) / (eta * ci + ct), rp = (ci - eta * ct) / (ci + eta * ct);
  EXPECT_NEAR(reference::fresnelDielectric(float(ci), float(eta)), 0.5 * (rs * rs + rp * rp), 1e-6);
  EXPECT_FLOAT_EQ(reference::fresnelDielectric(-0.5f, 1.0f / 1.5f), 1.0f);  // clamped to grazing
  EXPECT_FLOAT_EQ(reference::fresnelDielectric(2.0f, 1.0f / 1.5f), reference::fresnelDielectric(1.0f, 1.0f / 1.5f));
}

TEST(CpuReference, ShadeFieldOnAConstantEnvironment) {
  // Constant environment E: colour = (1 - F) T tint E + F E at normal incidence, F = 0.04 (1.5).
  std::vector<float> envPixels(8 * 4 * 4);
  for (size_t i = 0; i < envPixels.size(); i += 4) {
    envPixels[i] = 0.5f;
    envPixels[i + 1] = 0.25f;
    envPixels[i + 2] = 1.0f;
    envPixels[i + 3] = 1.0f;
  }
  const reference::LatLongImage env{8, 4, envPixels.data()};
  reference::DistortionImage distortion;
  distortion.width = distortion.height = 1;
  distortion.rgba = {0.0f, 0.0f, -1.0f, 2.0f};  // tau = 2
  reference::SurfacePoint p;
  p.position = {0, 0, 0};
  p.normal = {0, 0, 1};
  p.uv = {0.5f, 0.5f};
  p.frontIor = 1.5f;
  ObjectShading shading;
  shading.absorptionScale = 0.5f * std::numbers::ln2_v<float>;  // T = exp(-2 * 0.5 ln 2) = 0.5
  shading.tint = {1.0f, 0.5f, 1.0f};
  const reference::Vec3 c = reference::shadeField(distortion, env, p, {0, 0, 4}, shading, 2.0f);
  const float f = 0.04f;
  const float expected[3] = {((1 - f) * 0.5f * 1.0f + f) * 0.5f * 2.0f, ((1 - f) * 0.5f * 0.5f + f) * 0.25f * 2.0f,
                             ((1 - f) * 0.5f * 1.0f + f) * 1.0f * 2.0f};
  for (size_t k = 0; k < 3; ++k) EXPECT_NEAR(c[k], expected[k], 1e-5f) << k;
  // No data: the view direction is used (the same constant environment, so the same colour).
  distortion.rgba = {0, 0, 0, 2.0f};
  const reference::Vec3 c2 = reference::shadeField(distortion, env, p, {0, 0, 4}, shading, 2.0f);
  for (size_t k = 0; k < 3; ++k) EXPECT_NEAR(c2[k], expected[k], 1e-5f);
  // frontIor 0 falls back to shading.ior: 1.0 means no reflection at all.
  p.frontIor = 0.0f;
  shading.ior = 1.0f;
  const reference::Vec3 c3 = reference::shadeField(distortion, env, p, {0, 0, 4}, shading, 1.0f);
  EXPECT_NEAR(c3[0], 0.5f * 1.0f * 0.5f, 1e-6f);
  // An image with throughput: the transmitted term scales by min(|d|, 1); an image without it
  // ignores the length.
  distortion.rgba = {0.0f, 0.0f, -0.25f, 2.0f};
  EXPECT_NEAR(reference::shadeField(distortion, env, p, {0, 0, 4}, shading, 1.0f)[0], c3[0], 1e-6f);
  distortion.throughput = true;
  EXPECT_NEAR(reference::shadeField(distortion, env, p, {0, 0, 4}, shading, 1.0f)[0], 0.25f * c3[0], 1e-6f);
  distortion.rgba = {0.0f, 0.0f, -1.5f, 2.0f};  // a blend longer than 1 counts as 1
  EXPECT_NEAR(reference::shadeField(distortion, env, p, {0, 0, 4}, shading, 1.0f)[0], c3[0], 1e-6f);
}

// Jumps across texels (gpu_layout.h kSpatialAgreeCosine): two texels whose exits are 90 deg apart
// blend as colours, each texel's lookup weighed by its bilinear weight / (1 + luma), where the
// blended direction would read a third colour no path sees; texels that agree blend as directions.
// A 64 x 32 lat-long environment of three regions, read at level 0: red where y > 0.5, green
// where x > 0.5, yellow where both.
struct RedUpGreenRight {
  static constexpr uint32_t kW = 64, kH = 32;
  std::vector<float> pixels = makePixels();
  std::vector<std::vector<float>> noChain;
  reference::LatLongImage env{kW, kH, pixels.data(), &noChain};

  static std::vector<float> makePixels() {
    std::vector<float> out(size_t(kW) * kH * 4);
    for (uint32_t y = 0; y < kH; ++y)
      for (uint32_t x = 0; x < kW; ++x) {
        const float theta = (float(y) + 0.5f) / float(kH) * std::numbers::pi_v<float>;
        const float phi = ((float(x) + 0.5f) / float(kW) - 0.5f) * 2.0f * std::numbers::pi_v<float>;
        const float dx = std::sin(theta) * std::sin(phi), dy = std::cos(theta);
        float* p = &out[(size_t(y) * kW + x) * 4];
        p[0] = dy > 0.5f ? 1.0f : 0.0f;
        p[1] = dx > 0.5f ? 1.0f : 0.0f;
        p[2] = 0.0f;
        p[3] = 1.0f;
      }
    return out;
  }
};

TEST(CpuReference, TexelsAcrossAJumpBlendTheirColours) {
  const RedUpGreenRight regions;
  const reference::LatLongImage& env = regions.env;
  reference::DistortionImage distortion;
  distortion.width = 2;
  distortion.height = 1;
  reference::SurfacePoint p;
  p.normal = {0, 0, 1};
  p.uv = {0.5f, 0.5f};  // midway between the two texel centres
  p.frontIor = 1.0f;    // no reflection: the colour is the transmitted lookup
  const ObjectShading shading;
  auto shade = [&](const std::array<float, 3>& a, const std::array<float, 3>& b) {
    distortion.rgba = {a[0], a[1], a[2], 0.0f, b[0], b[1], b[2], 0.0f};
    return reference::shadeField(distortion, env, p, {0, 0, 4}, shading);
  };
  // Both texels +y: red, whichever way they blend.
  const reference::Vec3 same = shade({0, 1, 0}, {0, 1, 0});
  EXPECT_NEAR(same[0], 1.0f, 1e-5f);
  EXPECT_NEAR(same[1], 0.0f, 1e-5f);
  // +y and +x: their blended direction (1, 1, 0) / sqrt(2) reads yellow; the colours blend to red
  // and green weighed 0.5 / (1 + 0.2126) and 0.5 / (1 + 0.7152).
  const reference::Vec3 jump = shade({0, 1, 0}, {1, 0, 0});
  const float red = 1.0f / 1.2126f, green = 1.0f / 1.7152f;
  EXPECT_NEAR(jump[0], red / (red + green), 1e-4f);
  EXPECT_NEAR(jump[1], green / (red + green), 1e-4f);
  EXPECT_NEAR(jump[2], 0.0f, 1e-6f);
  // Within kSpatialAgreeCosine (2 deg apart about a direction inside the red region): direction
  // blending, the same red.
  const float a = 2.0f * std::numbers::pi_v<float> / 180.0f;
  const reference::Vec3 agree = shade({0, 1, 0}, {std::sin(a), std::cos(a), 0});
  EXPECT_NEAR(agree[0], 1.0f, 1e-5f);
  EXPECT_NEAR(agree[1], 0.0f, 1e-5f);
  // The uv on an empty texel whose neighbours straddle a jump with no weight: no colour weight, no
  // direction: the view direction (-z, which the environment shows black), never NaN.
  distortion.width = 2;
  distortion.height = 2;
  distortion.rgba = {0, 0, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0};
  p.uv = {0.25f, 0.25f};  // texel (0, 0)'s centre: bilinear weight 1 on the empty texel
  const reference::Vec3 empty = reference::shadeField(distortion, env, p, {0, 0, 4}, shading);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(empty[k], 0.0f) << k;
}

// Placing the jump between texels (gpu_layout.h kSpatialPlaceTrust): texel 0 leaves +y (red), texel 1
// +x (green), and the jump image says texel 0's view lies 0.1 cells from its table's jump and
// texel 1's 0.3: the side function, +0.1 at texel 0 and -0.3 at texel 1, is zero a quarter of the
// way from texel 0 (u = 0.375 between the centres at 0.25 and 0.75). Either side of it the red
// share is the bilinear weight moved by kSpatialPlaceTrust toward 1 or 0, then weighed by
// 1 / (1 + luma) as every jump cell's colours are. Derivatives of 1/100 of a texel: a sharp step.
TEST(CpuReference, JumpImagePlacesTheJumpBetweenTexels) {
  const RedUpGreenRight regions;
  reference::DistortionImage distortion;
  distortion.width = 2;
  distortion.height = 1;
  distortion.rgba = {0, 1, 0, 0, 1, 0, 0, 0};
  reference::SurfacePoint p;
  p.normal = {0, 0, 1};
  p.frontIor = 1.0f;  // no reflection: the colour is the transmitted light
  reference::LookupDerivatives d;
  d.uvDx = {0.005f, 0.0f};  // a hundredth of a texel's 0.5
  d.uvDy = {0.0f, 0.01f};
  auto redAt = [&](float u) {
    p.uv = {u, 0.5f};
    const reference::Vec3 c = reference::shadeField(distortion, regions.env, p, {0, 0, 4}, ObjectShading{}, 1.0f,
                                                    Transform{}, d);
    return c[0];
  };
  // The colour of a red share s (one texel a side): luma-weighted as the blend is.
  auto blended = [](float s) {
    const float red = s / (1.0f + gpu::kLumaRed), green = (1.0f - s) / (1.0f + gpu::kLumaGreen);
    return red / (red + green);
  };
  const float trust = gpu::kSpatialPlaceTrust;
  distortion.jump = {0.1f, 0.3f};
  EXPECT_NEAR(redAt(0.35f), blended(0.8f + trust * (1.0f - 0.8f)), 1e-4f) << "before the jump (t = 0.2)";
  EXPECT_NEAR(redAt(0.40f), blended(0.7f + trust * (0.0f - 0.7f)), 1e-4f) << "past it (t = 0.3)";
  EXPECT_NEAR(redAt(0.65f), blended(0.2f + trust * (0.0f - 0.2f)), 1e-4f) << "near texel 1, its side";
  // The distances swapped: the jump three quarters of the way, so t = 0.3 is still red's side.
  distortion.jump = {0.3f, 0.1f};
  EXPECT_NEAR(redAt(0.40f), blended(0.7f + trust * (1.0f - 0.7f)), 1e-4f);
  // A texel at the cap (no jump within a cell of its view), or no jump image: the bilinear blend.
  for (const std::vector<float>& none : {std::vector<float>{0.1f, gpu::kJumpDistanceMaxCells}, std::vector<float>{}}) {
    distortion.jump = none;
    EXPECT_NEAR(redAt(0.40f), blended(0.7f), 1e-4f);
  }
}

// A 64 x 32 lat-long environment of vertical stripes, red in every other 8 columns, green 0.5
// everywhere, with its level chain: level 0 reads red 1 at a red column's centre, the chain's
// coarse levels average the stripes to 0.5.
struct RedStripes {
  static constexpr uint32_t kW = 64, kH = 32;
  std::vector<float> pixels = makePixels();
  std::vector<std::vector<float>> chain = reference::environmentLevels(reference::LatLongImage{kW, kH, pixels.data()});
  reference::LatLongImage env{kW, kH, pixels.data(), &chain};

  static std::vector<float> makePixels() {
    std::vector<float> out(size_t(kW) * kH * 4);
    for (uint32_t row = 0; row < kH; ++row)
      for (uint32_t col = 0; col < kW; ++col) {
        float* p = &out[(size_t(row) * kW + col) * 4];
        p[0] = (col / 8) % 2 == 0 ? 1.0f : 0.0f;
        p[1] = 0.5f;
        p[2] = 0.0f;
        p[3] = 1.0f;
      }
    return out;
  }
  // The direction at the centre of texel (col, row) (environment.glsl's convention).
  static reference::Vec3 at(float col, float row) {
    const float theta = (row + 0.5f) / float(kH) * std::numbers::pi_v<float>;
    const float phi = ((col + 0.5f) / float(kW) - 0.5f) * 2.0f * std::numbers::pi_v<float>;
    return {std::sin(theta) * std::sin(phi), std::cos(theta), -std::sin(theta) * std::cos(phi)};
  }
};

// Scatter in a jump cell (gpu_layout.h kSpatialScatterThreshold): the spread four exits keep once
// one jump may split them in two, in closed form, and what the shading does with it over
// RedStripes.
TEST(CpuReference, ScatteredTexelsReadABlurrierLevel) {
  using reference::Vec3;
  const Vec3 x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1}, minusX{-1, 0, 0}, none{0, 0, 0};
  const float halfPi = 0.5f * std::numbers::pi_v<float>;
  EXPECT_EQ(reference::scatterAfterOneJump({x, x, x, x}), 0.0f);
  EXPECT_EQ(reference::scatterAfterOneJump({y, x, y, x}), 0.0f) << "a clean jump: two groups that agree";
  EXPECT_EQ(reference::scatterAfterOneJump({x, y, y, y}), 0.0f) << "one texel across a jump";
  EXPECT_NEAR(reference::scatterAfterOneJump({x, y, z, minusX}), halfPi, 1e-6f);
  EXPECT_NEAR(reference::scatterAfterOneJump({x, none, y, z}), halfPi, 1e-6f) << "three apart and an empty texel";
  const float a = 2.0f * std::numbers::pi_v<float> / 180.0f;  // 2 deg
  const Vec3 tilted{std::sin(a), 0.0f, std::cos(a)}, tilted2{0.0f, std::sin(a), std::cos(a)};
  EXPECT_NEAR(reference::scatterAfterOneJump({z, tilted, tilted2, z}), a, 1e-3f) << "a smooth cell: its own spread";

  const RedStripes stripes;
  const reference::LatLongImage& env = stripes.env;
  // Red columns 4, 20, 36 and 52, rows far apart.
  const std::array<Vec3, 4> scattered{RedStripes::at(4, 8), RedStripes::at(20, 24), RedStripes::at(36, 12),
                                      RedStripes::at(52, 20)};
  for (const Vec3& d : scattered) ASSERT_NEAR(reference::sampleLatLong(env, d, 0.0f)[0], 1.0f, 1e-5f) << "a red column";
  ASSERT_GT(reference::scatterAfterOneJump(scattered), 0.5f);
  reference::DistortionImage distortion;
  distortion.width = 2;
  distortion.height = 2;
  auto shade = [&](const std::array<Vec3, 4>& exits) {
    distortion.rgba.clear();
    for (const Vec3& e : exits) distortion.rgba.insert(distortion.rgba.end(), {e[0], e[1], e[2], 0.0f});
    reference::SurfacePoint p;
    p.normal = {0, 0, 1};
    p.uv = {0.5f, 0.5f};  // the cell's centre: a quarter of each texel
    p.frontIor = 1.0f;    // no reflection
    return reference::shadeField(distortion, env, p, {0, 0, 4}, ObjectShading{});
  };
  // Scattered: each lookup reads the coarse levels' average, not its red column.
  const Vec3 blurred = shade(scattered);
  EXPECT_NEAR(blurred[0], 0.5f, 0.05f);
  EXPECT_NEAR(blurred[1], 0.5f, 1e-4f);
  // A clean jump between two red columns: no scatter, level 0, red.
  const Vec3 sharp = shade({scattered[0], scattered[2], scattered[0], scattered[2]});
  EXPECT_NEAR(sharp[0], 1.0f, 1e-5f);
}

// A filtered exit shorter than 1 blends texels that point apart (gpu_layout.h
// kFilteredExitSpreadThreshold): its lookup reads a coarser level by how far beyond the threshold
// acos(length) is. One texel (so the lookup reads it as stored), no derivatives, over RedStripes.
TEST(CpuReference, ShortFilteredExitsReadABlurrierLevel) {
  const RedStripes stripes;
  const reference::LatLongImage& env = stripes.env;
  const reference::Vec3 red = RedStripes::at(20, 12);  // column 20: red
  ASSERT_NEAR(reference::sampleLatLong(env, red, 0.0f)[0], 1.0f, 1e-5f);
  reference::DistortionImage distortion;
  distortion.width = distortion.height = 1;
  reference::SurfacePoint p;
  p.normal = {0, 0, 1};
  p.uv = {0.5f, 0.5f};
  p.frontIor = 1.0f;  // no reflection
  auto shade = [&](float length) {
    distortion.rgba = {length * red[0], length * red[1], length * red[2], 0.0f};
    return reference::shadeField(distortion, env, p, {0, 0, 4}, ObjectShading{});
  };
  EXPECT_NEAR(shade(1.0f)[0], 1.0f, 1e-5f) << "a unit exit reads level 0";
  EXPECT_NEAR(shade(std::cos(0.05f))[0], 1.0f, 1e-5f) << "below the threshold: level 0";
  EXPECT_NEAR(shade(std::cos(0.3f))[0], 0.5f, 0.05f) << "0.3 rad apart: 16 x 0.22 rad wider, the coarse levels";
  // With a throughput channel the length is the throughput, not a spread: level 0, scaled by it.
  distortion.throughput = true;
  EXPECT_NEAR(shade(std::cos(0.3f))[0], std::cos(0.3f), 1e-4f);
}

// A jump between the pixel and its neighbour (object_field_body.glsl exitDerivative): the fine
// derivative spans it, the gentler one-sided difference does not. A row of four texels, exits A A
// B B (A 90 deg from B), the fragment at texel 1's centre, one texel per pixel. A sits at a
// stripe's edge of RedStripes (column 16 of the red 16..23), so that any footprint of a level
// above 0 reads the black stripe beside it too, as the jump's share of a tap would (about 0.36
// rad, level 1.9), while the slope's (zero: A A) reads level 0, red.
TEST(CpuReference, AJumpBesideThePixelDoesNotWidenItsLookups) {
  using reference::Vec3;
  const RedStripes stripes;
  const Vec3 a = RedStripes::at(16, 16), b{0.0f, 1.0f, 0.0f};
  ASSERT_NEAR(reference::sampleLatLong(stripes.env, a, 0.0f)[0], 1.0f, 1e-5f);
  ASSERT_NEAR(a[0] * b[0] + a[1] * b[1] + a[2] * b[2], 0.0f, 0.1f);
  reference::DistortionImage distortion;
  distortion.width = 4;
  distortion.height = 1;
  for (const Vec3& e : {a, a, b, b}) distortion.rgba.insert(distortion.rgba.end(), {e[0], e[1], e[2], 0.0f});
  reference::SurfacePoint p;
  p.normal = {0, 0, 1};
  p.uv = {1.5f / 4.0f, 0.5f};
  p.frontIor = 1.0f;  // no reflection
  reference::LookupDerivatives d;
  d.uvDx = {0.25f, 0.0f};
  d.exitDx = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};  // the neighbour ahead, across the jump
  EXPECT_NEAR(reference::shadeField(distortion, stripes.env, p, {0, 0, 4}, ObjectShading{}, 1.0f, {}, d)[0], 1.0f, 1e-4f)
      << "the slope behind (none) sets the footprint: level 0";
  // The same fine derivative with the neighbour behind across the jump (B B A A, texel 2's centre).
  distortion.rgba.clear();
  for (const Vec3& e : {b, b, a, a}) distortion.rgba.insert(distortion.rgba.end(), {e[0], e[1], e[2], 0.0f});
  p.uv = {2.5f / 4.0f, 0.5f};
  d.exitDx = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
  EXPECT_NEAR(reference::shadeField(distortion, stripes.env, p, {0, 0, 4}, ObjectShading{}, 1.0f, {}, d)[0], 1.0f, 1e-4f);
  // A slope keeps its footprint: exits turning 0.8 rad a texel about the vertical, on both sides
  // alike, read level 1 (a tap's share, about 0.2 rad), where column 16 blends the black stripe.
  distortion.rgba.clear();
  const float step = 0.8f, phi = std::atan2(a[0], -a[2]), r = std::sqrt(a[0] * a[0] + a[2] * a[2]);
  for (int k = 0; k < 4; ++k) {
    const float angle = phi + step * float(k - 2);
    distortion.rgba.insert(distortion.rgba.end(), {r * std::sin(angle), a[1], -r * std::cos(angle), 0.0f});
  }
  d.exitDx = {};
  EXPECT_LT(reference::shadeField(distortion, stripes.env, p, {0, 0, 4}, ObjectShading{}, 1.0f, {}, d)[0], 0.95f);
}

// The edge records of the polygon silhouette coverage (shrefract/object.h TriangleEdges): a cube
// whose faces have their own vertices (split normals) finds every edge's neighbour across the
// split; a lone quad's border is open; a degenerate triangle's edges are never silhouettes; a seam
// whose sides differ by float noise still joins.
TEST(CpuReference, TriangleEdgesFindTheirNeighbours) {
  // The cube [-1, 1]^3, 4 vertices per face, counter-clockwise seen from outside.
  std::vector<float> positions;
  std::vector<uint32_t> indices;
  const std::array<std::array<float, 3>, 6> normals{{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}};
  for (const auto& n : normals) {
    // Two axes u, v of the face with u x v = n.
    const std::array<float, 3> u = n[0] != 0.0f ? std::array<float, 3>{0, n[0], 0} : n[1] != 0.0f ? std::array<float, 3>{0, 0, n[1]} : std::array<float, 3>{n[2], 0, 0};
    const std::array<float, 3> v{n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]};
    const uint32_t base = uint32_t(positions.size() / 3);
    for (const auto& [a, b] : std::array<std::pair<float, float>, 4>{{{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}})
      for (int k = 0; k < 3; ++k) positions.push_back(n[size_t(k)] + a * u[size_t(k)] + b * v[size_t(k)]);
    indices.insert(indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
  const std::vector<TriangleEdges> edges =
      triangleEdges(positions.data(), uint32_t(positions.size() / 3), indices.data(), uint32_t(indices.size()));
  ASSERT_EQ(edges.size(), 12u);
  for (uint32_t t = 0; t < 12; ++t) {
    const auto& own = normals[t / 2];
    for (size_t k = 0; k < 3; ++k) {
      const auto& across = edges[t].neighbour[k];
      const float cosine = across[0] * own[0] + across[1] * own[1] + across[2] * own[2];
      const float length = std::sqrt(across[0] * across[0] + across[1] * across[1] + across[2] * across[2]);
      EXPECT_NEAR(length, 1.0f, 1e-6f) << "triangle " << t << " edge " << k << ": a neighbour, never open";
      // The diagonal's neighbour is the face's other triangle; the border's, the next face.
      EXPECT_TRUE(std::fabs(cosine - 1.0f) < 1e-6f || std::fabs(cosine) < 1e-6f) << t << " " << k;
      // The edge's inward normal: the opposite corner lies inside.
      const uint32_t opposite = indices[3 * t + (k + 2) % 3];
      const auto& e = edges[t].edge[k];
      EXPECT_GT(e[0] * positions[3 * opposite] + e[1] * positions[3 * opposite + 1] + e[2] * positions[3 * opposite + 2] - e[3], 0.5f);
    }
  }
  // A lone quad: its diagonal joins, its border is open; noise of 1e-7 on a shared corner still joins.
  std::vector<float> quad{-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, -1, 0, 1, 1, 0, -1, 1, 0};
  quad[12] += 1e-7f;
  const std::vector<uint32_t> quadIndices{0, 1, 2, 3, 4, 5};
  const std::vector<TriangleEdges> q = triangleEdges(quad.data(), 6, quadIndices.data(), 6);
  EXPECT_EQ(q[0].neighbour[0], (std::array<float, 4>{0, 0, 0, 1})) << "open";
  EXPECT_NEAR(q[0].neighbour[2][2], 1.0f, 1e-6f) << "the diagonal (2 -> 0) finds the other triangle";
  EXPECT_NEAR(q[1].neighbour[0][2], 1.0f, 1e-6f) << "the diagonal (3 -> 4) finds the first triangle";
  const std::vector<float> line{0, 0, 0, 1, 0, 0, 2, 0, 0};
  const std::vector<TriangleEdges> d = triangleEdges(line.data(), 3, quadIndices.data(), 3);
  for (size_t k = 0; k < 3; ++k) EXPECT_EQ(d[0].neighbour[k][3], -1.0f) << "degenerate: never a silhouette";
  // Unvalidated meshes (the CPU reference reads them): a NaN and coordinates near the float limit
  // weld without undefined behaviour (UBSan in the sanitizer build) and make no silhouette.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> extreme{nan, 0, 0, 3e38f, 0, 0, 0, 3e38f, 0};
  const std::vector<TriangleEdges> x = triangleEdges(extreme.data(), 3, quadIndices.data(), 3);
  for (size_t k = 0; k < 3; ++k) EXPECT_EQ(x[0].neighbour[k][3], -1.0f);
}

// polygonCoverage in closed form: a triangle in the plane z = 0 seen from +z, one pixel = s along
// x and y. Beside an open edge along x (inward normal +y), a point d inside covers 0.5 + d / s;
// beside an edge whose neighbour faces the eye it covers the whole pixel.
TEST(CpuReference, PolygonCoverageRampsAcrossSilhouetteEdges) {
  TriangleEdges edges;
  edges.edge[0] = {0, 1, 0, 0};               // y >= 0 inside
  edges.neighbour[0] = {0, 0, 0, 1};          // open
  edges.edge[1] = {-1, 0, 0, -10};            // x <= 10 inside
  edges.neighbour[1] = {0, 0, 1, 0};          // a coplanar neighbour: faces the eye
  edges.edge[2] = {0.6f, -0.8f, 0, -10};      // far away
  edges.neighbour[2] = {0, 0, -1, 0};         // a neighbour seen from behind, 10 inside: 1
  reference::SurfacePoint p;
  p.normal = {0, 0, 1};
  reference::LookupDerivatives d;
  const float s = 0.02f;
  d.positionDx = {s, 0, 0};
  d.positionDy = {0, -s, 0};
  const reference::Vec3 eye{0, 0, 5};
  for (float inside : {0.0f, 0.1f, 0.25f, 0.5f, 0.8f}) {
    p.position = {0.0f, inside * s, 0.0f};
    EXPECT_NEAR(reference::polygonCoverage(edges, p, eye, d), std::min(0.5f + inside, 1.0f), 1e-5f) << inside;
  }
  p.position = {9.999f, 0.5f, 0.0f};  // beside the edge whose neighbour faces the eye
  EXPECT_EQ(reference::polygonCoverage(edges, p, eye, d), 1.0f);
  // The eye below the plane sees the coplanar neighbour from behind: that edge bounds the glass.
  EXPECT_NEAR(reference::polygonCoverage(edges, p, {0, 0, -5}, d), 0.5f + 0.001f / s, 1e-3f);
  // A 45 degree edge: the pixel is sqrt 2 wide along its normal.
  edges.edge[0] = {std::numbers::sqrt2_v<float> / 2, std::numbers::sqrt2_v<float> / 2, 0, 0};
  p.position = {0.1f * s, 0.1f * s, 0.0f};  // 0.1 sqrt 2 s inside
  EXPECT_NEAR(reference::polygonCoverage(edges, p, eye, d), 0.5f + 0.1f, 1e-5f);
}

TEST(CpuReference, RenderHitsFrontFacesOnly) {
  // A quad at z = 0 facing +z; the camera on +z sees it in the middle of the image.
  FieldMesh mesh;
  mesh.positions = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
  mesh.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
  mesh.uvs = {0, 0, 1, 0, 1, 1, 0, 1};
  mesh.frontIor = {1.5f, 1.5f, 1.5f, 1.5f};
  mesh.indices = {0, 1, 2, 0, 2, 3};
  reference::DistortionImage distortion;
  distortion.width = distortion.height = 1;
  distortion.rgba = {0.0f, 0.0f, -1.0f, 0.0f};
  std::vector<float> envPixels(8 * 4 * 4, 1.0f);
  const reference::LatLongImage env{8, 4, envPixels.data()};
  Camera camera;
  camera.eye = {0, 0, 4};
  reference::RenderedImage image = reference::render({{&mesh, &distortion, ObjectShading{}}}, env, camera, 16, 16);
  EXPECT_EQ(image.object[8 * 16 + 8], 0);
  EXPECT_EQ(image.object[0], -1);
  // Seen from behind, the quad is culled.
  camera.eye = {0, 0, -4};
  image = reference::render({{&mesh, &distortion, ObjectShading{}}}, env, camera, 16, 16);
  EXPECT_EQ(image.object[8 * 16 + 8], -1);
}

}  // namespace
}  // namespace shrefract
