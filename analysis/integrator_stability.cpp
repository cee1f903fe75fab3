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
  NumericRecord record;
  const double k_over_j = scene.stiffness / scene.inertia;
  const double b_over_j = scene.damping / scene.inertia;
  const std::string over_j = " / " + short_number(scene.inertia);
  record.check_finite("k / J = " + short_number(scene.stiffness) + over_j, k_over_j);
  record.check_finite("b / J = " + short_number(scene.damping) + over_j, b_over_j);
  const double wt = std::sqrt(k_over_j) * scene.period_s;
  const double damping_t = b_over_j * scene.period_s;

  IntegratorVerdict v;
  v.ad.setConstant(std::numeric_limits<double>::quiet_NaN());
  v.eigenvalue_magnitude = std::numeric_limits<double>::quiet_NaN();
  if (record.clean()) {
    world::ContinuousStateSpace sys;
    sys.a = Eigen::MatrixXd::Zero(2, 2);
    sys.a(0, 1) = 1.0;
    sys.a(1, 0) = -k_over_j;
    sys.a(1, 1) = -b_over_j;
    sys.b = Eigen::MatrixXd::Zero(2, 1);
    sys.b(1, 0) = 1.0 / scene.inertia;
    v.ad = world::discretize(sys, scene.period_s, scene.integrator).ad;
    const Spectrum s = spectrum("the discrete state matrix Ad", v.ad, record);
    v.eigenvalues = s.eigenvalues;
    v.eigenvalue_magnitude = s.radius;
  }
  v.tolerance = marginal_tolerance + 64.0 * std::numeric_limits<double>::epsilon() * (wt + damping_t);
  v.verdict = judge_radius(v.eigenvalue_magnitude, v.tolerance, scene.period_s, record,
                           "w_n T = " + short_number(wt) + ", b T / J = " + short_number(damping_t));
  if (v.verdict.assessed()) {
    v.growth_per_second = std::pow(v.eigenvalue_magnitude, 1.0 / scene.period_s);
    v.growth_per_second_log10 = std::log10(v.eigenvalue_magnitude) / scene.period_s;
  } else {
    v.growth_per_second = v.growth_per_second_log10 = std::numeric_limits<double>::quiet_NaN();
  }
  return v;
}

}  // namespace hapticd::analysis
