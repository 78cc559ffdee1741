#include <shrefract/bake/fit.h>
#include <shrefract/field_decode.h>
#include <shrefract/sh.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>

#include <Eigen/Dense>

#include "robust_fit.h"

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

// The basis at every grid direction, directions x basis, row-major.
std::vector<double> basisAtDirections(const DirectionGrid& grid, int order, int nb) {
  const size_t nd = grid.directions.size();
  std::vector<double> y(nd * nb);
  for (size_t d = 0; d < nd; ++d)
    sh::evaluate(order, grid.directions[d].x, grid.directions[d].y, grid.directions[d].z, &y[d * nb]);
  return y;
}

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// W Y: the basis at each grid direction weighted by the direction's solid angle, directions x basis.
// Its transpose is the plain projection (FitMethod::PlainProjection), basis x directions.
RowMajor weightedBasis(const DirectionGrid& grid, const std::vector<double>& y, int nb) {
  const Eigen::Index nd = Eigen::Index(grid.directions.size());
  const Eigen::Map<const RowMajor> basis(y.data(), nd, nb);
  const Eigen::Map<const Eigen::VectorXd> weights(grid.weights.data(), nd);
  return (basis.array().colwise() * weights.array()).matrix();
}

// The penalty lambda R, R = diag((l (l+1))^2): its diagonal, one value per basis function.
Eigen::VectorXd penaltyDiagonal(int order, double lambda) {
  Eigen::VectorXd p(sh::basisCount(order));
  for (int l = 0; l <= order; ++l) {
    const double r = double(l) * (l + 1);
    for (int m = -l; m <= l; ++m) p(sh::index(l, m)) = lambda * r * r;
  }
  return p;
}

// Normal equations (Y^T W Y + lambda R) c = Y^T W f solved by Eigen's Cholesky (LLT) for every
// direction's column of Y^T W: the projection, basis x directions. Nothing where the system is
// not positive definite.
std::optional<RowMajor> regularizedProjection(const std::vector<double>& y, const RowMajor& weighted, int order,
                                              double lambda) {
  const Eigen::Map<const RowMajor> basis(y.data(), weighted.rows(), weighted.cols());
  Eigen::MatrixXd a = basis.transpose() * weighted;
  a.diagonal() += penaltyDiagonal(order, lambda);
  const Eigen::LLT<Eigen::MatrixXd> llt(a);
  if (llt.info() != Eigen::Success) return std::nullopt;
  return RowMajor(llt.solve(weighted.transpose()));
}

Result<void> checkFitInput(const DirectionGrid& grid, int order, double lambda, FitMethod method) {
  if (order < 0 || order > kMaxFitOrder)
    return makeError(ErrorCode::InvalidArgument,
                     "SH order " + std::to_string(order) + " is outside 0.." + std::to_string(kMaxFitOrder));
  const int nb = sh::basisCount(order);
  const size_t nd = grid.directions.size();
  if (nd == 0) return makeError(ErrorCode::InvalidArgument, "empty direction grid");
  if (method != FitMethod::PlainProjection && nd < size_t(nb) && lambda <= 0.0)
    return makeError(ErrorCode::InvalidArgument, "direction grid has fewer directions (" + std::to_string(nd) +
                                                     ") than basis functions (" + std::to_string(nb) + ")");
  if (!(lambda >= 0.0) || !std::isfinite(lambda))
    return makeError(ErrorCode::InvalidArgument, "regularization must be finite and >= 0");
  return {};
}

}  // namespace

Result<HemisphereFit> HemisphereFit::create(const DirectionGrid& grid, int order, double lambda, FitMethod method) {
  if (auto r = checkFitInput(grid, order, lambda, method); !r) return r.error();
  const int nb = sh::basisCount(order);
  const size_t nd = grid.directions.size();
  HemisphereFit fit;
  fit.order_ = order;
  fit.basis_ = nb;
  fit.directions_ = static_cast<uint32_t>(nd);
  const std::vector<double> y = basisAtDirections(grid, order, nb);
  fit.basisAtGrid_.assign(y.size(), 0.0f);
  std::transform(y.begin(), y.end(), fit.basisAtGrid_.begin(), [](double v) { return static_cast<float>(v); });
  if (method == FitMethod::RobustLeastSquares) {
    if (!isProductGrid(grid))
      return makeError(ErrorCode::InvalidArgument, "the robust SH fit needs a (theta, phi) grid of makeHemisphereGrid");
    const Eigen::VectorXd p = penaltyDiagonal(order, lambda);
    fit.robust_ = std::make_shared<const RobustReweighting>(grid, order, std::vector<double>(p.data(), p.data() + p.size()));
  }
  const RowMajor weighted = weightedBasis(grid, y, nb);
  std::optional<RowMajor> projection = method == FitMethod::PlainProjection
                                           ? RowMajor(weighted.transpose())
                                           : regularizedProjection(y, weighted, order, lambda);
  if (!projection)
    return makeError(ErrorCode::InvalidArgument, "hemisphere fit: the normal equations are singular for order " +
                                                     std::to_string(order) + " on a " + std::to_string(grid.rows) +
                                                     "x" + std::to_string(grid.columns) +
                                                     " grid; raise the regularization or the direction density");
  // Stored direction-major (P^T) for fit()'s axpy loop.
  fit.projectionT_.resize(size_t(nb) * nd);
  for (int i = 0; i < nb; ++i)
    for (size_t d = 0; d < nd; ++d)
      fit.projectionT_[d * size_t(nb) + size_t(i)] = static_cast<float>((*projection)(i, Eigen::Index(d)));
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
  if (robust_ && channels >= 3) robust_->apply(values, channels, coeffs);
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
  // The engine's sum (field_decode.h); a zero direction is read as the normal rather than as NaN.
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
