// Freudenberg 2.3: numerical stability of the discretized spring scene,
// checked against eq. (2.13)-(2.15) and against free-response simulations.
#include "analysis/integrator_stability.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <tuple>

#include <gtest/gtest.h>

namespace hapticd::analysis::integrator_stability_test {
namespace {

using world::Integrator;

// One free-response step (u = 0) of the continuous model J x'' = -k x - b x',
// written out per scheme by hand from its textbook definition, independent
// of world::discretize(): a wrong Ad in the code does not reproduce here.
struct FreeState {
  double x = 0.0;
  double v = 0.0;
};

FreeState hand_step(const SpringScene& s, FreeState p) {
  const double k = s.stiffness, j = s.inertia, b = s.damping, t = s.period_s;
  const auto accel = [&](double x, double v) { return (-k * x - b * v) / j; };
  switch (s.integrator) {
    case Integrator::forward_euler:  // both from the old values
      return {p.x + t * p.v, p.v + t * accel(p.x, p.v)};
    case Integrator::semi_implicit_euler: {  // velocity first, position with the new velocity
      const double v = p.v + t * accel(p.x, p.v);
      return {p.x + t * v, v};
    }
    case Integrator::trapezoid: {
      // x1 = x0 + T/2 (v0 + v1), v1 = v0 + T/2 (a(x0, v0) + a(x1, v1)):
      //   [1, -T/2; T k/(2J), 1 + T b/(2J)] [x1; v1] = [x0 + T/2 v0; v0 + T/2 a(x0, v0)]
      const double a11 = 1.0, a12 = -t / 2.0, a21 = t * k / (2.0 * j), a22 = 1.0 + t * b / (2.0 * j);
      const double r1 = p.x + t / 2.0 * p.v, r2 = p.v + t / 2.0 * accel(p.x, p.v);
      const double det = a11 * a22 - a12 * a21;  // Cramer
      return {(r1 * a22 - a12 * r2) / det, (a11 * r2 - a21 * r1) / det};
    }
    case Integrator::rk4: {
      const double k1x = p.v, k1v = accel(p.x, p.v);
      const double k2x = p.v + t / 2 * k1v, k2v = accel(p.x + t / 2 * k1x, p.v + t / 2 * k1v);
      const double k3x = p.v + t / 2 * k2v, k3v = accel(p.x + t / 2 * k2x, p.v + t / 2 * k2v);
      const double k4x = p.v + t * k3v, k4v = accel(p.x + t * k3x, p.v + t * k3v);
      return {p.x + t / 6 * (k1x + 2 * k2x + 2 * k3x + k4x), p.v + t / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)};
    }
    case Integrator::exact:
      break;  // sampled from the closed form instead, see free_state()
  }
  ADD_FAILURE() << "no hand step for " << to_string(s.integrator);
  return p;
}

// State at step n from x = 1, v = 0. For `exact` the closed-form
// underdamped oscillator x(t) = e^{-zeta w t} (cos(w_d t) + zeta w / w_d
// sin(w_d t)), v(t) = -(w^2 / w_d) e^{-zeta w t} sin(w_d t), sampled at
// t = n T; the others are iterated with hand_step().
double simulated_growth_per_second(const SpringScene& s, double seconds) {
  const double w = std::sqrt(s.stiffness / s.inertia);
  const double zeta = s.damping / (2.0 * std::sqrt(s.stiffness * s.inertia));
  EXPECT_LT(zeta, 1.0) << "closed form below is the underdamped one";
  const double wd = w * std::sqrt(1.0 - zeta * zeta);
  const int steps = static_cast<int>(std::lround(seconds / s.period_s));
  const int cycle = static_cast<int>(std::lround(2.0 * std::numbers::pi / w / s.period_s));
  FreeState p{1.0, 0.0};
  double first = 0.0, last = 0.0;
  for (int n = 0; n < steps; ++n) {
    if (s.integrator == Integrator::exact) {
      const double t = n * s.period_s, decay = std::exp(-zeta * w * t);
      p = {decay * (std::cos(wd * t) + zeta * w / wd * std::sin(wd * t)),
           -w * w / wd * decay * std::sin(wd * t)};
    }
    const double e = std::hypot(p.x, p.v / w);
    if (n < cycle) first = std::max(first, e);
    if (n >= steps - cycle) last = std::max(last, e);
    if (s.integrator != Integrator::exact) p = hand_step(s, p);
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
  EXPECT_TRUE(at.marginal());
  EXPECT_TRUE(at.stable());
  const IntegratorVerdict above = analyze_integrator({k, j, 1.1 * t * k, t, Integrator::forward_euler});
  EXPECT_TRUE(above.stable());
  EXPECT_FALSE(above.marginal());
  const IntegratorVerdict below = analyze_integrator({k, j, 0.9 * t * k, t, Integrator::forward_euler});
  EXPECT_FALSE(below.stable());
  EXPECT_GT(below.growth_per_second, 1.0);
}

TEST(IntegratorStability, UndampedVerdictsPerIntegrator) {
  const double k = 10.0, j = 0.01, t = 1e-3;
  auto verdict = [&](Integrator i) { return analyze_integrator({k, j, 0.0, t, i}); };
  EXPECT_FALSE(verdict(Integrator::forward_euler).stable());  // Freudenberg Fig. 8
  EXPECT_NEAR(verdict(Integrator::forward_euler).eigenvalue_magnitude, std::sqrt(1 + t * t * k / j), 1e-15);
  for (Integrator i : {Integrator::semi_implicit_euler, Integrator::trapezoid, Integrator::exact}) {
    EXPECT_TRUE(verdict(i).stable()) << to_string(i);
    EXPECT_TRUE(verdict(i).marginal()) << to_string(i);  // symplectic / energy-preserving
  }
  // RK4 damps an undamped oscillator slightly: |R(jy)|^2 = 1 - y^6/72 + y^8/576.
  const IntegratorVerdict rk4 = verdict(Integrator::rk4);
  EXPECT_TRUE(rk4.stable());
  EXPECT_FALSE(rk4.marginal());
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
      if (v.stable() && !v.marginal()) {
        EXPECT_LT(measured, 1.0) << to_string(i) << " b=" << b;
      }
      if (!v.stable()) {
        EXPECT_GT(measured, 1.0) << to_string(i) << " b=" << b;
      }
    }
  }
}

