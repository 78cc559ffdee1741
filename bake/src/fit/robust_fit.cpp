#include "robust_fit.h"

#include <shrefract/sh.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numbers>

#include <Eigen/Dense>

namespace shrefract::bake {

namespace {

// The angle between the expansion's exit and the traced one; a zero expansion is as far as can be.
double exitAngle(const double* fitted, const double* traced) {
  const double cx = fitted[1] * traced[2] - fitted[2] * traced[1];
  const double cy = fitted[2] * traced[0] - fitted[0] * traced[2];
  const double cz = fitted[0] * traced[1] - fitted[1] * traced[0];
  if (!(fitted[0] * fitted[0] + fitted[1] * fitted[1] + fitted[2] * fitted[2] > 0.0)) return std::numbers::pi;
  const double dot = fitted[0] * traced[0] + fitted[1] * traced[1] + fitted[2] * traced[2];
  return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), dot);
}

}  // namespace

bool isProductGrid(const DirectionGrid& grid) {
  const DirectionGrid product = makeHemisphereGrid(grid.rows, grid.columns);
  return grid.directions == product.directions && grid.weights == product.weights;
}

RobustReweighting::RobustReweighting(const DirectionGrid& grid, int order, std::vector<double> penalty)
    : order_(order), basis_(sh::basisCount(order)), slots_(2 * order + 1), rows_(grid.rows),
      columns_(grid.columns), penalty_(std::move(penalty)) {
  // At phi = 0 every function is its polar factor (cos 0 = 1); sin(|m| phi) shares the factor of
  // cos(|m| phi) (sh.cpp's recurrence writes p * C_m and p * S_m).
  polar_.resize(rows_, basis_);
  std::vector<double> y(static_cast<size_t>(basis_));
  for (uint32_t r = 0; r < rows_; ++r) {
    const glm::dvec3 w = grid.directions[size_t(r) * columns_];  // the row's theta at phi = 0
    sh::evaluate(order, std::hypot(w.x, w.y), 0.0, w.z, y.data());
    for (int l = 0; l <= order; ++l)
      for (int m = -l; m <= l; ++m) polar_(r, sh::index(l, m)) = y[size_t(sh::index(l, std::abs(m)))];
  }
  slotOf_.resize(size_t(basis_));
  basisOfSlot_.resize(size_t(slots_));
  for (int l = 0; l <= order; ++l)
    for (int m = -l; m <= l; ++m) {
      slotOf_[size_t(sh::index(l, m))] = m + order;
      basisOfSlot_[size_t(m + order)].push_back(sh::index(l, m));
    }
  for (const std::vector<int>& functions : basisOfSlot_) polarOfSlot_.push_back(polar_(Eigen::all, functions));
  azimuthal_.resize(slots_, columns_);
  cosines_.resize(slots_, columns_);
  sines_.resize(slots_, columns_);
  for (int s = 0; s < slots_; ++s) {
    const int m = s - order;
    for (uint32_t j = 0; j < columns_; ++j) {
      const double phi = std::atan2(grid.directions[j].y, grid.directions[j].x);
      azimuthal_(s, j) = m >= 0 ? std::cos(m * phi) : std::sin(-m * phi);
      cosines_(s, j) = std::cos(s * phi);
      sines_(s, j) = std::sin(s * phi);
    }
  }
  rowWeights_.resize(rows_);
  for (uint32_t r = 0; r < rows_; ++r) rowWeights_(r) = grid.weights[size_t(r) * columns_];
}

// sum_j u_j Phi_m(phi_j) Phi_n(phi_j) over a row from its weights' Fourier sums, by the
// product-to-sum identities.
double RobustReweighting::azimuthalProduct(const double* cosSums, const double* sinSums, int m, int n) const {
  const int a = std::abs(m), b = std::abs(n), sum = a + b, difference = std::abs(a - b);
  if (m >= 0 && n >= 0) return 0.5 * (cosSums[difference] + cosSums[sum]);
  if (m < 0 && n < 0) return 0.5 * (cosSums[difference] - cosSums[sum]);
  // sin(a phi) cos(b phi) = (sin((a + b) phi) + sin((a - b) phi)) / 2, with sin the odd one.
  const int sinIndex = m < 0 ? a : b, cosIndex = m < 0 ? b : a;
  const double sign = sinIndex > cosIndex ? 1.0 : sinIndex < cosIndex ? -1.0 : 0.0;
  return 0.5 * (sinSums[sum] + sign * sinSums[difference]);
}

