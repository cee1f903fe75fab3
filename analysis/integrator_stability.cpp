#include "analysis/integrator_stability.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace hapticd::analysis {

IntegratorVerdict analyze_integrator(const SpringScene& scene) {
  const auto finite_nonneg = [](double x) { return std::isfinite(x) && x >= 0.0; };
  if (!finite_nonneg(scene.stiffness) || !finite_nonneg(scene.damping) || !(scene.inertia > 0.0) ||
      !std::isfinite(scene.inertia) || !(scene.period_s > 0.0) || !std::isfinite(scene.period_s)) {
    throw std::invalid_argument("spring scene needs k >= 0, J > 0, b >= 0, T > 0");
  }
  world::ContinuousStateSpace sys;
  sys.a = Eigen::MatrixXd::Zero(2, 2);
  sys.a(0, 1) = 1.0;
  sys.a(1, 0) = -scene.stiffness / scene.inertia;
  sys.a(1, 1) = -scene.damping / scene.inertia;
  sys.b = Eigen::MatrixXd::Zero(2, 1);
  sys.b(1, 0) = 1.0 / scene.inertia;
  const world::DiscreteStateSpace d = world::discretize(sys, scene.period_s, scene.integrator);

  IntegratorVerdict v;
  v.ad = d.ad;
  const Eigen::EigenSolver<Eigen::Matrix2d> solver(v.ad, false);
  for (Eigen::Index i = 0; i < 2; ++i) {
    v.eigenvalues.push_back(solver.eigenvalues()(i));
    v.eigenvalue_magnitude = std::max(v.eigenvalue_magnitude, std::abs(solver.eigenvalues()(i)));
  }
  const double wt = std::sqrt(scene.stiffness / scene.inertia) * scene.period_s;
  const double damping_t = scene.damping / scene.inertia * scene.period_s;
  v.tolerance = marginal_tolerance + 64.0 * std::numeric_limits<double>::epsilon() * (wt + damping_t);
  v.stable = v.eigenvalue_magnitude <= 1.0 + v.tolerance;
  v.marginal = std::abs(v.eigenvalue_magnitude - 1.0) <= v.tolerance;
  v.growth_per_second = std::pow(v.eigenvalue_magnitude, 1.0 / scene.period_s);
  v.growth_per_second_log10 = std::log10(v.eigenvalue_magnitude) / scene.period_s;
  return v;
}

}  // namespace hapticd::analysis
