// Fitting hemisphere functions with spherical harmonics, and smoothing the result.
//
// A sample's data lives on the hemisphere of view directions above it (z >= 0 in its frame), but
// SH are orthogonal on the whole sphere. A plain projection treats the lower hemisphere as zero
// and rings at the horizon. We fit by weighted least squares over the grid directions with a
// Tikhonov penalty on the surface Laplacian of the expansion, lambda * sum_i (l_i (l_i + 1))^2 c_i^2:
// the data decide the upper hemisphere, the penalty picks the smoothest extension below it, and
// the ill-conditioning of SH restricted to a hemisphere (near-dependent pairs at high order) is
// bounded. docs/technique.md gives the measurements behind the default lambda.
#pragma once

#include <shrefract/field.h>
#include <shrefract/result.h>

#include <glm/vec3.hpp>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

namespace shrefract::bake {

// Directions at cell centres of a (theta, phi) grid over the upper hemisphere:
// theta_i = (i + 0.5) / rows * pi/2, phi_j = (j + 0.5) / columns * 2 pi; index i * columns + j.
// Weights are the cells' solid angles (they sum to 2 pi).
struct DirectionGrid {
  uint32_t rows = 0;
  uint32_t columns = 0;
  std::vector<glm::dvec3> directions;
  std::vector<double> weights;
};
DirectionGrid makeHemisphereGrid(uint32_t rows, uint32_t columns);

// Default Tikhonov weight, relative to the total solid angle (see docs/technique.md).
inline constexpr double kDefaultRegularization = 1e-5;

enum class FitMethod {
  RegularizedLeastSquares,  // the default
  PlainProjection,          // c_i = sum_k w_k f(w_k) Y_i(w_k): the lower hemisphere taken as zero
  // Regularized least squares, then kRobustIterations reweightings: direction k's weight becomes
  // w_k / (1 + (a_k / s)^2), a_k the angle between the expansion's exit (channels 0..2) and the
  // traced one, s = kRobustScaleDegrees (Cauchy's loss). Each reweighting lowers that loss, so
  // the fit gives up on the minority branches of a jump instead of ringing over the majority.
  // Channels past the third are fitted with the same weights.
  RobustLeastSquares,
};

// The robust fit's scale and passes, chosen by the images of the built-in scenes with the default
// lambda (docs/technique.md, "Robust fit": 5, 10 and 20 deg, a scale from each sample's residuals
// and lambda 1e-4 measured worse).
inline constexpr double kRobustScaleDegrees = 3.0;
inline constexpr int kRobustIterations = 8;

class RobustReweighting;

class HemisphereFit {
 public:
  // Precomputes the projection P (basis x directions) so that fitting one sample is a matrix
  // product. Errors: order outside 0..kMaxFitOrder, empty grid, fewer directions than basis
  // functions (least squares would be underdetermined), a singular system, RobustLeastSquares on
  // a grid that is not makeHemisphereGrid's.
  static Result<HemisphereFit> create(const DirectionGrid& grid, int order, double lambda,
                                      FitMethod method = FitMethod::RegularizedLeastSquares);

  int order() const { return order_; }
  int basisCount() const { return basis_; }
  uint32_t directionCount() const { return directions_; }

  // values[d * channels + c] at grid direction d -> coeffs[i * channels + c]. RobustLeastSquares
  // needs channels >= 3, the first three an exit direction.
  void fit(const float* values, uint32_t channels, float* coeffs) const;
  // Reconstruction at grid direction d: out[c] = sum_i coeffs[i * channels + c] Y_i(w_d).
  void reconstructAtGrid(const float* coeffs, uint32_t channels, uint32_t d, float* out) const;

 private:
  int order_ = 0;
  int basis_ = 0;
  uint32_t directions_ = 0;
  std::vector<float> projectionT_;  // directions_ x basis_, row-major (P transposed)
  std::vector<float> basisAtGrid_; // directions_ x basis_, row-major
  std::shared_ptr<const RobustReweighting> robust_;  // RobustLeastSquares only
};

inline constexpr int kMaxFitOrder = 24;

// Evaluates an expansion at an arbitrary local direction (z is clamped to >= 0 and the vector
// renormalized, as the engine does): out[c] for c < channels.
void evaluateExpansion(int order, const float* coeffs, uint32_t channels, glm::vec3 localDirection, float* out);

// Per-band weights of a frequency window for an order-L expansion (None: all ones).
// Hann uses width L + 1, so band L keeps a small non-zero weight.
std::vector<double> bandWindow(SmoothingWindow window, int order);

// Spatial smoothing: each sample's coefficients become the average of its own and those of its
// `count` nearest neighbours (3 or 5) among the samples near it on the surface (rings of the
// layout's adjacency graph, up to 4 rings deep). Nearest by Euclidean distance
// between sample positions; ties broken by index, so the result is deterministic.
// coeffs: samples x stride floats. Precondition: count in {3, 5}.
void smoothSpatially(std::vector<float>& coeffs, size_t stride, const std::vector<glm::vec3>& positions,
                     const std::vector<std::array<uint32_t, 2>>& adjacency, uint32_t count);

}  // namespace shrefract::bake
