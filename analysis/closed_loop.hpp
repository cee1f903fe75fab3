#pragma once
/// \file
/// A linear scene closed around a plant, as one discrete system. The plant is
/// discretized exactly (ZOH) with the motor force as input and the hand force
/// zero (the worst case: Hulin 2, Gil et al. 2004); the scene reads the sensed
/// position y[n] and its force F[n] reaches the plant D = scene output delay +
/// extra device delay samples later:
///   x[n+1] = Phi x[n] + Gamma u[n],   u[n] = F[n - D],
///   s[n+1] = a s[n] + b y[n],         F[n] = c s[n] + d y[n],   y = C x.
/// Augmented state [x; s; F[n-1] ... F[n-D]], dimension n + q + D.

#include <complex>
#include <vector>

#include <Eigen/Dense>

#include "analysis/verdict.hpp"
#include "world/plant.hpp"
#include "world/state_space.hpp"

namespace hapticd::analysis {

/// The augmented closed-loop state matrix. Throws std::invalid_argument on
/// inconsistent scene dimensions, negative delays or T <= 0.
Eigen::MatrixXd closed_loop_matrix(const world::LinearPlant& plant, world::Sensor sensor,
                                   const world::DiscreteLinearScene& scene, double period_s,
                                   int extra_delay_samples = 0);

/// |pole_radius - 1| within which a closed loop is marginal by default (e.g.
/// the free drift of a device without damping; simple roots on the circle).
inline constexpr double closed_loop_tolerance = 1e-9;

struct ClosedLoopVerdict {
  Eigen::MatrixXd a;                              ///< augmented state matrix
  std::vector<std::complex<double>> eigenvalues;  ///< closed-loop poles
  double pole_radius = 0.0;                       ///< max |pole| (NaN if not computable)
  Verdict verdict;  ///< judge_radius: cannot_assess when the plant's ZOH, the scene or a pole is not finite
  bool stable() const noexcept { return verdict.stable(); }      ///< pole_radius <= 1 + tolerance
  bool marginal() const noexcept { return verdict.marginal(); }  ///< |pole_radius - 1| <= tolerance
  double growth_per_second = 0.0;                                ///< pole_radius^(1/T)
};

/// `tolerance`: the band around |z| = 1 called marginal (the daemon's gate
/// uses 1e-7 for the double drift root, which is computed to ~sqrt(eps)).
ClosedLoopVerdict analyze_closed_loop(const world::LinearPlant& plant, world::Sensor sensor,
                                      const world::DiscreteLinearScene& scene, double period_s,
                                      int extra_delay_samples = 0, double tolerance = closed_loop_tolerance);

}  // namespace hapticd::analysis
