#pragma once
/// \file
/// Exact stability region of the virtual wall (Hulin, Preusche, Hirzinger
/// 2006): a discrete PD law F = -K x - B (x[n] - x[n-1])/T acting, d samples
/// late, through a zero-order hold on an undamped mass m with no hand on it.
/// Characteristic equation (eq. 1):
///   K T^2 z(z+1) + B T (z^2-1) + 2 m z^{1+d} (z-1)^2 = 0,
/// normalized (eq. 2-3) with alpha = K T^2/m, beta = B T/m:
///   alpha z(z+1) + beta (z^2-1) + 2 z^{1+d} (z-1)^2 = 0.
/// "Stable" means every root strictly inside the unit circle.
///
/// alpha = 0 always has the root z = 1 (the free mass drifts); questions about
/// alpha -> 0 (beta_max_at_zero_stiffness) divide that root out.

#include <complex>
#include <optional>
#include <string>
#include <vector>

#include "analysis/polynomial.hpp"
#include "analysis/verdict.hpp"

namespace hapticd::analysis {

/// Eq. (2): alpha = K T^2 / m.
constexpr double normalized_stiffness(double stiffness, double mass_kg, double period_s) noexcept {
  return stiffness * period_s * period_s / mass_kg;
}
/// Eq. (2): beta = B T / m.
constexpr double normalized_damping(double damping, double mass_kg, double period_s) noexcept {
  return damping * period_s / mass_kg;
}
/// Eq. (2) inverted: K = alpha m / T^2 (N/m).
constexpr double physical_stiffness(double alpha, double mass_kg, double period_s) noexcept {
  return alpha * mass_kg / (period_s * period_s);
}
/// Eq. (2) inverted: B = beta m / T (N s/m).
constexpr double physical_damping(double beta, double mass_kg, double period_s) noexcept {
  return beta * mass_kg / period_s;
}

/// Eq. (3), ascending coefficients, degree 3 + d.
Polynomial wall_characteristic_polynomial(double alpha, double beta, int delay_samples);
/// Roots of eq. (3): the closed-loop poles.
std::vector<std::complex<double>> wall_poles(double alpha, double beta, int delay_samples);
/// max |z| over the roots of eq. (3).
double pole_radius(double alpha, double beta, int delay_samples);
/// pole_radius < 1.
bool wall_stable(double alpha, double beta, int delay_samples);

/// Upper stability boundary alpha_max(beta): the supremum of the stable
/// stiffness interval (0, alpha_max) at this damping; 0 if no alpha > 0 is
/// stable (beta <= 0 or beta >= beta_max_at_zero_stiffness). Exact up to the
/// 1e-14 refinement of the unit-circle crossing (no curve fit).
double alpha_max(double beta, int delay_samples);

/// Largest beta for which the wall is stable as alpha -> 0+ (the root z = 1
/// divided out): 2 for d = 0, 2 sqrt2 - 2 for d = 1 (Hulin Remark 2).
double beta_max_at_zero_stiffness(int delay_samples);

struct BoundaryPoint {
  double beta = 0.0;
  double alpha = 0.0;
};
/// alpha_max at `count` betas evenly spaced over [0, beta_max_at_zero_stiffness].
std::vector<BoundaryPoint> stability_boundary(int delay_samples, int count);

/// The maximum stable stiffness (Hulin Remark 2): max over beta of alpha_max,
/// by golden section on beta to 1e-10, then polished on the exact boundary
/// curve alpha(theta), beta(theta) (eq. 3 at z = e^{j theta} is linear in
/// alpha, beta) by bisecting d alpha/d theta = 0.
BoundaryPoint max_stiffness_point(int delay_samples);

/// The stable beta interval at this alpha > 0 (eq. 3 as a family in beta);
/// nothing if no damping stabilizes it. For alpha = 0 the interval of the
/// reduced polynomial (z = 1 divided out), i.e. (0, beta_max_at_zero_stiffness).
/// If the stable set had several pieces this returns the lowest one (for eq. 3
/// it has one; the tests check that on a grid).
std::optional<Interval> stable_damping_range(double alpha, int delay_samples);

struct MinimumRadiusPoint {
  double alpha = 0.0;
  double beta = 0.0;
  double radius = 1.0;
};
/// Hulin 6.2: beta_opt(alpha) = argmin over stable beta of pole_radius (grid,
/// then golden section to 1e-11); nothing if alpha has no stable damping.
std::optional<MinimumRadiusPoint> minimum_radius_damping(double alpha, int delay_samples);
/// The global minimum of pole_radius along beta_opt(alpha) (Hulin Fig. 9).
MinimumRadiusPoint minimum_radius_point(int delay_samples);

/// A wall request checked in SI units. Missing stiffness or damping means 0
/// (the scene renders none). With K = 0 the drift root z = 1 is divided out:
/// a free mass with B in (0, B_max) is accepted.
struct WallVerdict {
  double mass_kg = 0.0;
  double period_s = 0.0;
  int delay_samples = 0;
  double stiffness = 0.0;  ///< K, N/m (as requested, 0 if absent)
  double damping = 0.0;    ///< B, N s/m
  double alpha = 0.0;
  double beta = 0.0;
  /// judge_radius on the roots of eq. (3), to +-32 eps (2 + alpha + beta) (the
  /// companion matrix's rounding relative to the mass term's 2): cannot_assess
  /// when alpha or beta overflow or swamp the mass term (alpha + beta > 3e6).
  Verdict verdict;
  bool stable() const noexcept { return verdict.stable(); }
  double pole_radius = 0.0;  ///< NaN when not assessed
  double alpha_max = 0.0;    ///< Remark 2 maximum over all damping
  double beta_at_alpha_max = 0.0;
  double k_max = 0.0;       ///< N/m
  double b_at_k_max = 0.0;  ///< N s/m
  double beta_max_at_zero_stiffness = 0.0;
  double b_max_at_zero_stiffness = 0.0;   ///< N s/m
  double alpha_max_for_damping = 0.0;     ///< alpha_max(beta) at the requested damping
  double k_max_for_damping = 0.0;         ///< N/m
  std::optional<Interval> damping_range;  ///< N s/m stable at the requested stiffness
};

/// Full verdict (a few ms). Throws std::invalid_argument on m <= 0, T <= 0,
/// d < 0, K < 0, B < 0 or non-finite input.
WallVerdict analyze_wall(double mass_kg, double period_s, int delay_samples,
                         std::optional<double> stiffness_n_per_m, std::optional<double> damping_n_s_per_m);

/// One sentence saying why the request is refused and what would hold (or,
/// for cannot_assess, why no verdict was possible); empty if the verdict is stable.
std::string refusal_message(const WallVerdict& verdict);

}  // namespace hapticd::analysis
