// Real SH evaluation by normalized recurrences. The polynomial part in z and the azimuthal part
// (x + i y)^m are kept apart:
//   Y_l^{+m} = Pbar_l^m(z) * C_m,  Y_l^{-m} = Pbar_l^m(z) * S_m,  C_m + i S_m = (x + i y)^m,
// where Pbar_l^m carries the whole normalization (and sqrt(2) for m > 0), and sin^m(theta) lives
// in C_m, S_m. docs/technique.md derives the recurrences:
//   Pbar_0^0 = 1/sqrt(4 pi)
//   Pbar_m^m = d_m Pbar_{m-1}^{m-1},  d_m = sqrt((2m+1)/(2m)), times sqrt(2) at m = 1
//   and for l > m, with s = sign(z) (+1 at z = 0), v = z - s = -s (x^2 + y^2) / (1 + |z|):
//   D_l      = a_lm v Pbar_{l-1}^m + s c_lm D_{l-1}           (D_m = 0)
//   Pbar_l^m = s t_lm Pbar_{l-1}^m + D_l
//   g_lm = sqrt((2l+1) / ((2l-1)(l-m)(l+m))),
//   a_lm = (2l-1) g_lm,  c_lm = (l-1-m) g_lm,  t_lm = (l+m) g_lm.
// This is the textbook three-term recurrence Pbar_l = a (z Pbar_{l-1} - b Pbar_{l-2}) rewritten on
// the differences D_l = Pbar_l - s t_lm Pbar_{l-1} (t_lm = Pbar_l^m(1) / Pbar_{l-1}^m(1)). Near the
// poles the three-term form sits on a double root and its rounding errors grow ~ l^2 eps; the
// difference form only multiplies them by |v| ~ theta^2/2 there, and v comes from rho^2, which is
// accurate where 1 - |z| is not. In float the worst error at order 16 drops from 2.6e-5 to
// 2.5e-6. No factorial appears: every constant is a ratio of small integers.
#include <shrefract/sh.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace shrefract::sh {
namespace {

// Orders whose constants are tabulated; higher orders compute them on the fly (same formulas,
// same results, slower). 64 covers every order the project uses with room to spare.
constexpr int kTableOrder = 64;

double diagFactor(int m) {
  const double dm = static_cast<double>(m);
  const double f = std::sqrt((2.0 * dm + 1.0) / (2.0 * dm));
  return m == 1 ? f * std::numbers::sqrt2 : f;
}

// a_lm, c_lm and t_lm of the recurrence above, for l > m >= 0.
struct Step {
  double a, c, t;
};

Step stepConstants(int l, int m) {
  const double dl = static_cast<double>(l);
  const double dm = static_cast<double>(m);
  const double g = std::sqrt((2.0 * dl + 1.0) / ((2.0 * dl - 1.0) * (dl - dm) * (dl + dm)));
  return {(2.0 * dl - 1.0) * g, (dl - 1.0 - dm) * g, (dl + dm) * g};
}

// Constants for 0 <= m <= l <= kTableOrder, steps indexed by index(l, m) (the m < 0 slots are
// unused: simpler indexing is worth the few kilobytes).
struct Table {
  std::vector<double> diag;  // d_m, m = 0..kTableOrder (d_0 unused)
  std::vector<Step> steps;   // at index(l, m), l > m

  Table()
      : diag(kTableOrder + 1, 1.0), steps(static_cast<size_t>(basisCount(kTableOrder)), Step{}) {
    for (int m = 1; m <= kTableOrder; ++m) diag[static_cast<size_t>(m)] = diagFactor(m);
    for (int m = 0; m <= kTableOrder; ++m) {
      for (int l = m + 1; l <= kTableOrder; ++l)
        steps[static_cast<size_t>(index(l, m))] = stepConstants(l, m);
    }
  }
};

const Table& table() {
  static const Table t;  // built once; function-local statics are thread-safe
  return t;
}

double diag(const Table& t, int m) {
  return m <= kTableOrder ? t.diag[static_cast<size_t>(m)] : diagFactor(m);
}

Step step(const Table& t, int l, int m) {
  return l <= kTableOrder ? t.steps[static_cast<size_t>(index(l, m))] : stepConstants(l, m);
}

template <class T>
void evaluateImpl(int order, T x, T y, T z, T* out) {
  if (order < 0) return;

  // Normalize; scaling by the largest component first keeps x*x + ... from overflowing or
  // underflowing. Zero (and NaN, through the negated comparison) becomes +z.
  const T largest = std::max(std::abs(x), std::max(std::abs(y), std::abs(z)));
  if (!(largest > T(0))) {
    x = T(0);
    y = T(0);
    z = T(1);
  } else {
    x /= largest;
    y /= largest;
    z /= largest;
    const T invLength = T(1) / std::sqrt(x * x + y * y + z * z);
    x *= invLength;
    y *= invLength;
    z *= invLength;
  }
  const T s = z < T(0) ? T(-1) : T(1);
  const T v = -s * (x * x + y * y) / (T(1) + std::abs(z));  // z - s, without cancellation

  const Table& tab = table();
  T pmm = static_cast<T>(0.5 / std::sqrt(std::numbers::pi));  // Pbar_0^0 = 1/sqrt(4 pi)
  T cm = T(1);                                                // C_0
  T sm = T(0);                                                // S_0
  for (int m = 0; m <= order; ++m) {
    if (m > 0) {
      const T cNext = x * cm - y * sm;
      sm = x * sm + y * cm;
      cm = cNext;
      pmm *= static_cast<T>(diag(tab, m));
    }
    out[index(m, m)] = pmm * cm;
    if (m > 0) out[index(m, -m)] = pmm * sm;

    T p = pmm;   // Pbar_{l-1}^m
    T d = T(0);  // D_{l-1}
    for (int l = m + 1; l <= order; ++l) {
      const Step k = step(tab, l, m);
      d = static_cast<T>(k.a) * v * p + s * static_cast<T>(k.c) * d;
      p = s * static_cast<T>(k.t) * p + d;
      out[index(l, m)] = p * cm;
      if (m > 0) out[index(l, -m)] = p * sm;
    }
  }
}

}  // namespace

void evaluate(int order, double x, double y, double z, double* out) {
  evaluateImpl<double>(order, x, y, z, out);
}

void evaluate(int order, float x, float y, float z, float* out) {
  evaluateImpl<float>(order, x, y, z, out);
}

double windowHann(int l, int width) {
  if (l < 0 || l >= width) return 0.0;
  return 0.5 *
         (1.0 + std::cos(std::numbers::pi * static_cast<double>(l) / static_cast<double>(width)));
}

double windowLanczos(int l, int order) {
  if (l < 0 || l > order) return 0.0;
  if (l == 0) return 1.0;
  const double t = std::numbers::pi * static_cast<double>(l) / static_cast<double>(order + 1);
  return std::sin(t) / t;
}

void applyWindow(int order, const double* bandWeights, float* coeffs, int channels) {
  for (int l = 0; l <= order; ++l) {
    const float w = static_cast<float>(bandWeights[l]);
    for (int i = index(l, -l); i <= index(l, l); ++i) {
      for (int c = 0; c < channels; ++c) coeffs[i * channels + c] *= w;
    }
  }
}

}  // namespace shrefract::sh
