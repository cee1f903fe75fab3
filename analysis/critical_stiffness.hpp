#pragma once
/// \file
/// Critical stiffness of a sampled spring on a plant (Diaz & Gil eq. 21-28,
/// 30): K_CR = Gm{ Z[H(s) G(s) e^{-td s}] }, the gain margin of the exact
/// zero-order-hold discretization with the delay td = l T + delta,
/// 0 <= delta < T:
///   x[k+1] = Phi x[k] + Gamma0 u[k-l] + Gamma1 u[k-l-1],
///   Phi = e^{AT}, Gamma0 = int_0^{T-delta} e^{As} ds B,
///   Gamma1 = e^{A(T-delta)} int_0^{delta} e^{As} ds B,
///   H(z) = C (zI - Phi)^{-1} (Gamma0 + Gamma1 z^{-1}) z^{-l}.
/// The spring closes the loop as 1 + K H(z) = 0 (F = -K y).

#include <complex>
#include <vector>

#include <Eigen/Dense>

#include "analysis/verdict.hpp"
#include "world/plant.hpp"

namespace hapticd::analysis {

struct DelayedZoh {
  Eigen::MatrixXd phi;
  Eigen::VectorXd gamma0;
  Eigen::VectorXd gamma1;
  int whole_samples = 0;  ///< l
  double fraction_s = 0;  ///< delta
  double period_s = 0;
};

/// Exact discretization of x' = A x + b u(t - td) with u held over each
/// period; both integrals via the augmented matrix exponential.
DelayedZoh discretize_delayed_zoh(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, double period_s,
                                  double delay_s);

/// H(e^{j w T}) for the output row c.
std::complex<double> frequency_response(const DelayedZoh& sys, const Eigen::RowVectorXd& c,
                                        double omega_rad_per_s);

struct PhaseCrossover {
  double omega_rad_per_s = 0.0;
  std::complex<double> response;  ///< H there (real, negative)
  double stiffness = 0.0;         ///< -1 / H, N/m
};

/// Frequencies in (0, pi/T] where H is real and negative: a log-spaced scan
/// of sign changes of Im H from `lowest_rad_per_s` (default 1e-4/T) to pi/T,
/// each bisected to a relative 1e-13, plus the Nyquist frequency itself. If
/// the phase is already below -180 deg at the first scan point (no damping:
/// the crossover is at w -> 0) a crossover {0, ..., stiffness 0} is reported first.
std::vector<PhaseCrossover> phase_crossovers(const DelayedZoh& sys, const Eigen::RowVectorXd& c,
                                             double lowest_rad_per_s = 0.0);

/// Largest loop delay, in periods, whose phase the scan resolves: between
/// two of its 6000 points z^-l turns by l * 0.0054 rad at Nyquist, which must
/// stay well below pi for no sign change of Im H to slip between them.
inline constexpr int max_delay_periods = 100;

struct CriticalStiffness {
  /// Empty when assessed; else why not (the plant's ZOH or H overflowed, or
  /// no phase crossover was found: then no finite K_CR is known). The numbers
  /// below mean nothing then.
  NumericRecord numerics;
  bool assessed() const noexcept { return numerics.clean(); }
  double k_cr = 0.0;                 ///< N/m: the spring is stable for 0 < K < k_cr
  double crossover_rad_per_s = 0.0;  ///< frequency of the oscillation at K = k_cr
  double crossover_hz = 0.0;
  double gain_margin_db = 0.0;  ///< 20 log10(k_cr)
};

/// K_CR of a pure spring on `plant` (motor-force input, position from
/// `sensor`) sampled at T with total loop delay td >= 0 (eq. 23, 28, 30).
/// The scan starts at 1e-4/T, or at 1e-2 of the plant's slowest nonzero mode
/// if that is lower (a light damping's corner b/m can lie below 1e-4/T at
/// T = 1 us). K_CR = 0 (phase past -180 deg at the start) only for a plant
/// with a double pole at s = 0 (no damping at all).
/// Throws std::invalid_argument if T <= 0, td < 0 or td > max_delay_periods T
/// (or either is not finite). Not assessed (see `numerics`) if H never
/// crosses the negative real axis, the phase is past -180 deg at the start
/// of a plant with damping, or a number on the way is not finite.
CriticalStiffness critical_stiffness(const world::LinearPlant& plant, world::Sensor sensor, double period_s,
                                     double delay_s);

}  // namespace hapticd::analysis
