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

#include "world/plant.hpp"
#include "world/state_space.hpp"

namespace hapticd::analysis {

/// The augmented closed-loop state matrix. Throws std::invalid_argument on
/// inconsistent scene dimensions, negative delays or T <= 0.
Eigen::MatrixXd closed_loop_matrix(const world::LinearPlant& plant, world::Sensor sensor,
                                   const world::DiscreteLinearScene& scene, double period_s,
                                   int extra_delay_samples = 0);

struct ClosedLoopVerdict {
  Eigen::MatrixXd a;                              ///< augmented state matrix
  std::vector<std::complex<double>> eigenvalues;  ///< closed-loop poles
  double pole_radius = 0.0;                       ///< max |pole|
  bool stable = false;                            ///< pole_radius < 1
  bool marginal = false;                          ///< |pole_radius - 1| <= 1e-9 (e.g. free drift)
  double growth_per_second = 0.0;                 ///< pole_radius^(1/T)
};

ClosedLoopVerdict analyze_closed_loop(const world::LinearPlant& plant, world::Sensor sensor,
                                      const world::DiscreteLinearScene& scene, double period_s,
                                      int extra_delay_samples = 0);

}  // namespace hapticd::analysis
