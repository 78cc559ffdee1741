// The robust SH fit's reweighting (FitMethod::RobustLeastSquares) on a (theta, phi) product grid.
//
// Each pass solves (Y^T U Y + lambda R) c = Y^T U f with U the solid angles scaled by Cauchy's weight
// of the previous pass's angles. Formed directly, Y^T U Y costs directions x basis^2 per pass and
// was most of an SH bake. A real SH function factors into a polar part and cos(m phi) or sin(|m| phi),
// so over a product grid the sum over a row's phi collapses to the row's weights' Fourier sums up
// to frequency 2L, and the normal matrix costs rows x basis^2 instead.
#pragma once

#include <shrefract/bake/fit.h>

#include <cstdint>
#include <vector>

#include <Eigen/Dense>

namespace shrefract::bake {

class RobustReweighting {
 public:
  // `grid` must be makeHemisphereGrid's (checked by HemisphereFit::create); `penalty` holds
  // lambda (l (l+1))^2 for each basis function.
  RobustReweighting(const DirectionGrid& grid, int order, std::vector<double> penalty);

  // kRobustIterations passes from the least-squares fit in `coeffs` (basis x channels), in place.
  void apply(const float* values, uint32_t channels, float* coeffs) const;

 private:
  using Matrix = Eigen::MatrixXd;
  int order_ = 0, basis_ = 0, slots_ = 0;  // slots: signed m + order, 0 .. 2 order
  uint32_t rows_ = 0, columns_ = 0;
  Matrix polar_;                      // rows x basis: each function's factor of theta at each row
  std::vector<int> slotOf_;           // basis -> m + order
  std::vector<std::vector<int>> basisOfSlot_;  // m + order -> its functions
  std::vector<Matrix> polarOfSlot_;   // m + order -> polar_'s columns of its functions
  Matrix azimuthal_;                  // slots x columns: cos(m phi_j), or sin(|m| phi_j) for m < 0
  Matrix cosines_, sines_;            // slots x columns: cos(k phi_j), sin(k phi_j), k = 0 .. 2 order
  Eigen::VectorXd rowWeights_;        // rows: a cell's solid angle
  std::vector<double> penalty_;

  struct Workspace;
  double azimuthalProduct(const double* cosSums, const double* sinSums, int m, int n) const;
  void normalMatrix(const Matrix& cosSums, const Matrix& sinSums, Matrix& normal) const;
  void expansionOnGrid(Workspace& w) const;
  void cauchyWeights(Workspace& w) const;
  void rightHandSide(Workspace& w) const;
};

// True where `grid` is makeHemisphereGrid(grid.rows, grid.columns), whose rows of one theta and
// columns of one phi the reweighting reads its factors from.
bool isProductGrid(const DirectionGrid& grid);

}  // namespace shrefract::bake
