// CPU checks of the real SH basis: orthonormality by exact quadrature, the order-2 Cartesian
// forms, an independent reference (std::sph_legendre), float against double, finiteness at high
// order and at the poles, the addition theorem per band, input normalization, and the windows.
#include <gtest/gtest.h>
#include <shrefract/sh.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

namespace {

namespace sh = shrefract::sh;
using std::numbers::pi;

static_assert(sh::basisCount(0) == 1 && sh::basisCount(2) == 9 && sh::basisCount(8) == 81);
static_assert(sh::index(0, 0) == 0 && sh::index(1, -1) == 1 && sh::index(2, 2) == 8);
static_assert(sh::index(sh::kMaxOrder, sh::kMaxOrder) == sh::basisCount(sh::kMaxOrder) - 1);

struct Dir {
  double x, y, z;
};

std::vector<Dir> randomDirections(int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Dir> dirs;
  while (static_cast<int>(dirs.size()) < count) {
    const double x = normal(rng), y = normal(rng), z = normal(rng);
    const double len = std::sqrt(x * x + y * y + z * z);
    if (len < 1e-6) continue;
    dirs.push_back({x / len, y / len, z / len});
  }
  return dirs;
}

// Random directions within 0.05 rad of a pole: the worst case for float rounding.
std::vector<Dir> nearPoleDirections(int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Dir> dirs;
  for (int k = 0; k < count; ++k) {
    const double theta = 0.05 * uniform(rng);
    const double phi = 2.0 * pi * uniform(rng);
    const double sz = (k % 2 == 0) ? 1.0 : -1.0;
    dirs.push_back(
        {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), sz * std::cos(theta)});
  }
  return dirs;
}

