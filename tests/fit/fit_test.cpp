// The hemisphere fit: exact on functions in the span, stable at the horizon where a plain
// projection rings, and the smoothing tools behave as documented.
#include <gtest/gtest.h>
#include <shrefract/bake/fit.h>
#include <shrefract/sh.h>

#include <cmath>
#include <random>

#include <algorithm>
#include <glm/glm.hpp>

namespace shrefract::bake {
namespace {

TEST(HemisphereGrid, WeightsSumToHemisphereAndDirectionsAreUnit) {
  const DirectionGrid g = makeHemisphereGrid(16, 32);
  ASSERT_EQ(g.directions.size(), 512u);
  double sum = 0.0;
  for (size_t k = 0; k < g.directions.size(); ++k) {
    sum += g.weights[k];
    EXPECT_NEAR(glm::length(g.directions[k]), 1.0, 1e-12);
    EXPECT_GT(g.directions[k].z, 0.0);
  }
  EXPECT_NEAR(sum, 2.0 * M_PI, 1e-12);
}

TEST(HemisphereFit, RecoversAnExpansionInTheSpanWithoutRegularization) {
  const int order = 4;
  const DirectionGrid g = makeHemisphereGrid(24, 48);
  auto fit = HemisphereFit::create(g, order, 0.0);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const int nb = sh::basisCount(order);
  std::vector<float> truth(nb * 2);
  for (auto& c : truth) c = u(rng);
  std::vector<float> values(g.directions.size() * 2);
  std::vector<double> y(nb);
  for (size_t d = 0; d < g.directions.size(); ++d) {
    sh::evaluate(order, g.directions[d].x, g.directions[d].y, g.directions[d].z, y.data());
    for (int c = 0; c < 2; ++c) {
      double s = 0;
      for (int i = 0; i < nb; ++i) s += static_cast<double>(truth[i * 2 + c]) * y[i];
      values[d * 2 + c] = static_cast<float>(s);
    }
  }
  std::vector<float> coeffs(nb * 2);
  fit->fit(values.data(), 2, coeffs.data());
  // On the hemisphere alone, the odd/even pairs are nearly dependent, so coefficients are only
  // determined up to the conditioning; the reconstruction on the hemisphere is what must match.
  for (size_t d = 0; d < g.directions.size(); d += 7) {
    float out[2];
    fit->reconstructAtGrid(coeffs.data(), 2, static_cast<uint32_t>(d), out);
    EXPECT_NEAR(out[0], values[d * 2], 2e-3);
    EXPECT_NEAR(out[1], values[d * 2 + 1], 2e-3);
  }
}

// A constant on the hemisphere is the hardest case for a projection: the implied step at the
// horizon rings (Gibbs). The regularized fit must be far flatter there.
TEST(HemisphereFit, RegularizedFitDoesNotRingAtTheHorizonLikeAPlainProjection) {
  const int order = 8;
  const DirectionGrid g = makeHemisphereGrid(32, 64);
  auto lsq = HemisphereFit::create(g, order, kDefaultRegularization);
  auto proj = HemisphereFit::create(g, order, 0.0, FitMethod::PlainProjection);
  ASSERT_TRUE(lsq.ok() && proj.ok());
  const int nb = sh::basisCount(order);
  std::vector<float> values(g.directions.size(), 1.0f);
  std::vector<float> a(nb), b(nb);
  lsq->fit(values.data(), 1, a.data());
  proj->fit(values.data(), 1, b.data());
  double maxLsq = 0, maxProj = 0;
  for (int k = 0; k <= 200; ++k) {  // along a meridian, from the pole to the horizon
    const float theta = float(k) / 200.0f * float(M_PI) / 2.0f;
    const glm::vec3 w(std::sin(theta), 0.0f, std::cos(theta));
    float va, vb;
    evaluateExpansion(order, a.data(), 1, w, &va);
    evaluateExpansion(order, b.data(), 1, w, &vb);
    maxLsq = std::max(maxLsq, double(std::fabs(va - 1.0f)));
    maxProj = std::max(maxProj, double(std::fabs(vb - 1.0f)));
  }
  EXPECT_LT(maxLsq, 0.01);
  EXPECT_GT(maxProj, 0.2);  // the projection's Gibbs overshoot/undershoot at the horizon
  std::printf("constant on the hemisphere, order 8: max error LSQ %.2e, plain projection %.2e\n", maxLsq, maxProj);
}

TEST(HemisphereFit, HighOrdersStayFiniteAndAccurate) {
  // A smooth, direction-like function: the refraction of w through a flat interface.
  for (int order : {12, 16, 20}) {
    const DirectionGrid g = makeHemisphereGrid(32, 64);
    auto fit = HemisphereFit::create(g, order, kDefaultRegularization);
    ASSERT_TRUE(fit.ok()) << fit.error().message;
    std::vector<float> values(g.directions.size() * 3);
    for (size_t d = 0; d < g.directions.size(); ++d) {
      const glm::vec3 w(g.directions[d]);
      const glm::vec3 t = glm::refract(-w, glm::vec3(0, 0, 1), 1.0f / 1.5f);
      for (int c = 0; c < 3; ++c) values[d * 3 + c] = t[c];
    }
    std::vector<float> coeffs(sh::basisCount(order) * 3);
    fit->fit(values.data(), 3, coeffs.data());
    for (float c : coeffs) ASSERT_TRUE(std::isfinite(c));
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    double maxAngle = 0;
    for (int k = 0; k < 500; ++k) {
      const float z = u(rng), phi = 2.0f * float(M_PI) * u(rng);
      const float r = std::sqrt(1 - z * z);
      const glm::vec3 w(r * std::cos(phi), r * std::sin(phi), z);
      const glm::vec3 t = glm::refract(-w, glm::vec3(0, 0, 1), 1.0f / 1.5f);
      float out[3];
      evaluateExpansion(order, coeffs.data(), 3, w, out);
      const glm::vec3 rec = glm::normalize(glm::vec3(out[0], out[1], out[2]));
      maxAngle = std::max(maxAngle, double(std::acos(std::clamp(glm::dot(rec, t), -1.0f, 1.0f))));
    }
    EXPECT_LT(maxAngle, 0.05) << "order " << order;
  }
}

TEST(HemisphereFit, RejectsBadArguments) {
  const DirectionGrid g = makeHemisphereGrid(2, 4);
  EXPECT_FALSE(HemisphereFit::create(g, -1, 0.0).ok());
  EXPECT_FALSE(HemisphereFit::create(g, kMaxFitOrder + 1, 0.0).ok());
  EXPECT_FALSE(HemisphereFit::create(g, 8, 0.0).ok());  // 8 directions, 81 functions, no penalty
  EXPECT_FALSE(HemisphereFit::create(g, 2, std::nan("")).ok());
}

// Every direction the pole: the m = +-1 functions are zero there, so without a penalty the normal
// equations have zero rows and the Cholesky factorization (Eigen's LLT) must report it, not return
// a projection of Inf or NaN. With the penalty the same grid fits.
TEST(HemisphereFit, SingularNormalEquationsAreRejected) {
  DirectionGrid pole;
  pole.rows = 4;
  pole.columns = 4;
  pole.directions.assign(16, glm::dvec3(0.0, 0.0, 1.0));
  pole.weights.assign(16, 0.1);
  auto singular = HemisphereFit::create(pole, 1, 0.0);
  ASSERT_FALSE(singular.ok());
  EXPECT_NE(singular.error().message.find("singular"), std::string::npos) << singular.error().message;
  EXPECT_TRUE(HemisphereFit::create(pole, 1, kDefaultRegularization).ok());
}

TEST(Smoothing, WindowsAndSpatialAveraging) {
  const auto none = bandWindow(SmoothingWindow::None, 8);
  const auto hann = bandWindow(SmoothingWindow::Hann, 8);
  const auto lanczos = bandWindow(SmoothingWindow::Lanczos, 8);
  ASSERT_EQ(hann.size(), 9u);
  EXPECT_EQ(none[8], 1.0);
  EXPECT_EQ(hann[0], 1.0);
  EXPECT_EQ(lanczos[0], 1.0);
  for (int l = 1; l <= 8; ++l) {
    EXPECT_LE(hann[l], hann[l - 1]);
    EXPECT_LE(lanczos[l], lanczos[l - 1]);
    EXPECT_GT(hann[l], 0.0);
  }
  // A line of 4 samples: averaging with 3 neighbours of the first gives the mean of all 4.
  std::vector<glm::vec3> pos = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  std::vector<std::array<uint32_t, 2>> adj = {{0, 1}, {1, 2}, {2, 3}};
  std::vector<float> c = {0, 4, 8, 12};
  smoothSpatially(c, 1, pos, adj, 3);
  EXPECT_FLOAT_EQ(c[0], 6.0f);
  EXPECT_FLOAT_EQ(c[3], 6.0f);
  std::vector<float> same = {2, 2, 2, 2};
  smoothSpatially(same, 1, pos, adj, 5);
  for (float v : same) EXPECT_FLOAT_EQ(v, 2.0f);
}

}  // namespace
}  // namespace shrefract::bake
