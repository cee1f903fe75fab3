// spring-wheel / spring-mass: Freudenberg 2.1-2.4, 2.16-2.24.

#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <type_traits>

#include <gtest/gtest.h>

#include "world/spring_scene.hpp"

namespace hapticd::world {
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
// Undamped: Ad (4) + k + state (2), nothing else (Bd_y = e1 - Ad e1, see step()).
static_assert(sizeof(None) == 7 * sizeof(double));

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
}  // namespace hapticd::world
