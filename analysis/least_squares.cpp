#include "analysis/least_squares.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace hapticd::analysis {

namespace {

constexpr double z95 = 1.959963984540054;  // two-sided 95 % of the normal distribution

bool finite(const Eigen::VectorXd& v) { return v.allFinite(); }

/// The LM step for damping lambda: min |J dx + r|^2 + lambda |D dx|^2, by QR
/// of the stacked matrix (no normal equations: J^T J squares the condition).
Eigen::VectorXd lm_step(const Eigen::MatrixXd& j, const Eigen::VectorXd& r, const Eigen::VectorXd& d,
                        double lambda) {
  const Eigen::Index m = j.rows();
  const Eigen::Index n = j.cols();
  Eigen::MatrixXd stacked(m + n, n);
  stacked.topRows(m) = j;
  stacked.bottomRows(n) = (std::sqrt(lambda) * d).asDiagonal();
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(m + n);
  rhs.head(m) = -r;
  return stacked.colPivHouseholderQr().solve(rhs);
}

}  // namespace

Eigen::MatrixXd numeric_jacobian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& residuals,
                                 const Eigen::VectorXd& theta, const Eigen::VectorXd& scale) {
  Eigen::MatrixXd jac;
  for (Eigen::Index c = 0; c < theta.size(); ++c) {
    const double h = 1e-6 * std::max(std::abs(theta(c)), scale(c));
    Eigen::VectorXd up = theta, down = theta;
    up(c) += h;
    down(c) -= h;
    const Eigen::VectorXd col = (residuals(up) - residuals(down)) / (2.0 * h);
    if (c == 0) jac.resize(col.size(), theta.size());
    jac.col(c) = col;
  }
  return jac;
}

double LeastSquaresFit::half_width(Eigen::Index j) const { return z95 * std::sqrt(covariance(j, j)); }

double LeastSquaresFit::correlation(Eigen::Index i, Eigen::Index j) const {
  const double denominator = std::sqrt(covariance(i, i) * covariance(j, j));
  return denominator > 0.0 ? covariance(i, j) / denominator : 0.0;
}

double LeastSquaresFit::half_width_of(const Eigen::VectorXd& weights) const {
  return z95 * std::sqrt(std::max(0.0, weights.dot(covariance * weights)));
}

LeastSquaresFit levenberg_marquardt(const LeastSquaresProblem& problem) {
  const Eigen::Index n = problem.start.size();
  if (n == 0 || problem.scale.size() != n || !(problem.scale.array() > 0.0).all()) {
    throw std::invalid_argument("least squares: scale must give a typical magnitude > 0 per parameter");
  }
  LeastSquaresFit fit;
  fit.parameters = problem.start;
  fit.residuals = problem.residuals(fit.parameters);
  const Eigen::Index m = fit.residuals.size();
  if (m < n) throw std::invalid_argument("least squares: fewer residuals than parameters");
  if (!finite(fit.residuals)) throw std::invalid_argument("least squares: residuals not finite at the start");
  fit.cost = fit.residuals.squaredNorm();
  double lambda = 1e-3;
  fit.stop_reason = "iteration limit";
  for (fit.iterations = 0; fit.iterations < problem.max_iterations; ++fit.iterations) {
    const Eigen::MatrixXd j = numeric_jacobian(problem.residuals, fit.parameters, problem.scale);
    Eigen::VectorXd d = j.colwise().norm().transpose();
    for (Eigen::Index c = 0; c < n; ++c) d(c) = std::max(d(c), 1e-300);
    bool improved = false;
    double decrease = 0.0;
    for (int attempt = 0; attempt < 12 && !improved; ++attempt) {
      const Eigen::VectorXd trial = fit.parameters + lm_step(j, fit.residuals, d, lambda);
      const Eigen::VectorXd r = problem.residuals(trial);
      const double cost = finite(r) ? r.squaredNorm() : std::numeric_limits<double>::infinity();
      if (cost < fit.cost) {
        decrease = (fit.cost - cost) / fit.cost;
        fit.parameters = trial;
        fit.residuals = r;
        fit.cost = cost;
        lambda = std::max(lambda * 0.2, 1e-15);
        improved = true;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) {
      fit.converged = true;  // no step lowers the cost: a minimum to rounding
      fit.stop_reason = "no step lowers the cost";
      break;
    }
    if (decrease < problem.relative_tolerance || fit.cost == 0.0) {
      fit.converged = true;
      fit.stop_reason = "cost changes by less than the tolerance";
      ++fit.iterations;
      break;
    }
  }
  fit.jacobian = numeric_jacobian(problem.residuals, fit.parameters, problem.scale);
  fit.residual_variance = m > n ? fit.cost / static_cast<double>(m - n) : 0.0;
  // Covariance through the SVD of the column-scaled Jacobian: scaling makes
  // the singular values comparable, and a rank-deficient direction shows up
  // as a huge variance instead of a failed inverse.
  Eigen::VectorXd norms = fit.jacobian.colwise().norm().transpose();
  for (Eigen::Index c = 0; c < n; ++c) norms(c) = norms(c) > 0.0 ? norms(c) : 1.0;
  const Eigen::MatrixXd scaled = fit.jacobian * norms.cwiseInverse().asDiagonal();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(scaled, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  fit.conditioning = sv(0) > 0.0 ? sv(n - 1) / sv(0) : 0.0;
  Eigen::VectorXd inverse_square(n);
  for (Eigen::Index c = 0; c < n; ++c) {
    inverse_square(c) = sv(c) > 1e-14 * sv(0) ? 1.0 / (sv(c) * sv(c)) : 1e28 / (sv(0) * sv(0));
  }
  const Eigen::MatrixXd& v = svd.matrixV();
  const Eigen::MatrixXd unscaled = v * inverse_square.asDiagonal() * v.transpose();
  fit.covariance = fit.residual_variance *
                   (norms.cwiseInverse().asDiagonal() * unscaled * norms.cwiseInverse().asDiagonal());
  return fit;
}

}  // namespace hapticd::analysis
