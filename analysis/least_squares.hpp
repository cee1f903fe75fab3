#pragma once
/// \file
/// Nonlinear least squares by Levenberg-Marquardt (More 1978: steps from the
/// QR factorization of [J; sqrt(lambda) D], D the column norms of J), with
/// the Jacobian by central differences, and the linearized statistics of the
/// minimum: covariance s^2 (J^T J)^-1 with s^2 = RSS / (m - n), 95 %
/// confidence half-widths, correlations. Pure Eigen; no allocation concerns
/// (off the RT path).

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Dense>

namespace hapticd::analysis {

struct LeastSquaresProblem {
  /// r(theta): m residuals (m >= n). Must be finite near the minimum; a
  /// non-finite r makes a trial step count as a failure.
  std::function<Eigen::VectorXd(const Eigen::VectorXd& theta)> residuals;
  Eigen::VectorXd start;
  /// Typical magnitude of each parameter (> 0): the finite-difference step is
  /// 1e-6 max(|theta_j|, scale_j).
  Eigen::VectorXd scale;
  int max_iterations = 200;
  double relative_tolerance = 1e-12;  ///< stop when the cost falls by less than this, relatively
};

struct LeastSquaresFit {
  Eigen::VectorXd parameters;
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;        ///< at the minimum
  Eigen::MatrixXd covariance;      ///< s^2 (J^T J)^-1 (pseudo-inverse where J is rank deficient)
  double cost = 0.0;               ///< sum of squared residuals
  double residual_variance = 0.0;  ///< s^2 = cost / (m - n)
  int iterations = 0;
  bool converged = false;
  std::string stop_reason;
  /// Smallest singular value of the column-scaled J over the largest: near 0
  /// when some combination of parameters does not change the residuals.
  double conditioning = 0.0;

  /// 1.96 sigma_j: the half-width of the 95 % confidence interval.
  double half_width(Eigen::Index j) const;
  /// cov_ij / (sigma_i sigma_j).
  double correlation(Eigen::Index i, Eigen::Index j) const;
  /// 1.96 sigma of sum_j w_j theta_j (e.g. b_m + b_d: w = [.., 1, 1, ..]).
  double half_width_of(const Eigen::VectorXd& weights) const;
};

/// Minimizes |r(theta)|^2 from problem.start. Throws std::invalid_argument
/// if the sizes do not fit (m < n, scale of the wrong size or not > 0) or the
/// residuals at the start are not finite.
LeastSquaresFit levenberg_marquardt(const LeastSquaresProblem& problem);

/// Central-difference Jacobian of r at theta (column j: step 1e-6 max(|theta_j|, scale_j)).
Eigen::MatrixXd numeric_jacobian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& residuals,
                                 const Eigen::VectorXd& theta, const Eigen::VectorXd& scale);

}  // namespace hapticd::analysis
