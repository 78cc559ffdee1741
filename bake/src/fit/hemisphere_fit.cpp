#include <shrefract/bake/fit.h>
#include <shrefract/sh.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace shrefract::bake {

DirectionGrid makeHemisphereGrid(uint32_t rows, uint32_t columns) {
  DirectionGrid g;
  g.rows = rows;
  g.columns = columns;
  const double dTheta = 0.5 * std::numbers::pi / rows;
  const double dPhi = 2.0 * std::numbers::pi / columns;
  g.directions.reserve(size_t(rows) * columns);
  g.weights.reserve(size_t(rows) * columns);
  for (uint32_t i = 0; i < rows; ++i) {
    const double theta0 = i * dTheta, theta1 = (i + 1) * dTheta;
    const double theta = (i + 0.5) * dTheta;
    // Exact solid angle of the cell: (cos theta0 - cos theta1) dphi.
    const double weight = (std::cos(theta0) - std::cos(theta1)) * dPhi;
    for (uint32_t j = 0; j < columns; ++j) {
      const double phi = (j + 0.5) * dPhi;
      g.directions.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      g.weights.push_back(weight);
    }
  }
  return g;
}

namespace {

// In-place Cholesky factorization of a symmetric positive definite n x n matrix (lower triangle).
bool cholesky(std::vector<double>& a, int n) {
  for (int j = 0; j < n; ++j) {
    double d = a[size_t(j) * n + j];
    for (int k = 0; k < j; ++k) d -= a[size_t(j) * n + k] * a[size_t(j) * n + k];
    if (!(d > 0.0)) return false;
    d = std::sqrt(d);
    a[size_t(j) * n + j] = d;
    for (int i = j + 1; i < n; ++i) {
      double s = a[size_t(i) * n + j];
      for (int k = 0; k < j; ++k) s -= a[size_t(i) * n + k] * a[size_t(j) * n + k];
      a[size_t(i) * n + j] = s / d;
    }
  }
  return true;
}

// Solves L L^T x = b in place.
void choleskySolve(const std::vector<double>& l, int n, double* b) {
  for (int i = 0; i < n; ++i) {
    double s = b[i];
    for (int k = 0; k < i; ++k) s -= l[size_t(i) * n + k] * b[k];
    b[i] = s / l[size_t(i) * n + i];
  }
  for (int i = n - 1; i >= 0; --i) {
    double s = b[i];
    for (int k = i + 1; k < n; ++k) s -= l[size_t(k) * n + i] * b[k];
    b[i] = s / l[size_t(i) * n + i];
  }
}

}  // namespace

Result<HemisphereFit> HemisphereFit::create(const DirectionGrid& grid, int order, double lambda, FitMethod method) {
  if (order < 0 || order > kMaxFitOrder)
    return makeError(ErrorCode::InvalidArgument,
                     "SH order " + std::to_string(order) + " is outside 0.." + std::to_string(kMaxFitOrder));
  const int nb = sh::basisCount(order);
  const size_t nd = grid.directions.size();
  if (nd == 0) return makeError(ErrorCode::InvalidArgument, "empty direction grid");
  if (method == FitMethod::RegularizedLeastSquares && nd < size_t(nb) && lambda <= 0.0)
    return makeError(ErrorCode::InvalidArgument, "direction grid has fewer directions (" + std::to_string(nd) +
                                                     ") than basis functions (" + std::to_string(nb) + ")");
  if (!(lambda >= 0.0) || !std::isfinite(lambda))
    return makeError(ErrorCode::InvalidArgument, "regularization must be finite and >= 0");

  HemisphereFit fit;
  fit.order_ = order;
  fit.basis_ = nb;
  fit.directions_ = static_cast<uint32_t>(nd);
  std::vector<double> y(nd * nb);  // directions x basis
  for (size_t d = 0; d < nd; ++d)
    sh::evaluate(order, grid.directions[d].x, grid.directions[d].y, grid.directions[d].z, &y[d * nb]);
  fit.basisAtGrid_.resize(y.size());
  for (size_t k = 0; k < y.size(); ++k) fit.basisAtGrid_[k] = static_cast<float>(y[k]);

  std::vector<double> projection(size_t(nb) * nd);
  if (method == FitMethod::PlainProjection) {
    for (int i = 0; i < nb; ++i)
      for (size_t d = 0; d < nd; ++d) projection[size_t(i) * nd + d] = grid.weights[d] * y[d * nb + i];
  } else {
    // Normal equations (Y^T W Y + lambda R) c = Y^T W f, with R = diag((l (l+1))^2).
    std::vector<double> a(size_t(nb) * nb, 0.0);
    for (size_t d = 0; d < nd; ++d) {
      const double w = grid.weights[d];
      const double* row = &y[d * nb];
      for (int i = 0; i < nb; ++i) {
        const double wi = w * row[i];
        for (int j = 0; j <= i; ++j) a[size_t(i) * nb + j] += wi * row[j];
      }
    }
    for (int l = 0; l <= order; ++l) {
      const double r = double(l) * (l + 1);
      for (int m = -l; m <= l; ++m) {
        const int i = sh::index(l, m);
        a[size_t(i) * nb + i] += lambda * r * r;
      }
    }
    for (int i = 0; i < nb; ++i)
      for (int j = i + 1; j < nb; ++j) a[size_t(i) * nb + j] = a[size_t(j) * nb + i];
    if (!cholesky(a, nb))
      return makeError(ErrorCode::InvalidArgument, "hemisphere fit: the normal equations are singular for order " +
                                                       std::to_string(order) + " on a " + std::to_string(grid.rows) +
                                                       "x" + std::to_string(grid.columns) +
                                                       " grid; raise the regularization or the direction density");
    std::vector<double> column(nb);
    for (size_t d = 0; d < nd; ++d) {
      for (int i = 0; i < nb; ++i) column[i] = grid.weights[d] * y[d * nb + i];
      choleskySolve(a, nb, column.data());
      for (int i = 0; i < nb; ++i) projection[size_t(i) * nd + d] = column[i];
    }
  }
  fit.projectionT_.resize(projection.size());
  for (int i = 0; i < nb; ++i)
    for (size_t d = 0; d < nd; ++d)
      fit.projectionT_[d * size_t(nb) + size_t(i)] = static_cast<float>(projection[size_t(i) * nd + d]);
  return fit;
}

