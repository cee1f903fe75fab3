// Freudenberg 2.3: numerical stability of the discretized spring scene,
// checked against eq. (2.13)-(2.15) and against free-response simulations.
#include "analysis/integrator_stability.hpp"

#include <cmath>
#include <numbers>
#include <tuple>

#include <gtest/gtest.h>

namespace hapticd::analysis {
namespace {

using world::Integrator;

// Amplitude growth factor per second measured by iterating Ad for `seconds`
// from x = [1, 0]: energy-like norm sqrt(x^2 + (v/w)^2), averaged over a
// final and an initial cycle so the non-orthogonal eigenvectors do not bias it.
double simulated_growth_per_second(const SpringScene& s, double seconds) {
  const IntegratorVerdict v = analyze_integrator(s);
  const double w = std::sqrt(s.stiffness / s.inertia);
  const int steps = static_cast<int>(std::lround(seconds / s.period_s));
  const int cycle = static_cast<int>(std::lround(2.0 * std::numbers::pi / w / s.period_s));
  Eigen::Vector2d x(1.0, 0.0);
  double first = 0.0, last = 0.0;
  for (int n = 0; n < steps; ++n) {
    const double e = std::hypot(x(0), x(1) / w);
    if (n < cycle) first = std::max(first, e);
    if (n >= steps - cycle) last = std::max(last, e);
    x = v.ad * x;
  }
  return std::pow(last / first, 1.0 / (seconds - cycle * s.period_s));
}

TEST(IntegratorStability, ForwardEulerMatchesEq2_13) {
  const SpringScene s{10.0, 0.01, 0.002, 1e-3, Integrator::forward_euler};
  const double wn = std::sqrt(s.stiffness / s.inertia);
  const double zeta = s.damping / (2.0 * std::sqrt(s.stiffness * s.inertia));
  const IntegratorVerdict v = analyze_integrator(s);
  const double t = s.period_s;
  EXPECT_NEAR(v.eigenvalue_magnitude * v.eigenvalue_magnitude,
              std::abs(1 - 2 * t * zeta * wn + t * t * wn * wn), 1e-14);
}

// Eq. (2.14)-(2.15): forward Euler is stable iff b > T k, marginal at b = T k.
TEST(IntegratorStability, ForwardEulerDampingRule) {
  const double k = 10.0, j = 0.01, t = 1e-3;
  const IntegratorVerdict at = analyze_integrator({k, j, t * k, t, Integrator::forward_euler});
  EXPECT_TRUE(at.marginal);
  EXPECT_TRUE(at.stable);
  const IntegratorVerdict above = analyze_integrator({k, j, 1.1 * t * k, t, Integrator::forward_euler});
  EXPECT_TRUE(above.stable);
  EXPECT_FALSE(above.marginal);
  const IntegratorVerdict below = analyze_integrator({k, j, 0.9 * t * k, t, Integrator::forward_euler});
  EXPECT_FALSE(below.stable);
  EXPECT_GT(below.growth_per_second, 1.0);
}

TEST(IntegratorStability, UndampedVerdictsPerIntegrator) {
  const double k = 10.0, j = 0.01, t = 1e-3;
  auto verdict = [&](Integrator i) { return analyze_integrator({k, j, 0.0, t, i}); };
  EXPECT_FALSE(verdict(Integrator::forward_euler).stable);  // Freudenberg Fig. 8
  EXPECT_NEAR(verdict(Integrator::forward_euler).eigenvalue_magnitude, std::sqrt(1 + t * t * k / j), 1e-15);
  for (Integrator i : {Integrator::semi_implicit_euler, Integrator::trapezoid, Integrator::exact}) {
    EXPECT_TRUE(verdict(i).stable) << to_string(i);
    EXPECT_TRUE(verdict(i).marginal) << to_string(i);  // symplectic / energy-preserving
  }
  // RK4 damps an undamped oscillator slightly: |R(jy)|^2 = 1 - y^6/72 + y^8/576.
  const IntegratorVerdict rk4 = verdict(Integrator::rk4);
  EXPECT_TRUE(rk4.stable);
  EXPECT_FALSE(rk4.marginal);
  const double y = t * std::sqrt(k / j);
  EXPECT_NEAR(rk4.eigenvalue_magnitude, std::sqrt(1 - std::pow(y, 6) / 72 + std::pow(y, 8) / 576), 1e-14);
}

// Time domain: each verdict's growth per second is what the free response does.
TEST(IntegratorStability, TimeDomainGrowthMatchesVerdict) {
  for (Integrator i : world::all_integrators) {
    for (double b : {0.0, 0.005, 0.02}) {
      const SpringScene s{10.0, 0.01, b, 1e-3, i};
      const IntegratorVerdict v = analyze_integrator(s);
      const double measured = simulated_growth_per_second(s, 10.0);
      EXPECT_NEAR(measured, v.growth_per_second, 0.01 * v.growth_per_second) << to_string(i) << " b=" << b;
      if (v.stable && !v.marginal) {
        EXPECT_LT(measured, 1.0) << to_string(i) << " b=" << b;
      }
      if (!v.stable) {
        EXPECT_GT(measured, 1.0) << to_string(i) << " b=" << b;
      }
    }
  }
}

// Forward Euler with a coarse period on a stiff spring: grows visibly.
TEST(IntegratorStability, StiffForwardEulerGrowsFast) {
  const IntegratorVerdict v = analyze_integrator({1000.0, 0.01, 0.0, 1e-3, Integrator::forward_euler});
  EXPECT_FALSE(v.stable);
  EXPECT_GT(v.growth_per_second, 1e20);
}

// Stiff and extreme: the exact ZOH of an undamped spring stays marginal
// (|lambda| = 1 to rounding) at w T = 10, 100, 1e4 and 3.2e5, where before
// the balanced matrix exponential it read 0.99999999986 at w T = 100 and
// 1.00043 (unstable) at w T = 3.2e5.
TEST(IntegratorStability, ExactStaysMarginalOnStiffSprings) {
  for (const auto& [k, j, t] : {std::tuple{1e4, 1e-4, 1e-3}, std::tuple{1e6, 1e-4, 1e-3},
                                std::tuple{1e8, 1e-6, 1e-3}, std::tuple{1e9, 1e-6, 1e-2}}) {
    const IntegratorVerdict v = analyze_integrator({k, j, 0.0, t, Integrator::exact});
    EXPECT_TRUE(v.stable) << k;
    EXPECT_TRUE(v.marginal) << k << ": |lambda| - 1 = " << v.eigenvalue_magnitude - 1.0;
  }
  // Damped, it decays at exactly e^{-zeta w T} per step.
  const double k = 1e6, j = 1e-4, b = 0.2;  // zeta = b / (2 sqrt(k j)) = 0.01
  const IntegratorVerdict v = analyze_integrator({k, j, b, 1e-3, Integrator::exact});
  EXPECT_NEAR(v.eigenvalue_magnitude, std::exp(-b / (2.0 * j) * 1e-3), 1e-12);
}

// Growth that overflows a double still has a finite log10 to report.
TEST(IntegratorStability, OverflowingGrowthKeepsItsLog10) {
  const IntegratorVerdict v = analyze_integrator({1e6, 1e-4, 0.0, 1e-3, Integrator::semi_implicit_euler});
  EXPECT_FALSE(v.stable);
  EXPECT_TRUE(std::isinf(v.growth_per_second));
  EXPECT_NEAR(v.growth_per_second_log10, std::log10(v.eigenvalue_magnitude) * 1e3, 1e-9);
  EXPECT_GT(v.growth_per_second_log10, 3000.0);
}

TEST(IntegratorStability, RejectsBadInput) {
  EXPECT_THROW(analyze_integrator({1.0, 0.0, 0.0, 1e-3, Integrator::exact}), std::invalid_argument);
  EXPECT_THROW(analyze_integrator({1.0, 1.0, -1.0, 1e-3, Integrator::exact}), std::invalid_argument);
  EXPECT_THROW(analyze_integrator({1.0, 1.0, 0.0, 0.0, Integrator::exact}), std::invalid_argument);
}

}  // namespace
}  // namespace hapticd::analysis