// Y^T U Y = sum over rows r of polar_r T_r polar_r^T, T_r(i, n) the azimuthal product of the two
// functions' m: each slot's columns are (functions x rows, scaled by T) x (rows x its functions).
void RobustReweighting::normalMatrix(const Matrix& cosSums, const Matrix& sinSums, Matrix& normal) const {
  thread_local Matrix products, scaled, columns;  // rows x slots^2; basis x rows; basis x functions
  products.resize(rows_, slots_ * slots_);
  for (uint32_t r = 0; r < rows_; ++r)
    for (int s = 0; s < slots_; ++s)
      for (int t = 0; t < slots_; ++t)
        products(r, s * slots_ + t) = azimuthalProduct(&cosSums(0, r), &sinSums(0, r), s - order_, t - order_);
  normal.resize(basis_, basis_);
  scaled.resize(basis_, rows_);
  for (int t = 0; t < slots_; ++t) {
    for (int i = 0; i < basis_; ++i)
      scaled.row(i) = polar_.col(i).cwiseProduct(products.col(slotOf_[size_t(i)] * slots_ + t)).transpose();
    columns.noalias() = scaled * polarOfSlot_[size_t(t)];
    normal(Eigen::all, basisOfSlot_[size_t(t)]) = columns;
  }
}

// A worker's matrices, kept from sample to sample. Column r * channels + k of a columns x
// (rows x channels) matrix is channel k along row r.
struct RobustReweighting::Workspace {
  Matrix traced, fitted, weightedValues, bySlot, weightedBySlot, weights, cosSums, sinSums, normal, rhs, c;
};

// The expansion c on the grid, into w.fitted: per row, the sum over l of polar c for each m, then
// the sum over m along phi.
void RobustReweighting::expansionOnGrid(Workspace& w) const {
  const Eigen::Index nc = w.c.cols();
  w.bySlot.setZero(slots_, Eigen::Index(rows_) * nc);
  for (Eigen::Index r = 0; r < rows_; ++r)
    for (Eigen::Index i = 0; i < basis_; ++i) w.bySlot.block(slotOf_[size_t(i)], r * nc, 1, nc) += polar_(r, i) * w.c.row(i);
  w.fitted.noalias() = azimuthal_.transpose() * w.bySlot;
}

// Each direction's solid angle scaled by Cauchy's weight of its exit's angle, into w.weights, and
// the traced values so weighted, into w.weightedValues.
void RobustReweighting::cauchyWeights(Workspace& w) const {
  const Eigen::Index nc = w.c.cols();
  const double scale = kRobustScaleDegrees * std::numbers::pi / 180.0;
  w.weights.resize(columns_, rows_);
  w.weightedValues.resize(columns_, Eigen::Index(rows_) * nc);
  for (Eigen::Index r = 0; r < rows_; ++r)
    for (Eigen::Index j = 0; j < columns_; ++j) {
      const double expansion[3] = {w.fitted(j, r * nc), w.fitted(j, r * nc + 1), w.fitted(j, r * nc + 2)};
      const double exit[3] = {w.traced(j, r * nc), w.traced(j, r * nc + 1), w.traced(j, r * nc + 2)};
      const double a = exitAngle(expansion, exit) / scale;
      w.weights(j, r) = rowWeights_(r) / (1.0 + a * a);
      w.weightedValues.block(j, r * nc, 1, nc) = w.weights(j, r) * w.traced.block(j, r * nc, 1, nc);
    }
}

// Y^T U f: along phi per slot, then the polar factor.
void RobustReweighting::rightHandSide(Workspace& w) const {
  const Eigen::Index nc = w.c.cols();
  w.weightedBySlot.noalias() = azimuthal_ * w.weightedValues;
  w.rhs.setZero(basis_, nc);
  for (Eigen::Index r = 0; r < rows_; ++r)
    for (Eigen::Index i = 0; i < basis_; ++i)
      w.rhs.row(i) += polar_(r, i) * w.weightedBySlot.block(slotOf_[size_t(i)], r * nc, 1, nc);
}

void RobustReweighting::apply(const float* values, uint32_t channels, float* coeffs) const {
  using FloatRows = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::Index nc = channels;
  thread_local Workspace w;
  w.traced.resize(columns_, Eigen::Index(rows_) * nc);
  for (Eigen::Index r = 0; r < rows_; ++r)
    for (Eigen::Index j = 0; j < columns_; ++j)
      for (Eigen::Index k = 0; k < nc; ++k) w.traced(j, r * nc + k) = values[size_t((r * columns_ + j) * nc + k)];
  w.c = Eigen::Map<const FloatRows>(coeffs, basis_, nc).cast<double>();
  for (int pass = 0; pass < kRobustIterations; ++pass) {
    expansionOnGrid(w);
    cauchyWeights(w);
    w.cosSums.noalias() = cosines_ * w.weights;
    w.sinSums.noalias() = sines_ * w.weights;
    normalMatrix(w.cosSums, w.sinSums, w.normal);
    w.normal.diagonal() += Eigen::Map<const Eigen::VectorXd>(penalty_.data(), basis_);
    rightHandSide(w);
    const Eigen::LLT<Matrix> llt(w.normal);
    if (llt.info() != Eigen::Success) break;  // keeps the last pass's fit
    w.c = llt.solve(w.rhs);
  }
  Eigen::Map<FloatRows>(coeffs, basis_, nc) = w.c.cast<float>();
}

}  // namespace shrefract::bake