// Poles, equator points and a few near-pole directions: where recurrences usually break.
std::vector<Dir> specialDirections() {
  std::vector<Dir> dirs = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  for (int k = 0; k < 16; ++k) {
    const double phi = 2.0 * pi * k / 16.0;
    dirs.push_back({std::cos(phi), std::sin(phi), 0.0});
  }
  for (double eps : {1e-3, 1e-7, 1e-12}) {
    const double s = std::sqrt(1.0 - eps * eps);
    dirs.push_back({eps, 0.0, s});
    dirs.push_back({0.0, eps, -s});
  }
  return dirs;
}

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n, Golub-Welsch not needed at n=32).
void gaussLegendre(int n, std::vector<double>& nodes, std::vector<double>& weights) {
  nodes.assign(static_cast<size_t>(n), 0.0);
  weights.assign(static_cast<size_t>(n), 0.0);
  for (int i = 0; i < n; ++i) {
    double x = std::cos(pi * (i + 0.75) / (n + 0.5));
    double dp = 0.0;
    for (int iter = 0; iter < 100; ++iter) {
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (x * p1 - p0) / (x * x - 1.0);
      const double dx = p1 / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    nodes[static_cast<size_t>(i)] = x;
    weights[static_cast<size_t>(i)] = 2.0 / ((1.0 - x * x) * dp * dp);
  }
}

TEST(ShTest, OrthonormalByQuadratureAtOrder20) {
  // Products of two order-20 functions have degree <= 40: 32 Gauss-Legendre nodes in z are exact
  // to degree 63 and 64 uniform azimuths are exact for trigonometric degree < 64.
  constexpr int kOrder = sh::kMaxOrder;
  constexpr int kNz = 32;
  constexpr int kNphi = 64;
  constexpr int kN = sh::basisCount(kOrder);
  std::vector<double> nodes, weights;
  gaussLegendre(kNz, nodes, weights);

  std::vector<double> gram(static_cast<size_t>(kN * kN), 0.0);
  std::vector<double> y(static_cast<size_t>(kN));
  for (int iz = 0; iz < kNz; ++iz) {
    const double z = nodes[static_cast<size_t>(iz)];
    const double r = std::sqrt(1.0 - z * z);
    const double w = weights[static_cast<size_t>(iz)] * (2.0 * pi / kNphi);
    for (int ip = 0; ip < kNphi; ++ip) {
      const double phi = 2.0 * pi * ip / kNphi;
      sh::evaluate(kOrder, r * std::cos(phi), r * std::sin(phi), z, y.data());
      for (int i = 0; i < kN; ++i) {
        const double wyi = w * y[static_cast<size_t>(i)];
        double* row = &gram[static_cast<size_t>(i * kN)];
        for (int j = 0; j <= i; ++j) row[j] += wyi * y[static_cast<size_t>(j)];
      }
    }
  }
  double worst = 0.0;
  for (int i = 0; i < kN; ++i) {
    for (int j = 0; j <= i; ++j) {
      const double expected = i == j ? 1.0 : 0.0;
      const double err = std::abs(gram[static_cast<size_t>(i * kN + j)] - expected);
      worst = std::max(worst, err);
      ASSERT_NEAR(gram[static_cast<size_t>(i * kN + j)], expected, 1e-10)
          << "i=" << i << " j=" << j;
    }
  }
  std::printf("orthonormality at L=%d: max |G - I| = %.3g\n", kOrder, worst);
}

TEST(ShTest, Order2MatchesCartesianForms) {
  // Exact constants: 1/(2 sqrt(pi)), sqrt(3/(4 pi)), sqrt(15/(4 pi)), sqrt(5/(16 pi)),
  // sqrt(15/(16 pi)). The six-digit ones are those of the usual listings (the slides print
  // 0.488602 for sqrt(3/(4 pi)) = 0.4886025...).
  const double c0 = 0.5 / std::sqrt(pi), c1 = std::sqrt(3.0 / (4.0 * pi));
  const double c2 = std::sqrt(15.0 / (4.0 * pi)), c20 = std::sqrt(5.0 / (16.0 * pi));
  const double c22 = std::sqrt(15.0 / (16.0 * pi));
  auto dirs = randomDirections(1000, 1);
  auto special = specialDirections();
  dirs.insert(dirs.end(), special.begin(), special.end());
  for (const Dir& d : dirs) {
    const double x = d.x, y = d.y, z = d.z;
    std::array<double, 9> v{};
    sh::evaluate(2, x, y, z, v.data());
    const std::array<double, 9> exact = {c0,
                                         c1 * y,
                                         c1 * z,
                                         c1 * x,
                                         c2 * x * y,
                                         c2 * y * z,
                                         c20 * (3.0 * z * z - 1.0),
                                         c2 * x * z,
                                         c22 * (x * x - y * y)};
    const std::array<double, 9> listed = {0.282095,
                                          0.488603 * y,
                                          0.488603 * z,
                                          0.488603 * x,
                                          1.092548 * x * y,
                                          1.092548 * y * z,
                                          0.315392 * (3.0 * z * z - 1.0),
                                          1.092548 * x * z,
                                          0.546274 * (x * x - y * y)};
    for (size_t i = 0; i < 9; ++i) {
      EXPECT_NEAR(v[i], exact[i], 1e-14) << "i=" << i;
      EXPECT_NEAR(v[i], listed[i], 1e-6) << "i=" << i;
    }
    // The slides' form of index 6 and their 0.488602 for index 1.
    EXPECT_NEAR(v[6], 0.630783 * z * z - 0.315392 * (x * x + y * y), 1e-6);
    EXPECT_NEAR(v[1], 0.488602 * y, 1e-6);

    std::array<float, 9> vf{};
    sh::evaluate(2, static_cast<float>(x), static_cast<float>(y), static_cast<float>(z), vf.data());
    for (size_t i = 0; i < 9; ++i)
      EXPECT_NEAR(static_cast<double>(vf[i]), exact[i], 1e-6) << "i=" << i;
  }
}

#if defined(__cpp_lib_math_special_functions)
TEST(ShTest, MatchesStdSphLegendreReference) {
  // std::sph_legendre(l, m, theta) = (-1)^m K_l^m P_l^m(cos theta) (it carries the Condon-Shortley
  // phase; we do not), an implementation independent of ours.
  constexpr int kOrder = 15;
  std::vector<double> v(static_cast<size_t>(sh::basisCount(kOrder)));
  auto dirs = randomDirections(200, 2);
  auto special = specialDirections();
  dirs.insert(dirs.end(), special.begin(), special.end());
  for (const Dir& d : dirs) {
    // libstdc++ computes sin(theta) as sqrt(1 - cos^2(theta)), which is 0 within 1e-8 rad of a
    // pole: skip those (FiniteUpToOrder30IncludingPolesAndEquator checks the poles themselves).
    const double rho = std::hypot(d.x, d.y);
    if (rho > 0.0 && rho < 1e-6) continue;
    sh::evaluate(kOrder, d.x, d.y, d.z, v.data());
    // atan2 keeps theta accurate near the poles, where acos(z) loses it.
    const double theta = std::atan2(rho, d.z);
    const double phi = std::atan2(d.y, d.x);
    for (int l = 0; l <= kOrder; ++l) {
      for (int m = 0; m <= l; ++m) {
        const double sign = (m % 2 == 0) ? 1.0 : -1.0;
        const double p =
            sign * std::sph_legendre(static_cast<unsigned>(l), static_cast<unsigned>(m), theta);
        if (m == 0) {
          EXPECT_NEAR(v[static_cast<size_t>(sh::index(l, 0))], p, 1e-12) << "l=" << l;
        } else {
          EXPECT_NEAR(v[static_cast<size_t>(sh::index(l, m))],
                      std::sqrt(2.0) * p * std::cos(m * phi), 1e-12)
              << "l=" << l << " m=" << m;
          EXPECT_NEAR(v[static_cast<size_t>(sh::index(l, -m))],
                      std::sqrt(2.0) * p * std::sin(m * phi), 1e-12)
              << "l=" << l << " m=" << -m;
        }
      }
    }
  }
}
#else
TEST(ShTest, MatchesStdSphLegendreReference) {
  GTEST_SKIP() << "std::sph_legendre is not available in this standard library";
}
#endif

TEST(ShTest, FloatMatchesDoubleUpToOrder20) {
  // Tolerance: float rounding (eps = 6e-8) accumulates about linearly in l through the
  // recurrences, times |Y| <= sqrt((2l+1)/(4 pi)); measured worst cases are 1.3e-6 at L = 8,
  // 2.5e-6 at L = 16 and 3.2e-6 at L = 20 (over 3e5 directions, a third near the poles).
  // 5e-6 leaves headroom for other compilers' contraction choices.
  constexpr int kOrder = sh::kMaxOrder;
  constexpr size_t kN = static_cast<size_t>(sh::basisCount(kOrder));
  constexpr double kTolerance = 5e-6;
  std::vector<double> vd(kN);
  std::vector<float> vf(kN);
  auto dirs = randomDirections(20000, 3);
  auto nearPoles = nearPoleDirections(20000, 7);
  auto special = specialDirections();
  dirs.insert(dirs.end(), nearPoles.begin(), nearPoles.end());
  dirs.insert(dirs.end(), special.begin(), special.end());
  std::vector<double> worst(kOrder + 1, 0.0);
  for (const Dir& d : dirs) {
    // Compare on the same (float-rounded) input so that only the evaluation differs.
    const float fx = static_cast<float>(d.x), fy = static_cast<float>(d.y),
                fz = static_cast<float>(d.z);
    sh::evaluate(kOrder, static_cast<double>(fx), static_cast<double>(fy), static_cast<double>(fz),
                 vd.data());
    sh::evaluate(kOrder, fx, fy, fz, vf.data());
    for (int l = 0; l <= kOrder; ++l) {
      for (int i = sh::index(l, -l); i <= sh::index(l, l); ++i) {
        const double err =
            std::abs(static_cast<double>(vf[static_cast<size_t>(i)]) - vd[static_cast<size_t>(i)]);
        worst[static_cast<size_t>(l)] = std::max(worst[static_cast<size_t>(l)], err);
      }
    }
  }
  for (int l : {8, 16, 20}) {
    std::printf("float vs double, band %d: max abs diff = %.3g (tolerance %.3g)\n", l,
                worst[static_cast<size_t>(l)], kTolerance);
  }
  for (int l = 0; l <= kOrder; ++l)
    EXPECT_LE(worst[static_cast<size_t>(l)], kTolerance) << "band " << l;
}

TEST(ShTest, FiniteUpToOrder30IncludingPolesAndEquator) {
  constexpr int kOrder = 30;
  constexpr size_t kN = static_cast<size_t>(sh::basisCount(kOrder));
  std::vector<double> vd(kN);
  std::vector<float> vf(kN);
  auto dirs = randomDirections(2000, 4);
  auto special = specialDirections();
  dirs.insert(dirs.end(), special.begin(), special.end());
  for (const Dir& d : dirs) {
    sh::evaluate(kOrder, d.x, d.y, d.z, vd.data());
    sh::evaluate(kOrder, static_cast<float>(d.x), static_cast<float>(d.y), static_cast<float>(d.z),
                 vf.data());
    for (size_t i = 0; i < kN; ++i) {
      ASSERT_TRUE(std::isfinite(vd[i])) << "i=" << i;
      ASSERT_TRUE(std::isfinite(vf[i])) << "i=" << i;
      // |Y_lm| <= sqrt((2l+1)/(4 pi)) (a consequence of the addition theorem).
      ASSERT_LE(std::abs(vd[i]), std::sqrt(61.0 / (4.0 * pi)) + 1e-9) << "i=" << i;
    }
  }
  // At the poles only the zonal functions survive: Y_l0(+-z) = (+-1)^l sqrt((2l+1)/(4 pi)).
  for (double sz : {1.0, -1.0}) {
    sh::evaluate(kOrder, 0.0, 0.0, sz, vd.data());
    for (int l = 0; l <= kOrder; ++l) {
      for (int m = -l; m <= l; ++m) {
        const double expected =
            m != 0 ? 0.0 : std::pow(sz, l) * std::sqrt((2.0 * l + 1.0) / (4.0 * pi));
        EXPECT_NEAR(vd[static_cast<size_t>(sh::index(l, m))], expected, 1e-12)
            << "l=" << l << " m=" << m;
      }
    }
  }
}

TEST(ShTest, BandEnergyIsRotationInvariant) {
  // Addition theorem: sum_m Y_lm(w)^2 = (2l+1)/(4 pi) for every direction w.
  constexpr int kOrder = 30;
  std::vector<double> v(static_cast<size_t>(sh::basisCount(kOrder)));
  auto dirs = randomDirections(2000, 5);
  auto special = specialDirections();
  dirs.insert(dirs.end(), special.begin(), special.end());
  double worst = 0.0;
  for (const Dir& d : dirs) {
    sh::evaluate(kOrder, d.x, d.y, d.z, v.data());
    for (int l = 0; l <= kOrder; ++l) {
      double sum = 0.0;
      for (int m = -l; m <= l; ++m)
        sum += v[static_cast<size_t>(sh::index(l, m))] * v[static_cast<size_t>(sh::index(l, m))];
      const double expected = (2.0 * l + 1.0) / (4.0 * pi);
      worst = std::max(worst, std::abs(sum - expected));
      ASSERT_NEAR(sum, expected, 1e-10) << "l=" << l;
    }
  }
  std::printf("band energy up to L=%d: max abs error = %.3g\n", kOrder, worst);
}

TEST(ShTest, NormalizesInputAndMapsZeroToPlusZ) {
  constexpr int kOrder = 6;
  constexpr size_t kN = static_cast<size_t>(sh::basisCount(kOrder));
  std::vector<double> unit(kN), scaled(kN);
  for (const Dir& d : randomDirections(50, 6)) {
    sh::evaluate(kOrder, d.x, d.y, d.z, unit.data());
    for (double s : {1e-300, 0.25, 3.0, 1e300}) {
      sh::evaluate(kOrder, s * d.x, s * d.y, s * d.z, scaled.data());
      for (size_t i = 0; i < kN; ++i) EXPECT_NEAR(scaled[i], unit[i], 1e-13) << "scale " << s;
    }
  }
  std::vector<double> zero(kN), plusZ(kN);
  sh::evaluate(kOrder, 0.0, 0.0, 0.0, zero.data());
  sh::evaluate(kOrder, 0.0, 0.0, 1.0, plusZ.data());
  for (size_t i = 0; i < kN; ++i) EXPECT_EQ(zero[i], plusZ[i]);
  std::vector<float> zeroF(kN);
  sh::evaluate(kOrder, 0.0f, 0.0f, 0.0f, zeroF.data());
  for (size_t i = 0; i < kN; ++i) EXPECT_NEAR(static_cast<double>(zeroF[i]), plusZ[i], 1e-6);
}

TEST(ShTest, WindowsStartAtOneAndNeverIncrease) {
  for (int width : {1, 2, 5, 9, 21}) {
    EXPECT_DOUBLE_EQ(sh::windowHann(0, width), 1.0);
    double previous = 1.0;
    for (int l = 0; l <= 40; ++l) {
      const double w = sh::windowHann(l, width);
      EXPECT_LE(w, previous) << "width=" << width << " l=" << l;
      EXPECT_GE(w, 0.0);
      if (l >= width) {
        EXPECT_EQ(w, 0.0);
      }
      previous = w;
    }
  }
  EXPECT_NEAR(sh::windowHann(2, 4), 0.5, 1e-15);
  for (int order : {0, 1, 4, 8, 20}) {
    EXPECT_DOUBLE_EQ(sh::windowLanczos(0, order), 1.0);
    double previous = 1.0;
    for (int l = 0; l <= 40; ++l) {
      const double w = sh::windowLanczos(l, order);
      EXPECT_LE(w, previous) << "order=" << order << " l=" << l;
      EXPECT_GE(w, 0.0);
      if (l > order) {
        EXPECT_EQ(w, 0.0);
      }
      previous = w;
    }
  }
  // sinc(pi/2) = 2/pi at l = (order+1)/2.
  EXPECT_NEAR(sh::windowLanczos(4, 7), 2.0 / pi, 1e-15);
}

TEST(ShTest, ApplyWindowScalesEachBandOfEveryChannel) {
  constexpr int kOrder = 3;
  constexpr int kChannels = 4;
  constexpr int kN = sh::basisCount(kOrder);
  std::vector<float> coeffs(static_cast<size_t>(kN * kChannels), 2.0f);
  const double weights[kOrder + 1] = {1.0, 0.5, 0.25, 0.0};
  sh::applyWindow(kOrder, weights, coeffs.data(), kChannels);
  for (int l = 0; l <= kOrder; ++l) {
    for (int m = -l; m <= l; ++m) {
      for (int c = 0; c < kChannels; ++c) {
        EXPECT_EQ(static_cast<double>(coeffs[static_cast<size_t>(sh::index(l, m) * kChannels + c)]),
                  2.0 * weights[l]);
      }
    }
  }
}

}  // namespace