// Forward Euler with a coarse period on a stiff spring: grows visibly.
TEST(IntegratorStability, StiffForwardEulerGrowsFast) {
  const IntegratorVerdict v = analyze_integrator({1000.0, 0.01, 0.0, 1e-3, Integrator::forward_euler});
  EXPECT_FALSE(v.stable());
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
    EXPECT_TRUE(v.stable()) << k;
    EXPECT_TRUE(v.marginal()) << k << ": |lambda| - 1 = " << v.eigenvalue_magnitude - 1.0;
  }
  // Damped, it decays at exactly e^{-zeta w T} per step.
  const double k = 1e6, j = 1e-4, b = 0.2;  // zeta = b / (2 sqrt(k j)) = 0.01
  const IntegratorVerdict v = analyze_integrator({k, j, b, 1e-3, Integrator::exact});
  EXPECT_NEAR(v.eigenvalue_magnitude, std::exp(-b / (2.0 * j) * 1e-3), 1e-12);
}

// Growth that overflows a double still has a finite log10 to report.
TEST(IntegratorStability, OverflowingGrowthKeepsItsLog10) {
  const IntegratorVerdict v = analyze_integrator({1e6, 1e-4, 0.0, 1e-3, Integrator::semi_implicit_euler});
  EXPECT_FALSE(v.stable());
  EXPECT_TRUE(std::isinf(v.growth_per_second));
  // Closed form, undamped semi-implicit Euler: Ad = [[1 - y^2, T], [-T k/J, 1]]
  // with y = w T has trace 2 - y^2 and det 1, so for y > 2 the larger root of
  // lambda^2 - (2 - y^2) lambda + 1 = 0 has |lambda| = (y^2 - 2 + y sqrt(y^2 - 4)) / 2.
  // Here y = sqrt(1e6 / 1e-4) 1e-3 = 100: |lambda| = 9997.9998999799950...,
  // growth_per_second_log10 = 1000 log10(|lambda|) = 3999.913128071889.
  const double y = std::sqrt(1e6 / 1e-4) * 1e-3;
  const double lambda = (y * y - 2.0 + y * std::sqrt(y * y - 4.0)) / 2.0;
  EXPECT_NEAR(v.eigenvalue_magnitude, lambda, 1e-9 * lambda);
  const double expected_log10 = std::log10(lambda) / 1e-3;
  EXPECT_NEAR(expected_log10, 3999.913128071889, 1e-9);  // the derivation above, by hand
  EXPECT_NEAR(v.growth_per_second_log10, expected_log10, 1e-6 * expected_log10);
  EXPECT_GT(v.growth_per_second_log10, 3000.0);
}

