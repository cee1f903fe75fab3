#pragma once
/// \file
/// Continuous and discrete linear state-space models, x' = A x + B u
/// (Freudenberg 2.6) and x[n+1] = Ad x[n] + Bd u[n] (Freudenberg 2.7).
/// These are planning-time objects (dynamic Eigen matrices, built off the
/// RT path); scenes copy what they need into fixed-size storage.

#include <Eigen/Dense>

namespace hapticd::world {

struct ContinuousStateSpace {
  Eigen::MatrixXd a;  ///< n x n
  Eigen::MatrixXd b;  ///< n x m
};

struct DiscreteStateSpace {
  Eigen::MatrixXd ad;  ///< n x n
  Eigen::MatrixXd bd;  ///< n x m, input held over the period (ZOH)
  double period_s = 0.0;
};

}  // namespace hapticd::world

namespace hapticd::world {

/// A linear scene as a discrete system from measured position y[n] to the
/// force/torque it commands on the device F[n] (before any output delay):
///   s[n+1] = a s[n] + b y[n],   F[n] = c s[n] + d y[n].
/// Built off the RT path; analysis/ closes the loop with a plant through it.
struct DiscreteLinearScene {
  Eigen::MatrixXd a;             ///< q x q (q may be 0)
  Eigen::MatrixXd b;             ///< q x 1
  Eigen::MatrixXd c;             ///< 1 x q
  Eigen::MatrixXd d;             ///< 1 x 1
  int output_delay_samples = 0;  ///< samples between computing F and applying it
};

}  // namespace hapticd::world
