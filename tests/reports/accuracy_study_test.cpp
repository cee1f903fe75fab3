// The numbers behind `hapticctl report accuracy` (analysis/accuracy_study.hpp):
// the exact integrator against the held-input closed form, the orders and
// error constants derived in accuracy_study.hpp, the stability limits, the
// Boost.Odeint references and the sampled wall's lag.
#include "analysis/accuracy_study.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "analysis/wall_stability.hpp"

namespace hapticd::analysis::accuracy_study_test {
namespace {

using world::Integrator;

constexpr double pi = std::numbers::pi;

Method scheme(Integrator i) { return {Method::Kind::integrator, i, 0.0}; }
const Method sampled_wall{Method::Kind::sampled_wall, Integrator::exact, 0.0};

RunResult run(const AccuracyCase& c, const Method& m, double period_s, std::vector<double> checkpoints) {
  StudyProgress progress;
  return run_method(c, m, {period_s, std::move(checkpoints), 0, 0}, progress);
}

double one_period(const AccuracyCase& c) { return 2.0 * pi / natural_frequency(c); }

// The exact (ZOH) integrator solves the held-input problem exactly, so its
// error against the closed form is rounding only. For relative damping this
// holds only because the reference holds the backward-difference velocity
// z0/T over the first period (an ideal step's impulse would leave an O(T)
// difference: 3e-3 of k z0 at T = 1 ms here).
TEST(AccuracyStudy, ExactIntegratorIsExactOnTheHeldInputProblem) {
  for (const AccuracyScene s : all_accuracy_scenes) {
    if (!has_integrator(s)) continue;
    for (const double t : {1e-4, 1e-3, 1e-2}) {
      const AccuracyCase c = default_case(s, 1e-3);
      const RunResult r = run(c, scheme(Integrator::exact), t, {10.0});
      EXPECT_LT(r.errors.back(), 2e-11) << to_string(s) << " T=" << t;
    }
  }
}

TEST(AccuracyStudy, RelativeDampingOutputStartsWithTheEstimatorsImpulse) {
  const AccuracyCase c = default_case(AccuracyScene::spring_wheel_relative, 1e-3);
  const SecondOrderStep r = reference_problem(c, 1e-3);
  // F[0] = k (0 - z0) + b (0 - z0 / T): the step seen by the backward difference.
  EXPECT_DOUBLE_EQ(reference_output(c, r, 0, 1e-3), -c.stiffness * c.step - c.damping * c.step / 1e-3);
}

// tan(x) = -x in (3 pi/2, 2 pi): where x |sin x| peaks within one period.
double last_sine_peak() {
  double x = 4.9;
  for (int i = 0; i < 50; ++i) x -= (std::tan(x) + x) / (1.0 / (std::cos(x) * std::cos(x)) + 1.0);
  return x * std::abs(std::sin(x));
}

TEST(AccuracyStudy, LeadingErrorConstantsAreTheDerivedOnes) {
  const double theta = 2 * pi;  // one natural period
  EXPECT_NEAR(last_sine_peak(), 4.8145, 1e-4);
  EXPECT_NEAR(leading_error_law(Integrator::forward_euler, theta).constant, pi, 1e-9);
  EXPECT_EQ(leading_error_law(Integrator::semi_implicit_euler, theta).constant, 0.5);
  EXPECT_NEAR(leading_error_law(Integrator::trapezoid, theta).constant, last_sine_peak() / 12, 1e-9);
  EXPECT_NEAR(leading_error_law(Integrator::rk4, theta).constant, last_sine_peak() / 120, 1e-10);
  EXPECT_EQ(leading_error_law(Integrator::forward_euler, theta).order, 1);
  EXPECT_EQ(leading_error_law(Integrator::semi_implicit_euler, theta).order, 1);
  EXPECT_EQ(leading_error_law(Integrator::trapezoid, theta).order, 2);
  EXPECT_EQ(leading_error_law(Integrator::rk4, theta).order, 4);
}

AccuracyStudyOptions sweep_only(AccuracyScene scene, double top) {
  AccuracyStudyOptions o;
  o.cases = {default_case(scene, 1e-3)};
  o.periods_s = {1e-3};
  o.durations_s = {0.01};
  o.wn_t = log_grid(1e-3, top, 8);
  o.odeint = false;
  o.timing_steps = 256;
  return o;
}

const OrderFit& fit_of(const AccuracyStudy& s, Integrator i) {
  for (const OrderFit& f : s.orders) {
    if (f.method.kind == Method::Kind::integrator && f.method.integrator == i) return f;
  }
  throw std::logic_error("no fit");
}

// Error scales as (w_n T)^p with p = 1, 1, 2, 4 and the constants above
// (the undamped wheel over one natural period, the sweep of figure 3).
TEST(AccuracyStudy, SweepFindsTheOrdersAndConstants) {
  StudyProgress progress;
  const AccuracyStudy s = run_accuracy_study(sweep_only(AccuracyScene::spring_wheel, 0.05), progress);
  struct Expected {
    Integrator integrator;
    double order, constant, constant_tolerance;
  };
  const Expected expected[] = {{Integrator::forward_euler, 1, pi, 0.01},
                               {Integrator::semi_implicit_euler, 1, 0.5, 0.01},
                               {Integrator::trapezoid, 2, last_sine_peak() / 12, 0.002},
                               {Integrator::rk4, 4, last_sine_peak() / 120, 0.01}};
  for (const Expected& e : expected) {
    const OrderFit& f = fit_of(s, e.integrator);
    EXPECT_GE(f.points, 4) << to_string(e.integrator);
    EXPECT_NEAR(f.order, e.order, 0.01) << to_string(e.integrator);
    EXPECT_NEAR(f.constant / e.constant, 1.0, e.constant_tolerance) << to_string(e.integrator);
  }
  // Point by point where the leading term dominates (w_n T <= 0.01).
  for (const SweepRow& r : s.sweep) {
    if (r.wn_t > 0.01 || !std::isfinite(r.predicted) || r.predicted < 1e-11) continue;
    EXPECT_NEAR(r.error / r.predicted, 1.0, 0.035) << r.method.name() << " w_n T=" << r.wn_t;
  }
}

TEST(AccuracyStudy, StabilityLimitsOfTheIntegrators) {
  const AccuracyCase undamped = default_case(AccuracyScene::spring_wheel, 1e-3);
  EXPECT_EQ(stability_limit(undamped, scheme(Integrator::forward_euler), 1e-3), 0.0);
  EXPECT_NEAR(stability_limit(undamped, scheme(Integrator::semi_implicit_euler), 1e-3), 2.0, 1e-9);
  EXPECT_NEAR(stability_limit(undamped, scheme(Integrator::rk4), 1e-3), 2.0 * std::sqrt(2.0), 1e-9);
  EXPECT_TRUE(std::isinf(stability_limit(undamped, scheme(Integrator::trapezoid), 1e-3)));
  EXPECT_TRUE(std::isinf(stability_limit(undamped, scheme(Integrator::exact), 1e-3)));
  // Freudenberg 2.14: forward Euler is stable for w_n T < 2 zeta.
  const AccuracyCase damped = default_case(AccuracyScene::spring_wheel_absolute, 1e-3);
  EXPECT_NEAR(stability_limit(damped, scheme(Integrator::forward_euler), 1e-3) / (2 * damping_ratio(damped)),
              1.0, 1e-6);
}

// The wall's limit from the closed loop (analyze_closed_loop) sits on Hulin's
// boundary: along alpha = h^2, beta = 2 zeta h the pole radius of eq. (3) is 1.
TEST(AccuracyStudy, WallLimitIsOnHulinsBoundary) {
  for (const int d : {0, 1, 3}) {
    AccuracyCase c = default_case(AccuracyScene::wall, 1e-3);
    c.delay_samples = d;
    const double h = stability_limit(c, sampled_wall, 1e-3);
    const double zeta = damping_ratio(c);
    EXPECT_NEAR(pole_radius(h * h, 2 * zeta * h, d), 1.0, 1e-6) << "d=" << d;
    EXPECT_TRUE(wall_stable(0.99 * h * 0.99 * h, 2 * zeta * 0.99 * h, d)) << "d=" << d;
    EXPECT_FALSE(wall_stable(1.01 * h * 1.01 * h, 2 * zeta * 1.01 * h, d)) << "d=" << d;
  }
}

TEST(AccuracyStudy, SweepStabilityFlagsFollowTheLimit) {
  StudyProgress progress;
  const AccuracyStudy s = run_accuracy_study(sweep_only(AccuracyScene::spring_wheel_absolute, pi), progress);
  for (const SweepRow& r : s.sweep) {
    for (const StabilityLimitRow& l : s.limits) {
      if (l.method.label() != r.method.label() || std::abs(r.wn_t / l.wn_t - 1.0) < 1e-3) continue;
      EXPECT_EQ(r.stable, r.wn_t < l.wn_t) << r.method.name() << " w_n T=" << r.wn_t;
    }
  }
}

// Odeint's runge_kutta4 with step T is the same scheme as world's rk4 on a
// held input: the same error where it is far above rounding.
TEST(AccuracyStudy, OdeintRk4IsTheSameSchemeAsRk4) {
  const Method odeint_rk4{Method::Kind::odeint_rk4, Integrator::rk4, 0.0};
  for (const AccuracyScene s : {AccuracyScene::spring_wheel, AccuracyScene::spring_wheel_relative}) {
    const AccuracyCase c = default_case(s, 1e-3);
    for (const double t : {1e-3, 1e-2}) {
      const double ours = run(c, scheme(Integrator::rk4), t, {10.0}).errors.back();
      const double theirs = run(c, odeint_rk4, t, {10.0}).errors.back();
      EXPECT_NEAR(theirs / ours, 1.0, 1e-4) << to_string(s) << " T=" << t;
    }
  }
}

// Dormand-Prince with dense output, tolerance tol on the state in units of
// the step: over one natural period the error stays within a small factor of
// tol (2-3.3 measured), and shrinks in proportion to it, from 1e-3 to 1e-12.
TEST(AccuracyStudy, OdeintDopri5ReachesItsTolerance) {
  for (const AccuracyScene s : all_accuracy_scenes) {
    const AccuracyCase c = default_case(s, 1e-3);
    for (double tol = 1e-3; tol > 1e-13; tol /= 10) {
      const Method dopri5{Method::Kind::odeint_dopri5, Integrator::rk4, tol};
      const double error = run(c, dopri5, 1e-3, {one_period(c)}).errors.back();
      EXPECT_LT(error, 4 * tol) << to_string(s) << " tol=" << tol;
      EXPECT_GT(error, 0.1 * tol) << to_string(s) << " tol=" << tol;
    }
  }
}

// The sampled wall's force lags the continuous wall's by (d + 1/2) T at
// contact, where the ideal force rises fastest (B F_h / m).
TEST(AccuracyStudy, SampledWallLagsByDelayPlusHalfASample) {
  for (const int d : {0, 1, 2}) {
    AccuracyCase c = default_case(AccuracyScene::wall, 1e-3);
    c.delay_samples = d;
    const ErrorLaw law = wall_error_law(c);
    EXPECT_EQ(law.order, 1);
    EXPECT_NEAR(law.constant, (d + 0.5) * 2 * damping_ratio(c), 1e-12);
    for (const double h : {1e-3, 3e-3}) {
      const AccuracyCase ch = at_normalized_frequency(c, h, 1e-3);
      const double error = run(ch, sampled_wall, 1e-3, {one_period(ch)}).errors.back();
      EXPECT_NEAR(error / law.at(h), 1.0, 0.02) << "d=" << d << " h=" << h;
    }
  }
}

TEST(AccuracyStudy, CheckpointsAndGrowthAreRunningMaxima) {
  StudyProgress progress;
  const AccuracyCase c = default_case(AccuracyScene::spring_wheel, 1e-3);
  const RunResult r = run_method(c, scheme(Integrator::trapezoid), {1e-3, {1, 10}, 10, 256}, progress);
  ASSERT_EQ(r.errors.size(), 2u);
  EXPECT_LE(r.errors[0], r.errors[1]);
  ASSERT_GT(r.growth.size(), 30u);
  for (std::size_t i = 1; i < r.growth.size(); ++i) {
    EXPECT_GT(r.growth[i].time_s, r.growth[i - 1].time_s);
    EXPECT_GE(r.growth[i].error, r.growth[i - 1].error);
  }
  EXPECT_EQ(r.growth.back().error, r.errors[1]);
  EXPECT_EQ(r.periods, 10001);
  EXPECT_DOUBLE_EQ(r.cpu_s_per_simulated_s, r.cpu_s_per_step / 1e-3);
}

// A non-finite output ends the run: inf from there on, never a silent NaN.
TEST(AccuracyStudy, OverflowIsInfinite) {
  AccuracyCase c = default_case(AccuracyScene::spring_wheel, 1e-3);
  c = at_normalized_frequency(c, 100.0, 1e-3);  // forward Euler grows x1e4 per step
  const RunResult r = run(c, scheme(Integrator::forward_euler), 1e-3, {0.01, 1.0});
  EXPECT_GT(r.errors[0], 1e15);  // 10 steps of x100: large but finite
  EXPECT_TRUE(std::isfinite(r.errors[0]));
  EXPECT_TRUE(std::isinf(r.errors[1]));  // overflowed before 1000 steps
  EXPECT_FALSE(r.stable);
}

TEST(AccuracyStudy, ProgressReachesTheEndAndCanStopTheStudy) {
  AccuracyStudyOptions o = sweep_only(AccuracyScene::wall, 0.1);
  o.durations_s = {0.5};
  o.odeint = true;
  o.tolerances = {1e-6};
  double last = 0.0;
  StudyProgress counting([&](double fraction, const std::string&) {
    EXPECT_GE(fraction, last - 1e-12);
    last = fraction;
    return true;
  });
  run_accuracy_study(o, counting);
  EXPECT_NEAR(last, 1.0, 1e-9);

  int calls = 0;
  StudyProgress stopping([&](double, const std::string&) { return ++calls < 3; });
  EXPECT_THROW(run_accuracy_study(o, stopping), StudyCancelled);
}

}  // namespace
}  // namespace hapticd::analysis::accuracy_study_test
