#pragma once
/// \file
/// Numerical stability of a discretized spring scene (Freudenberg 2.3):
/// J x'' = -k x - b x', state [x; x'], A = [[0, 1], [-k/J, -b/J]] (eq. 2.6),
/// discretized with the scene's integrator to x[n+1] = Ad x[n] (eq. 2.7).
/// Forward Euler gives |lambda_d|^2 = 1 - 2 T zeta w_n + T^2 w_n^2 (eq. 2.13),
/// stable iff T < 2 zeta / w_n, i.e. b > T k (eq. 2.14-2.15).

#include <complex>
#include <vector>

#include <Eigen/Dense>

#include "analysis/verdict.hpp"
#include "world/integrator.hpp"

namespace hapticd::analysis {

struct SpringScene {
  double stiffness = 0.0;  ///< k, N/m or N m/rad
  double inertia = 0.0;    ///< J (or m), kg m^2 or kg
  double damping = 0.0;    ///< b >= 0, N m s/rad or N s/m
  double period_s = 1e-3;  ///< T
  world::Integrator integrator = world::Integrator::exact;
};

/// Tolerance on |lambda| - 1 for "marginal" (and for "stable": |lambda| <= 1 + tol)
/// when w T is small; it grows with the rounding of the discretization,
/// 64 eps (w T + b T / J), so that an exact ZOH at w T = 3e5 (|lambda| - 1 =
/// 1e-12 from rounding) is not called unstable. Real instabilities are far
/// larger there: forward Euler's |lambda| - 1 is about (w T)^2 / 2. Where the
/// tolerance passes max_radius_tolerance (w T + b T / J > 7e6) a radius near
/// 1 cannot be assessed (verdict.hpp): e.g. the exact ZOH of k = 1e20,
/// J = 0.0258 at T = 1 ms, w_n T = 6e7.
inline constexpr double marginal_tolerance = 1e-12;

struct IntegratorVerdict {
  Eigen::Matrix2d ad;                             ///< discrete state matrix (NaN if not computable)
  std::vector<std::complex<double>> eigenvalues;  ///< of ad
  double eigenvalue_magnitude = 0.0;              ///< max |lambda|
  double tolerance = 0.0;                         ///< on |lambda| - 1, see marginal_tolerance
  Verdict
      verdict;  ///< from judge_radius: cannot_assess when k/J, b/J, Ad or lambda overflow or w T is too large
  bool stable() const noexcept { return verdict.stable(); }      ///< max |lambda| <= 1 + tolerance
  bool marginal() const noexcept { return verdict.marginal(); }  ///< | max |lambda| - 1 | <= tolerance
  double growth_per_second =
      0.0;  ///< max|lambda|^(1/T): free-oscillation amplitude factor per second (may be inf)
  double growth_per_second_log10 = 0.0;  ///< log10(max|lambda|) / T: finite even when the factor overflows
};

/// Throws std::invalid_argument unless k >= 0, J > 0, b >= 0, T > 0 (finite).
IntegratorVerdict analyze_integrator(const SpringScene& scene);

}  // namespace hapticd::analysis
