// The scene/plant loop as one discrete system, checked against Hulin eq. (1)
// and against critical_stiffness.
#include "analysis/closed_loop.hpp"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "analysis/critical_stiffness.hpp"
#include "analysis/wall_stability.hpp"
#include "world/spring_scene.hpp"

namespace hapticd::analysis::closed_loop_test {
namespace {

// Hulin's wall: s = previous y; F = -K y - B (y - y_prev)/T.
world::DiscreteLinearScene wall_scene(double k, double b, double t, int delay) {
  world::DiscreteLinearScene s;
  s.a = Eigen::MatrixXd::Zero(1, 1);
  s.b = Eigen::MatrixXd::Ones(1, 1);
  s.c = Eigen::MatrixXd::Constant(1, 1, b / t);
  s.d = Eigen::MatrixXd::Constant(1, 1, -k - b / t);
  s.output_delay_samples = delay;
  return s;
}

world::DiscreteLinearScene spring_scene(double k) {
  world::DiscreteLinearScene s;
  s.a.resize(0, 0);
  s.b.resize(0, 1);
  s.c.resize(1, 0);
  s.d = Eigen::MatrixXd::Constant(1, 1, -k);
  return s;
}

// Every root of eq. (1) appears among the closed-loop poles (nearest match);
// the remaining poles, if any, are at z = 0.
TEST(ClosedLoop, WallPolesAreTheRootsOfHulinEq1) {
  const double m = 0.1, t = 1e-3;
  const world::LinearPlant plant = world::RigidPlant{m, 0.0}.model();
  for (int d = 0; d <= 3; ++d) {
    for (const auto& [k, b] : {std::pair{9000.0, 46.0}, std::pair{2000.0, 10.0}, std::pair{20000.0, 4.6}}) {
      const auto v = analyze_closed_loop(plant, world::Sensor::motor, wall_scene(k, b, t, d), t);
      auto poles = v.eigenvalues;
      const Polynomial eq1 =
          add_scaled(add_scaled(Polynomial(static_cast<std::size_t>(d) + 4, 0.0), k * t * t, {0.0, 1.0, 1.0}),
                     b * t, {-1.0, 0.0, 1.0});
      Polynomial p = eq1;
      p[static_cast<std::size_t>(d) + 1] += 2 * m;
      p[static_cast<std::size_t>(d) + 2] -= 4 * m;
      p[static_cast<std::size_t>(d) + 3] += 2 * m;
      for (const auto& z : roots(p)) {
        auto it = std::min_element(poles.begin(), poles.end(),
                                   [&](auto a, auto c) { return std::abs(a - z) < std::abs(c - z); });
        ASSERT_NE(it, poles.end());
        EXPECT_LT(std::abs(*it - z), 1e-6) << "d=" << d << " K=" << k;
        poles.erase(it);
      }
      for (const auto& z : poles) EXPECT_LT(std::abs(z), 1e-9) << "extra pole not at 0, d=" << d;
      EXPECT_EQ(v.stable(), wall_stable(normalized_stiffness(k, m, t), normalized_damping(b, m, t), d));
    }
  }
}

TEST(ClosedLoop, ExtraDeviceDelayAddsToSceneDelay) {
  const double m = 0.1, t = 1e-3;
  const world::LinearPlant plant = world::RigidPlant{m, 0.0}.model();
  const auto a = analyze_closed_loop(plant, world::Sensor::motor, wall_scene(3000.0, 30.0, t, 2), t, 0);
  const auto b = analyze_closed_loop(plant, world::Sensor::motor, wall_scene(3000.0, 30.0, t, 0), t, 2);
  EXPECT_NEAR(a.pole_radius, b.pole_radius, 1e-12);
  // Two routes to the same poles (eigenvalues of the 5x5 loop vs companion
  // roots); a near-double root here limits the agreement to ~1e-8.
  EXPECT_NEAR(a.pole_radius, pole_radius(0.03, 0.3, 2), 1e-7);
}

// A pure spring on the two-mass plant: the closed loop turns unstable at the
// K_CR found from the frequency response (integer delays here).
TEST(ClosedLoop, SpringOnTwoMassPlantAgreesWithCriticalStiffness) {
  const world::LinearPlant plant = world::TwoMassPlant{}.model();
  const double t = 1e-3;
  for (world::Sensor sensor : {world::Sensor::motor, world::Sensor::body}) {
    for (int d = 0; d <= 2; ++d) {
      const double kcr = critical_stiffness(plant, sensor, t, d * t).k_cr;
      const auto inside = analyze_closed_loop(plant, sensor, spring_scene(0.97 * kcr), t, d);
      const auto outside = analyze_closed_loop(plant, sensor, spring_scene(1.03 * kcr), t, d);
      EXPECT_TRUE(inside.stable()) << d;
      EXPECT_FALSE(outside.stable()) << d;
      EXPECT_GT(outside.growth_per_second, 1.0);
      const auto at = analyze_closed_loop(plant, sensor, spring_scene(kcr), t, d);
      EXPECT_NEAR(at.pole_radius, 1.0, 1e-7) << d;
    }
  }
}

// hapticctl load wall damping=1e308 was accepted with pole radius 0.0125:
// B/T overflowed to inf in the scene, the loop matrix held inf, and the
// eigenvalues Eigen returned for it meant nothing. Likewise the wheel's
// forward Euler with b = 1e308 (b/J = inf in Ad): "stable, radius 0".
TEST(ClosedLoop, NonFiniteSceneCannotBeAssessed) {
  const double m = 0.1, t = 1e-3;
  const world::LinearPlant plant = world::RigidPlant{m, 0.0}.model();
  const auto wall = analyze_closed_loop(plant, world::Sensor::motor, wall_scene(9000.0, 1e308, t, 1), t);
  EXPECT_EQ(wall.verdict.state, VerdictState::cannot_assess);
  EXPECT_FALSE(wall.stable());
  EXPECT_NE(wall.verdict.reason.find("an entry of the scene's"), std::string::npos) << wall.verdict.reason;
  EXPECT_NE(wall.verdict.reason.find("overflowed to inf"), std::string::npos) << wall.verdict.reason;
  EXPECT_TRUE(std::isnan(wall.pole_radius));

  world::SpringParameters wheel;
  wheel.stiffness = 1.0186;
  wheel.inertia = 0.0258;
  wheel.damping = 1e308;
  wheel.integrator = world::Integrator::forward_euler;
  const auto model = world::SpringScene<world::SpringDamping::relative>(wheel, t).linear_model();
  const auto spring =
      analyze_closed_loop(world::RigidPlant{0.01, 0.002}.model(), world::Sensor::motor, model, t);
  EXPECT_EQ(spring.verdict.state, VerdictState::cannot_assess);
  EXPECT_FALSE(spring.stable());

  // A plant whose ZOH the matrix exponential gets wrong (m = 1e-100 kg: it
  // returned Ad = 0, Bd = 0, and the loop read "stable, radius 9e-5").
  const auto light = analyze_closed_loop(world::RigidPlant{1e-100, 0.0}.model(), world::Sensor::motor,
                                         wall_scene(9000.0, 46.0, t, 1), t);
  EXPECT_EQ(light.verdict.state, VerdictState::cannot_assess);
  EXPECT_NE(light.verdict.reason.find("det e^(A T) = 0"), std::string::npos) << light.verdict.reason;
}

TEST(ClosedLoop, RejectsInconsistentScene) {
  const world::LinearPlant plant = world::RigidPlant{}.model();
  world::DiscreteLinearScene s = spring_scene(1.0);
  s.c = Eigen::MatrixXd::Zero(1, 2);
  EXPECT_THROW(closed_loop_matrix(plant, world::Sensor::motor, s, 1e-3), std::invalid_argument);
  EXPECT_THROW(closed_loop_matrix(plant, world::Sensor::motor, spring_scene(1.0), 1e-3, -1),
               std::invalid_argument);
}

}  // namespace
}  // namespace hapticd::analysis::closed_loop_test
