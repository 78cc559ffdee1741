// Real orthonormal spherical harmonics (SH): evaluation of the basis and per-band windows.
//
// Convention (shared with spirv/include/shrefract/sh.glsl and docs/technique.md):
// - Index: basis function (l, m), 0 <= l <= order, -l <= m <= l, lives at i = l*l + l + m.
//   An expansion of order L has (L+1)^2 coefficients.
// - Axes: z is the pole (theta is measured from +z); phi is measured from +x toward +y. In bake
//   usage, z of a sample's local frame is the surface normal.
// - Real basis, orthonormal over the unit sphere, NO Condon-Shortley phase:
//     m > 0:  Y_l^m  = sqrt(2) K_l^m P_l^m(cos theta) cos(m phi)
//     m = 0:  Y_l^0  =         K_l^0 P_l^0(cos theta)
//     m < 0:  Y_l^m  = sqrt(2) K_l^|m| P_l^|m|(cos theta) sin(|m| phi)
//   with K_l^m = sqrt((2l+1)/(4 pi) (l-m)!/(l+m)!) and P_l^m without the (-1)^m factor. This is
//   the usual "graphics" convention; order 2 in Cartesian form (x, y, z a unit vector):
//     Y_0 = 0.282095
//     Y_1 = 0.488603 y    Y_2 = 0.488603 z    Y_3 = 0.488603 x
//     Y_4 = 1.092548 xy   Y_5 = 1.092548 yz   Y_6 = 0.315392 (3z^2 - 1)
//     Y_7 = 1.092548 xz   Y_8 = 0.546274 (x^2 - y^2)
//
// Evaluation uses normalized recurrences only (no factorials, no trigonometry); see the docs.
// All functions are thread-safe; the normalization table is built once on first use.
#pragma once

namespace shrefract::sh {

// Number of basis functions of an expansion of order `order` (bands 0..order).
constexpr int basisCount(int order) { return (order + 1) * (order + 1); }

// Flat index of basis function (l, m). Precondition: 0 <= l, -l <= m <= l.
constexpr int index(int l, int m) { return l * l + l + m; }

// Highest order the project uses and tests for orthonormality. evaluate() accepts higher orders
// (tested finite up to 30); see evaluate() for the limits.
inline constexpr int kMaxOrder = 20;

// Writes Y_i(x, y, z) for i = 0 .. basisCount(order)-1 to out.
// The direction need not be unit length: it is normalized first (scaled by its largest component,
// so huge or tiny vectors do not overflow). The zero vector is treated as +z. The output for
// non-finite input is unspecified.
// The float overload runs the same recurrences in float (constants are computed in double and
// rounded once). Its error grows about linearly with l: it agrees with the double overload to
// 5e-6 absolute up to order 20 (tested; docs/technique.md, "Evaluation"). Intermediate values grow
// with the order near the poles, but float stays finite well past order 30 (tested), double far
// beyond.
// Preconditions: order >= 0 (nothing is written otherwise); out has basisCount(order) entries.
void evaluate(int order, double x, double y, double z, double* out);
void evaluate(int order, float x, float y, float z, float* out);

// Hann window for band l: (1 + cos(pi l / width)) / 2 for 0 <= l < width, else 0.
// windowHann(0, width) == 1 for width >= 1; width <= 0 gives 0 for every band.
double windowHann(int l, int width);

// Lanczos window for band l of an order-`order` expansion: sinc(pi l / (order + 1)) with
// sinc(t) = sin(t)/t and sinc(0) = 1, for 0 <= l <= order; 0 for l > order (the first zero of
// sinc is at l = order + 1, so the window stays non-negative and non-increasing).
// Precondition: order >= 0, l >= 0.
double windowLanczos(int l, int order);

// Scales every coefficient of band l by bandWeights[l], l = 0..order.
// Layout: coefficient i of channel c is coeffs[i * channels + c] (the GPU layout stores 4
// channels per basis function: the exit direction's x, y, z and the optical depth tau).
// Preconditions: order >= 0; bandWeights has order + 1 entries; channels >= 1; coeffs has
// basisCount(order) * channels entries.
void applyWindow(int order, const double* bandWeights, float* coeffs, int channels);

}  // namespace shrefract::sh