void HemisphereFit::fit(const float* values, uint32_t channels, float* coeffs) const {
  // c = P v as a sequence of axpy over the basis (P stored direction-major): each coefficient's
  // sum runs in a fixed order (deterministic) and the inner loop vectorizes without reassociation.
  thread_local std::vector<float> acc;
  acc.assign(size_t(basis_) * channels, 0.0f);
  for (uint32_t d = 0; d < directions_; ++d) {
    const float* p = &projectionT_[size_t(d) * basis_];
    const float* v = &values[size_t(d) * channels];
    for (uint32_t c = 0; c < channels; ++c) {
      const float vc = v[c];
      float* a = &acc[size_t(c) * basis_];
      for (int i = 0; i < basis_; ++i) a[i] += p[i] * vc;
    }
  }
  for (int i = 0; i < basis_; ++i)
    for (uint32_t c = 0; c < channels; ++c) coeffs[size_t(i) * channels + c] = acc[size_t(c) * basis_ + size_t(i)];
}

void HemisphereFit::reconstructAtGrid(const float* coeffs, uint32_t channels, uint32_t d, float* out) const {
  const float* y = &basisAtGrid_[size_t(d) * basis_];
  for (uint32_t c = 0; c < channels; ++c) {
    double s = 0.0;
    for (int i = 0; i < basis_; ++i) s += static_cast<double>(coeffs[size_t(i) * channels + c]) * static_cast<double>(y[i]);
    out[c] = static_cast<float>(s);
  }
}

void evaluateExpansion(int order, const float* coeffs, uint32_t channels, glm::vec3 w, float* out) {
  // The engine's sum (field.h); a zero direction is read as the normal rather than as NaN.
  if (!(w.x * w.x + w.y * w.y + std::max(w.z, 0.0f) * std::max(w.z, 0.0f) > 0.0f)) w = glm::vec3(0.0f, 0.0f, 1.0f);
  const EncodingShape shape{Encoding::Sh, static_cast<uint32_t>(order), 0, 0, channels};
  evaluateCoefficients(shape, coeffs, nullptr, {w.x, w.y, w.z}, out);
}

std::vector<double> bandWindow(SmoothingWindow window, int order) {
  std::vector<double> w(static_cast<size_t>(order) + 1, 1.0);
  for (int l = 0; l <= order; ++l) {
    if (window == SmoothingWindow::Hann) w[static_cast<size_t>(l)] = sh::windowHann(l, order + 1);
    if (window == SmoothingWindow::Lanczos) w[static_cast<size_t>(l)] = sh::windowLanczos(l, order);
  }
  return w;
}

}  // namespace shrefract::bake
