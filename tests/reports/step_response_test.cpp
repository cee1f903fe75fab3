// The closed form behind the accuracy report (analysis/step_response.hpp):
// initial conditions, the differential equation itself, an independent
// fine integration, and the digits of the short velocity pulse.
#include "analysis/step_response.hpp"

#include <array>
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

namespace hapticd::analysis::step_response_test {
namespace {

struct Body {
  const char* name;
  double zeta;
};
constexpr std::array<Body, 5> bodies{
    {{"undamped", 0.0}, {"light", 0.003}, {"underdamped", 0.7}, {"critical", 1.0}, {"overdamped", 3.0}}};

SecondOrderStep problem(double zeta) {
  SecondOrderStep s;
  s.natural_frequency = 2.0 * std::numbers::pi * 1.5;
  s.decay = zeta * s.natural_frequency;
  s.initial = -0.7;
  s.forcing = 3.0;
  s.pulse = 40.0;
  s.pulse_width = 0.013;
  return s;
}

double forcing_at(const SecondOrderStep& s, double t) {
  return s.forcing + (t < s.pulse_width ? s.pulse : 0.0);
}

TEST(StepResponse, StartsAtRestAtTheInitialPosition) {
  for (const Body& b : bodies) {
    const SecondOrderStep s = problem(b.zeta);
    EXPECT_DOUBLE_EQ(s.position(0.0), s.initial) << b.name;
    EXPECT_EQ(s.velocity(0.0), 0.0) << b.name;
  }
}

// e'' + 2 sigma e' + w_n^2 e = g(t), with e' and e'' from central differences,
// away from the pulse's end (where g jumps).
TEST(StepResponse, SatisfiesTheDifferentialEquation) {
  for (const Body& b : bodies) {
    const SecondOrderStep s = problem(b.zeta);
    const double w2 = s.natural_frequency * s.natural_frequency;
    for (const double t : {0.004, 0.009, 0.05, 0.31, 1.7, 4.2}) {
      const double dt = 1e-6;
      const double v = (s.position(t + dt) - s.position(t - dt)) / (2 * dt);
      const double a = (s.velocity(t + dt) - s.velocity(t - dt)) / (2 * dt);
      const double scale = std::abs(forcing_at(s, t)) + w2 * std::abs(s.position(t)) + 1.0;
      EXPECT_NEAR(v, s.velocity(t), 1e-6 * (std::abs(s.velocity(t)) + 1.0)) << b.name << " t=" << t;
      EXPECT_NEAR(a + 2 * s.decay * s.velocity(t) + w2 * s.position(t), forcing_at(s, t), 1e-6 * scale)
          << b.name << " t=" << t;
    }
  }
}

TEST(StepResponse, IsContinuousWhereThePulseEnds) {
  for (const Body& b : bodies) {
    const SecondOrderStep s = problem(b.zeta);
    const double tp = s.pulse_width;
    EXPECT_NEAR(s.position(std::nextafter(tp, 0.0)), s.position(tp), 1e-12) << b.name;
    EXPECT_NEAR(s.velocity(std::nextafter(tp, 0.0)), s.velocity(tp), 1e-10) << b.name;
  }
}

// Classic RK4 with 2^-20 s steps through the pulse (which ends on a step),
// written out here independently of the closed form.
TEST(StepResponse, MatchesAFineNumericalIntegration) {
  for (const Body& b : bodies) {
    SecondOrderStep s = problem(b.zeta);
    s.pulse_width = 0.0078125;  // 2^-7 s: a whole number of steps
    const double h = std::ldexp(1.0, -20);
    const double w2 = s.natural_frequency * s.natural_frequency;
    double x = s.initial, v = 0.0, t = 0.0;
    const auto accel = [&](double tt, double xx, double vv) {
      return forcing_at(s, tt) - 2 * s.decay * vv - w2 * xx;
    };
    for (const double until : {0.0078125, 0.25, 1.0}) {
      while (t < until - h / 2) {
        const double k1x = v, k1v = accel(t, x, v);
        const double k2x = v + h / 2 * k1v, k2v = accel(t, x + h / 2 * k1x, v + h / 2 * k1v);
        const double k3x = v + h / 2 * k2v, k3v = accel(t, x + h / 2 * k2x, v + h / 2 * k2v);
        const double k4x = v + h * k3v, k4v = accel(t, x + h * k3x, v + h * k3v);
        x += h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
        v += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
        t += h;
      }
      EXPECT_NEAR(s.position(t), x, 1e-10) << b.name << " t=" << t;
      EXPECT_NEAR(s.velocity(t), v, 1e-8) << b.name << " t=" << t;
    }
  }
}

// After a pulse of width tp << 1/w_n the response is a difference of two
// nearly equal free responses: P(t) = int_{t-tp}^{t} h. Subtracting them
// directly loses ~1e-16 / (w_n tp) relative (1e-8 here); the expm1 form keeps
// all digits. Reference: 5-point Gauss-Legendre of h over [t - tp, t].
TEST(StepResponse, ShortPulseKeepsItsDigits) {
  SecondOrderStep s;
  s.natural_frequency = 2.0 * std::numbers::pi;
  s.decay = 0.003 * s.natural_frequency;
  s.pulse = 1.0;
  s.pulse_width = 1e-9;
  constexpr std::array<double, 5> node{0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640,
                                       0.9061798459386640};
  constexpr std::array<double, 5> weight{0.5688888888888889, 0.4786286704993665, 0.4786286704993665,
                                         0.2369268850561891, 0.2369268850561891};
  // Away from the zeros of h (there even the argument's rounding is relative).
  for (const double t : {0.1, 0.37, 1.13, 2.2}) {
    double integral = 0.0;
    const double mid = t - s.pulse_width / 2, half = s.pulse_width / 2;
    for (std::size_t i = 0; i < 5; ++i) {
      integral += weight[i] * half * free_response(s.natural_frequency, s.decay, mid + half * node[i]).h;
    }
    EXPECT_NEAR(s.position(t) / integral, 1.0, 1e-12) << "t=" << t;
  }
}

}  // namespace
}  // namespace hapticd::analysis::step_response_test
