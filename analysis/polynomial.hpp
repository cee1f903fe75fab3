#pragma once
/// \file
/// Real polynomials and the root-locus tools the stability analyses share.
/// A polynomial is stored with ascending coefficients: p(z) = sum_i c[i] z^i.

#include <complex>
#include <vector>

namespace hapticd::analysis {

using Polynomial = std::vector<double>;  ///< ascending coefficients

/// p(z) by Horner's rule.
std::complex<double> evaluate(const Polynomial& p, std::complex<double> z) noexcept;
/// p'(z).
std::complex<double> evaluate_derivative(const Polynomial& p, std::complex<double> z) noexcept;
/// a + s b (the shorter one is zero-padded).
Polynomial add_scaled(const Polynomial& a, double s, const Polynomial& b);

/// Roots from the eigenvalues of the companion matrix (Eigen::EigenSolver).
/// Trailing (leading-order) zero coefficients are dropped first.
std::vector<std::complex<double>> roots(const Polynomial& p);
/// max |root|; 0 for a constant polynomial.
double root_radius(const Polynomial& p);

/// Where the one-parameter family p0 + t p1 has a root on the unit circle.
struct UnitCircleCrossing {
  double t = 0.0;      ///< parameter value
  double theta = 0.0;  ///< the root is e^{j theta}, theta in [0, pi]
};

/// All crossings of p0 + t p1, sorted by t. At z = e^{j theta} a root exists
/// for a real t iff Im(p0 conj(p1)) = 0, and then t = -Re(p0 conj p1)/|p1|^2.
/// theta = 0 and pi are checked directly; (0, pi) is scanned on a linear grid
/// plus logarithmic grids at both ends and each sign change is bisected to
/// |d theta| <= 1e-14.
std::vector<UnitCircleCrossing> unit_circle_crossings(const Polynomial& p0, const Polynomial& p1);

struct Interval {
  double lower = 0.0;
  double upper = 0.0;
  double width() const noexcept { return upper - lower; }
  bool contains(double x) const noexcept { return x > lower && x < upper; }
};

/// The open intervals of t > t_min (t_min itself excluded) on which all roots
/// of p0 + t p1 lie strictly inside the unit circle: the crossings split the
/// axis, each piece is classified by the root radius at its midpoint, and
/// touching stable pieces are merged. The last piece may have upper = +inf.
std::vector<Interval> stable_intervals(const Polynomial& p0, const Polynomial& p1, double t_min);

}  // namespace hapticd::analysis
