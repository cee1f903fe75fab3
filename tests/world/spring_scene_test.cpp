// spring-wheel / spring-mass: Freudenberg 2.1-2.4, 2.16-2.24.

#include <array>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <type_traits>

#include <gtest/gtest.h>

#include "world/spring_scene.hpp"

namespace hapticd::world::spring_scene_test {
namespace {

using None = SpringScene<SpringDamping::none>;
using Absolute = SpringScene<SpringDamping::absolute>;
using Relative = SpringScene<SpringDamping::relative>;

// The type shows what is used.
static_assert(!None::has_velocity_estimator && !Absolute::has_velocity_estimator);
static_assert(Relative::has_velocity_estimator && Relative::has_damping_term);
static_assert(None::input_count == 1 && Absolute::input_count == 1 && Relative::input_count == 2);
static_assert(None::channel_count == 2 && Relative::channel_count == 3);
static_assert(sizeof(None) == sizeof(Absolute));
// The relative variant carries b, the estimator (previous, velocity, 1/T) and a wider Bd.
static_assert(sizeof(Relative) >= sizeof(None) + 2 * sizeof(double) + sizeof(BackwardDifference));
// Undamped: Ad (4) + k + J_w + state (2), nothing else (Bd_y = e1 - Ad e1, see
// step()); J_w is the stored energy's (1/2 J_w theta_w_dot^2, the passivity observer).
static_assert(sizeof(None) == 8 * sizeof(double));

constexpr double k = 1.0186;
constexpr double j = 0.0258;

TEST(SpringScene, UndampedTypeHasNoVelocityChannel) {
  for (const auto name : None::channel_names) EXPECT_NE(name, "device_velocity");
  for (const auto name : Absolute::channel_names) EXPECT_NE(name, "device_velocity");
  EXPECT_EQ(Relative::channel_names[2], "device_velocity");
}

TEST(SpringScene, NoneRefusesDamping) {
  EXPECT_THROW(None(SpringParameters{k, j, 0.1, Integrator::exact}, 1e-3), std::invalid_argument);
  EXPECT_THROW(None(SpringParameters{k, 0.0, 0.0, Integrator::exact}, 1e-3), std::invalid_argument);
  EXPECT_THROW(None(SpringParameters{k, j, 0.0, Integrator::exact}, 0.0), std::invalid_argument);
}

TEST(SpringScene, ExactStepResponseIsMinusKz0CosWnT) {
  // Freudenberg 2.3-2.4, with F the torque on the device (= -T_q on the wheel... sign: -k z0 cos).
  const double t = 1e-3;
  None scene(SpringParameters{k, j, 0.0, Integrator::exact}, t);
  scene.reset(0.0);
  const double z0 = std::numbers::pi / 4.0;
  const double w = std::sqrt(k / j);
  const double peak = k * z0;
  double worst_first_second = 0.0;
  double worst = 0.0;
  for (int n = 0; n <= 10000; ++n) {
    const double expected = -k * z0 * std::cos(w * n * t);
    const double err = std::abs(scene.step(z0) - expected) / peak;
    if (n <= 1000) worst_first_second = std::max(worst_first_second, err);
    worst = std::max(worst, err);
  }
  EXPECT_LT(worst_first_second, 1e-12);
  EXPECT_LT(worst, 1e-9);
}

TEST(SpringScene, ResetGivesZeroOutputAtAnyPosition) {
  for (const auto integrator : all_integrators) {
    None none(SpringParameters{k, j, 0.0, integrator}, 1e-3);
    Absolute absolute(SpringParameters{k, j, 0.01, integrator}, 1e-3);
    Relative relative(SpringParameters{k, j, 0.01, integrator}, 1e-3);
    for (const double y : {-3.0, 0.0, 0.7, 1234.5}) {
      // Disturb first so that reset really has something to undo.
      none.step(y + 1.0);
      absolute.step(y - 1.0);
      relative.step(y + 2.0);
      none.reset(y);
      absolute.reset(y);
      relative.reset(y);
      for (int n = 0; n < 5; ++n) {
        EXPECT_EQ(none.step(y), 0.0);
        EXPECT_EQ(absolute.step(y), 0.0);
        EXPECT_EQ(relative.step(y), 0.0);
      }
    }
  }
}

TEST(SpringScene, ForwardEulerUndampedAmplitudeGrowsByLambdaToTheN) {
  // Freudenberg 2.2 Fig. 8: w^2 e^2 + v^2 (e = theta_w - z0) grows exactly by
  // |lambda|^2 = 1 + T^2 w^2 per step.
  const double t = 1e-3;
  const double w2 = k / j;
  None scene(SpringParameters{k, j, 0.0, Integrator::forward_euler}, t);
  scene.reset(0.0);
  const double z0 = 0.5;
  std::array<double, 2> ch{};
  scene.step(z0);  // state after the step input
  scene.channels(ch);
  const auto energy = [&] { return w2 * (ch[0] - z0) * (ch[0] - z0) + ch[1] * ch[1]; };
  const double q0 = energy();
  const int steps = 10000;
  for (int n = 0; n < steps; ++n) scene.step(z0);
  scene.channels(ch);
  const double growth = std::pow(1.0 + t * t * w2, steps);
  EXPECT_NEAR(energy() / q0, growth, 1e-9 * growth);
  EXPECT_GT(growth, 1.4);  // the instability is visible over 10 s
}

TEST(SpringScene, ForwardEulerWithDampingTkStaysBounded) {
  const double t = 1e-3;
  const double z0 = 0.5;
  // Absolute reference (Freudenberg Fig. 10): a lossless discrete oscillator.
  Absolute absolute(SpringParameters{k, j, t * k, Integrator::forward_euler}, t);
  None undamped(SpringParameters{k, j, 0.0, Integrator::forward_euler}, t);
  absolute.reset(0.0);
  undamped.reset(0.0);
  double max_abs = 0.0;
  double max_undamped = 0.0;
  double max_last_second = 0.0;
  for (int n = 0; n < 10000; ++n) {
    const double f = std::abs(absolute.step(z0));
    max_abs = std::max(max_abs, f);
    if (n >= 9000) max_last_second = std::max(max_last_second, f);
    max_undamped = std::max(max_undamped, std::abs(undamped.step(z0)));
  }
  EXPECT_LT(max_abs, 1.01 * k * z0);
  EXPECT_GT(max_last_second, 0.99 * k * z0);  // lossless, not damped away
  EXPECT_GT(max_undamped, 1.15 * k * z0);     // while b = 0 grows
}

TEST(SpringScene, RelativeDampingUsesTheDeviceVelocity) {
  // With the device moving at constant velocity v and the wheel co-moving, the
  // damper sees no relative motion; with the wheel at rest it sees -v.
  const double t = 1e-3;
  const double b = 0.05;
  Relative relative(SpringParameters{k, j, b, Integrator::exact}, t);
  Absolute absolute(SpringParameters{k, j, b, Integrator::exact}, t);
  relative.reset(0.0);
  absolute.reset(0.0);
  const double v = 0.3;
  const double f_rel = relative.step(v * t);
  const double f_abs = absolute.step(v * t);
  EXPECT_NEAR(f_rel, k * (0.0 - v * t) + b * (0.0 - v), 1e-15);
  EXPECT_NEAR(f_abs, k * (0.0 - v * t), 1e-15);
  std::array<double, 3> ch{};
  relative.channels(ch);
  EXPECT_NEAR(ch[2], v, 1e-12);
}

// Freudenberg 2.19 with the inputs the scene holds over a period: theta_z =
// y[n] and theta_z_dot = y_dot[n] = (y[n] - y[n-1]) / T (its BackwardDifference),
// both constant over [nT, (n+1)T). Integrated by classic RK4 with `substeps`
// steps per period, independent of discretize() and of the scene's Ad / Bd.
struct HeldInputReference {
  double k, j, b, t;
  int substeps = 1000;
  double w = 0.0, w_dot = 0.0, y_previous = 0.0;
  /// The output the scene gives for input y (2.22 with the sign on the device), then one period.
  double step(double y) {
    const double y_dot = (y - y_previous) / t;
    y_previous = y;
    const double out = k * (w - y) + b * (w_dot - y_dot);
    const auto accel = [&](double x, double v) { return (-k * (x - y) - b * (v - y_dot)) / j; };
    const double h = t / substeps;
    for (int i = 0; i < substeps; ++i) {
      const double k1x = w_dot, k1v = accel(w, w_dot);
      const double k2x = w_dot + h / 2 * k1v, k2v = accel(w + h / 2 * k1x, w_dot + h / 2 * k1v);
      const double k3x = w_dot + h / 2 * k2v, k3v = accel(w + h / 2 * k2x, w_dot + h / 2 * k2v);
      const double k4x = w_dot + h * k3v, k4v = accel(w + h * k3x, w_dot + h * k3v);
      w += h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
      w_dot += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    }
    return out;
  }
};

// The relative-damping column (2.19-2.22) against the fine RK4 reference,
// for a sine and a ramp of the device.
TEST(SpringScene, RelativeDampingExactMatchesFineIntegrationOfEq2_19) {
  const double t = 1e-3, b = 0.05;
  const auto sine = [](int n) { return 0.5 * std::sin(2.0 * std::numbers::pi * 3.0 * (n + 1) * 1e-3); };
  const auto ramp = [](int n) { return 0.2 + 0.3 * (n + 1) * 1e-3; };
  for (const auto& input : {std::function<double(int)>(sine), std::function<double(int)>(ramp)}) {
    Relative scene(SpringParameters{k, j, b, Integrator::exact}, t);
    const double y0 = input(-1);
    scene.reset(y0);
    HeldInputReference ref{k, j, b, t};
    ref.w = y0;
    ref.y_previous = y0;
    double worst = 0.0, largest = 0.0;
    for (int n = 0; n < 400; ++n) {
      const double y = input(n);
      const double expected = ref.step(y);
      const double got = scene.step(y);
      worst = std::max(worst, std::abs(got - expected));
      largest = std::max(largest, std::abs(expected));
      std::array<double, 3> ch{};
      scene.channels(ch);
      EXPECT_NEAR(ch[0], ref.w, 1e-12) << n;
      EXPECT_NEAR(ch[1], ref.w_dot, 1e-10) << n;
    }
    EXPECT_GT(largest, 0.01);
    EXPECT_LT(worst, 1e-11);  // observed 1e-14; a scene that dropped y_dot would be off by b v = 0.015
  }
}

// Freudenberg 2.22: a wheel co-moving with the device (theta_w = theta_z,
// theta_w_dot = theta_z_dot) sees no damping. In continuous time, with the
// device on a ramp theta_z = v t, theta_w = v t solves 2.19 and the torque is
// 0. The scene holds theta_z = y[n] over the period while the wheel moves on,
// so on the ramp it settles one half period behind: with e = theta_w - y[n]
// at the period start and u = theta_w_dot, the held-input solution over a
// period is [e; u](T) = [b v/k; 0] + Phi(T) ([e; u] - [b v/k; 0]), and the
// periodic state [e + v T; u] = [e; u] after y moves on by v T solves
// (Phi - I) [e - b v/k; u] = [v T; 0]. Phi is the damped-oscillator map,
// written out. To first order u = v (no relative velocity: the damper is
// idle), e = -v T/2, F = k e + b (u - v) = -k v T/2.
TEST(SpringScene, RelativeDampingCoMovingWheelSeesNoDamping) {
  const double t = 1e-3, b = 0.3, v = 0.3;
  const double w = std::sqrt(k / j), sigma = b / (2.0 * j), wd = std::sqrt(w * w - sigma * sigma);
  const double decay = std::exp(-sigma * t), c = std::cos(wd * t), sn = std::sin(wd * t);
  const double p11 = decay * (c + sigma / wd * sn), p12 = decay * sn / wd;
  const double p21 = -decay * w * w / wd * sn, p22 = decay * (c - sigma / wd * sn);
  // Cramer on (Phi - I) [d; u] = [v T; 0].
  const double a11 = p11 - 1.0, a12 = p12, a21 = p21, a22 = p22 - 1.0, det = a11 * a22 - a12 * a21;
  const double d = v * t * a22 / det, u = -a21 * v * t / det;
  const double e = d + b * v / k;
  const double f_steady = k * e + b * (u - v);
  EXPECT_NEAR(u, v, v * w * w * t * t / 10.0);  // u = v (1 - w^2 T^2 / 12 + ...)
  EXPECT_NEAR(f_steady, -k * v * t / 2.0, k * v * t / 2.0 * (b * t / j + w * w * t * t));

  // The scene cannot be started co-moving (reset() zeroes the wheel velocity),
  // so it starts from rest at y = 0 with the device on the ramp from the first
  // step: the start transient decays (e^{-sigma t}, sigma = 5.8 / s) and it
  // settles on the periodic co-moving state above.
  Relative scene(SpringParameters{k, j, b, Integrator::exact}, t);
  scene.reset(0.0);
  double f = 0.0;
  for (int n = 0; n < 8000; ++n) f = scene.step(v * (n + 1) * t);
  std::array<double, 3> ch{};
  scene.channels(ch);
  EXPECT_NEAR(ch[2], v, 1e-12);  // the backward difference of the ramp
  EXPECT_NEAR(ch[1], u, 1e-12);  // wheel velocity: co-moving to O(T^2)
  EXPECT_NEAR(b * (ch[1] - ch[2]), b * (u - v), 1e-12);
  EXPECT_LT(std::abs(b * (ch[1] - ch[2])), 1e-5 * b * v);  // the damper sees no relative motion
  EXPECT_NEAR(f, f_steady, 1e-12);
  // ... while a wheel at rest would feel the full b v.
  Relative at_rest(SpringParameters{k, j, b, Integrator::exact}, t);
  at_rest.reset(0.0);
  EXPECT_NEAR(at_rest.step(v * t), -k * v * t - b * v, 1e-15);
}

template <class S>
void expect_linear_model_matches(S scene) {
  const DiscreteLinearScene m = scene.linear_model();
  ASSERT_EQ(m.output_delay_samples, 0);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double y0 = 0.2;
  scene.reset(y0);
  // Linear-model state at equilibrium y0: theta_w = y0, velocity 0, (y[n-1] = y0).
  Eigen::VectorXd s = Eigen::VectorXd::Zero(m.a.rows());
  s(0) = y0;
  if (m.a.rows() == 3) s(2) = y0;
  for (int n = 0; n < 500; ++n) {
    const double y = y0 + 0.1 * u(rng);
    const double f_model = (m.c * s)(0) + m.d(0, 0) * y;
    EXPECT_NEAR(scene.step(y), f_model, 1e-10);
    s = m.a * s + m.b * y;
  }
}

TEST(SpringScene, LinearModelReproducesStep) {
  for (const auto integrator : all_integrators) {
    expect_linear_model_matches(None(SpringParameters{k, j, 0.0, integrator}, 1e-3));
    expect_linear_model_matches(Absolute(SpringParameters{k, j, 0.02, integrator}, 1e-3));
    expect_linear_model_matches(Relative(SpringParameters{k, j, 0.02, integrator}, 1e-3));
  }
}

}  // namespace
}  // namespace hapticd::world::spring_scene_test
