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
/// of sign changes of Im H from 1e-4/T to pi/T, each bisected to a relative
/// 1e-13, plus the Nyquist frequency itself. If the phase is already below
/// -180 deg at the first scan point (no damping: the crossover is at w -> 0)
/// a crossover {0, ..., stiffness 0} is reported first.
std::vector<PhaseCrossover> phase_crossovers(const DelayedZoh& sys, const Eigen::RowVectorXd& c);

struct CriticalStiffness {
  double k_cr = 0.0;                 ///< N/m: the spring is stable for 0 < K < k_cr
  double crossover_rad_per_s = 0.0;  ///< frequency of the oscillation at K = k_cr
  double crossover_hz = 0.0;
  double gain_margin_db = 0.0;  ///< 20 log10(k_cr)
};

/// K_CR of a pure spring on `plant` (motor-force input, position from
/// `sensor`) sampled at T with total loop delay td >= 0 (eq. 23, 28, 30).
/// Throws std::invalid_argument if T <= 0, td < 0, or H never crosses the
/// negative real axis (then no finite stiffness limit was found).
CriticalStiffness critical_stiffness(const world::LinearPlant& plant, world::Sensor sensor, double period_s,
                                     double delay_s);

}  // namespace hapticd::analysis
