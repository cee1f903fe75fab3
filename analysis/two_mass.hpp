#pragma once
/// \file
/// The cable mode of the two-mass device (Diaz & Gil eq. 5-16, 24).

#include <complex>
#include <optional>

#include "analysis/critical_stiffness.hpp"
#include "analysis/polynomial.hpp"
#include "analysis/verdict.hpp"
#include "world/plant.hpp"

namespace hapticd::analysis {

/// Eq. (11)-(16) and the resonance distance estimate of eq. (24).
struct ResonanceParameters {
  /// Clean unless a parameter below overflowed or is NaN (e.g. k_c m in omega_n).
  NumericRecord numerics;
  bool assessed() const noexcept { return numerics.clean(); }
  double omega_1 = 0.0;  ///< sqrt(k_c / m_m), rad/s (11)
  double omega_2 = 0.0;  ///< sqrt(k_c / m_d) (12)
  double omega_n = 0.0;  ///< sqrt(k_c m / (m_d m_m)) (13)
  double z_1 = 0.0;      ///< (b_m + b_c)/m_m, 1/s (14)
  double z_2 = 0.0;      ///< (b_d + b_c)/m_d (15)
  double z_n = 0.0;      ///< z_1 + z_2 - b/m (16)
  double q = 0.0;        ///< m_m z_n omega_n, N/m (24)
  double q_db = 0.0;     ///< 20 log10(q)
};
ResonanceParameters resonance_parameters(const world::TwoMassPlant& plant);

/// Exact common denominator p_d p_m - (k_c + b_c s)^2 of eq. (5)-(7), ascending in s.
Polynomial two_mass_denominator(const world::TwoMassPlant& plant);
/// The denominator implied by the factorization (10):
/// (m_d m_m / m) (m s^2 + b s)(s^2 + z_n s + omega_n^2). Equal to the exact one
/// except in the s^2 coefficient: b z_n m_d m_m/m instead of b_d b_m + b_c b.
Polynomial two_mass_factored_denominator(const world::TwoMassPlant& plant);

/// G_m(s) = p_d / (p_d p_m - (k_c + b_c s)^2), eq. (7).
std::complex<double> motor_transfer(const world::TwoMassPlant& plant, std::complex<double> s);

/// The resonant peak of |G_m(j w)| near omega_n and its exact distance to
/// 0 dB, 1/|G_m| (the quantity eq. 24 approximates).
struct ResonantPeak {
  double omega_rad_per_s = 0.0;
  double distance = 0.0;     ///< 1 / |G_m(j w_peak)|, N/m
  double distance_db = 0.0;  ///< 20 log10(distance)
};
/// Golden-section maximum of |G_m(j w)| on [omega_n/2, 2 omega_n]; nothing if
/// the maximum sits on the bracket's edge (mode too damped to peak) or the
/// numbers are not finite.
std::optional<ResonantPeak> resonant_peak(const world::TwoMassPlant& plant);

/// Diaz & Gil after eq. (24): the rigid model suffices at this delay while
/// Q >= K_CR (the cable mode lies above the loop's gain margin). Nothing
/// unless both were assessed: no comparison with a number that overflowed.
std::optional<bool> rigid_model_suffices(const ResonanceParameters& modes, const CriticalStiffness& k);

}  // namespace hapticd::analysis