// hapticctl analyze integrator --scheme forward-euler --stiffness 1e308
// --inertia 0.0258 said "stable, marginal, |lambda| = 0": k/J overflowed, Ad
// held inf and NaN, and max |lambda| over NaN eigenvalues stayed 0.
TEST(IntegratorStability, OverflowCannotBeAssessed) {
  const IntegratorVerdict v = analyze_integrator({1e308, 0.0258, 0.0, 1e-3, Integrator::forward_euler});
  EXPECT_EQ(v.verdict.state, VerdictState::cannot_assess);
  EXPECT_FALSE(v.stable());
  EXPECT_FALSE(v.marginal());
  EXPECT_NE(v.verdict.reason.find("k / J = 1e+308 / 0.0258 overflowed to inf"), std::string::npos)
      << v.verdict.reason;
  // The damper as well, under every scheme.
  for (const Integrator i : world::all_integrators) {
    const IntegratorVerdict d = analyze_integrator({1.0, 0.0258, 1e308, 1e-3, i});
    EXPECT_EQ(d.verdict.state, VerdictState::cannot_assess) << to_string(i);
    EXPECT_NE(d.verdict.reason.find("b / J"), std::string::npos) << d.verdict.reason;
  }
  // Finite k/J whose Ad overflows: forward Euler's w^2 T at k/J = 1e307, T = 1 s.
  const IntegratorVerdict ad = analyze_integrator({1e307, 1.0, 0.0, 1.0, Integrator::rk4});
  EXPECT_EQ(ad.verdict.state, VerdictState::cannot_assess);
  EXPECT_NE(ad.verdict.reason.find("Ad"), std::string::npos) << ad.verdict.reason;
}

// analyze integrator --scheme exact --stiffness 1e20 --inertia 0.0258
// --period 1ms said "marginal": at w_n T = 6.2e7 the matrix exponential
// rounds |lambda| to 64 eps w_n T = 9e-7, wider than the 1e-7 a verdict
// needs; at k = 1e28, T = 1 s (w_n T = 6e14) it read 1.0072 and "marginal".
TEST(IntegratorStability, PrecisionLossCannotBeAssessed) {
  for (const auto& [k, t] : {std::pair{1e20, 1e-3}, std::pair{1e28, 1.0}}) {
    const IntegratorVerdict v = analyze_integrator({k, 0.0258, 0.0, t, Integrator::exact});
    EXPECT_EQ(v.verdict.state, VerdictState::cannot_assess) << k;
    EXPECT_FALSE(v.stable()) << k;
    EXPECT_NE(v.verdict.reason.find("w_n T = "), std::string::npos) << v.verdict.reason;
    EXPECT_TRUE(std::isnan(v.growth_per_second)) << k;
  }
  // Clearly unstable stays a verdict however coarse: forward Euler's |lambda| = w T.
  EXPECT_EQ(analyze_integrator({1e20, 0.0258, 0.0, 1e-3, Integrator::forward_euler}).verdict.state,
            VerdictState::unstable);
  // The scene catalog's extremes at 1 ms (k = 1e9, J = 1e-9: w_n T = 1e6) are assessed.
  EXPECT_TRUE(analyze_integrator({1e9, 1e-9, 0.0, 1e-3, Integrator::exact}).marginal());
}

TEST(IntegratorStability, RejectsBadInput) {
  EXPECT_THROW(analyze_integrator({1.0, 0.0, 0.0, 1e-3, Integrator::exact}), std::invalid_argument);
  EXPECT_THROW(analyze_integrator({1.0, 1.0, -1.0, 1e-3, Integrator::exact}), std::invalid_argument);
  EXPECT_THROW(analyze_integrator({1.0, 1.0, 0.0, 0.0, Integrator::exact}), std::invalid_argument);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(analyze_integrator({nan, 1.0, 0.0, 1e-3, Integrator::exact}), std::invalid_argument);
  EXPECT_THROW(analyze_integrator({1.0, 1.0, 0.0, nan, Integrator::exact}), std::invalid_argument);
}

}  // namespace
}  // namespace hapticd::analysis::integrator_stability_test
