// wall: Hulin's discrete PD wall, unilateral, delayed, disarmed on load.

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "tests/world/test_support.hpp"
#include "world/integrator.hpp"
#include "world/plant.hpp"
#include "world/wall_scene.hpp"

namespace hapticd::world::wall_scene_test {
namespace {

using Plain = WallScene<WallDamping::none, WallDelay::none>;
using Delayed = WallScene<WallDamping::none, WallDelay::samples>;
using Damped = WallScene<WallDamping::backward_difference, WallDelay::none>;
using Full = WallScene<WallDamping::backward_difference, WallDelay::samples>;

static_assert(!Plain::has_velocity_estimator && !Plain::has_delay_line);
static_assert(Full::has_velocity_estimator && Full::has_delay_line);
static_assert(sizeof(Plain) < sizeof(Damped));
static_assert(sizeof(Plain) < sizeof(Delayed));
static_assert(sizeof(Delayed) >= sizeof(Plain) + max_wall_delay_samples * sizeof(double));
static_assert(sizeof(Damped) >= sizeof(Plain) + sizeof(double) + sizeof(BackwardDifference));
static_assert(Plain::channel_count == 2 && Damped::channel_count == 3);

constexpr double period = 1e-3;

TEST(WallScene, ZeroOutsidePdInside) {
  Damped wall(WallParameters{9000.0, 46.0, 0.01, WallSide::upper, 0}, period);
  wall.reset(0.0);
  EXPECT_EQ(wall.step(0.0), 0.0);
  EXPECT_EQ(wall.step(0.005), 0.0);  // approaching, still outside
  EXPECT_EQ(wall.step(0.01), 0.0);   // on the surface: no penetration
  const double y = 0.012;
  const double v = (y - 0.01) / period;
  EXPECT_NEAR(wall.step(y), -9000.0 * 0.002 - 46.0 * v, 1e-9);
  EXPECT_NEAR(wall.step(y), -9000.0 * 0.002, 1e-9);  // at rest inside: spring only
  EXPECT_EQ(wall.step(0.0), 0.0);                    // back outside
}

TEST(WallScene, LowerSidePushesUp) {
  Plain wall(WallParameters{1000.0, 0.0, -0.5, WallSide::lower, 0}, period);
  wall.reset(0.0);
  EXPECT_EQ(wall.step(0.0), 0.0);
  EXPECT_NEAR(wall.step(-0.6), 100.0, 1e-12);
}

TEST(WallScene, NeverPullsIntoTheWall) {
  Damped wall(WallParameters{1000.0, 50.0, 0.0, WallSide::upper, 0}, period);
  wall.reset(-0.01);
  wall.step(0.002);
  // Withdrawing fast: -K pen - B v = -1000*0.001 + 50*1 > 0 would pull; clamped.
  EXPECT_EQ(wall.step(0.001), 0.0);
}

TEST(WallScene, DelayShiftsByExactlyDSamples) {
  for (const int d : {1, 2, 5, 16}) {
    Damped direct(WallParameters{5000.0, 10.0, 0.0, WallSide::upper, 0}, period);
    Full delayed(WallParameters{5000.0, 10.0, 0.0, WallSide::upper, d}, period);
    direct.reset(-0.01);
    delayed.reset(-0.01);
    std::vector<double> reference;
    for (int n = 0; n < 200; ++n) {
      const double y = 0.01 * std::sin(0.05 * n);
      reference.push_back(direct.step(y));
      const double out = delayed.step(y);
      if (n < d) {
        EXPECT_EQ(out, 0.0) << "d=" << d << " n=" << n;
      } else {
        EXPECT_EQ(out, reference[static_cast<std::size_t>(n - d)]) << "d=" << d << " n=" << n;
      }
    }
  }
}

TEST(WallScene, DisarmedWhenLoadedInsideUntilOutsideOnce) {
  Delayed wall(WallParameters{9000.0, 0.0, 0.0, WallSide::upper, 1}, period);
  wall.reset(0.02);  // loaded 2 cm deep
  EXPECT_FALSE(wall.armed());
  for (int n = 0; n < 10; ++n) EXPECT_EQ(wall.step(0.02 - 0.001 * n), 0.0);
  wall.step(-0.001);  // out once
  EXPECT_TRUE(wall.armed());
  wall.step(0.001);  // law: -9 N, applied one sample later
  EXPECT_NEAR(wall.step(0.001), -9.0, 1e-12);
  // A fresh reset outside arms at once.
  Plain plain(WallParameters{9000.0, 0.0, 0.0, WallSide::upper, 0}, period);
  plain.reset(-0.001);
  EXPECT_TRUE(plain.armed());
  EXPECT_NEAR(plain.step(0.001), -9.0, 1e-12);
}

TEST(WallScene, ResetGivesZeroOutput) {
  Full wall(WallParameters{9000.0, 46.0, 0.0, WallSide::upper, 3}, period);
  for (const double y : {-1.0, 0.0, 0.05}) {
    wall.step(y + 0.3);
    wall.reset(y);
    for (int n = 0; n < 5; ++n) EXPECT_EQ(wall.step(y), 0.0);
  }
}

TEST(WallScene, RefusesParametersThatDoNotFitTheType) {
  EXPECT_THROW(Plain(WallParameters{1.0, 1.0, 0.0, WallSide::upper, 0}, period), std::invalid_argument);
  EXPECT_THROW(Plain(WallParameters{1.0, 0.0, 0.0, WallSide::upper, 1}, period), std::invalid_argument);
  EXPECT_THROW(Delayed(WallParameters{1.0, 0.0, 0.0, WallSide::upper, 17}, period), std::invalid_argument);
}

/// Closed loop of the wall's linear model and a rigid mass (ZOH); returns its eigenvalues.
std::vector<std::complex<double>> closed_loop_poles(const DiscreteLinearScene& scene, double mass) {
  const DiscreteStateSpace plant = discretize_zoh(RigidPlant{mass, 0.0}.model().dynamics, period);
  const Eigen::Index q = scene.a.rows();
  const auto d = static_cast<Eigen::Index>(scene.output_delay_samples);
  const Eigen::Index n = 2 + q + d;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  const Eigen::VectorXd bp = plant.bd.col(motor_force_input);
  // Law: F = c s + dd y, y = x_p(0).
  Eigen::RowVectorXd law = Eigen::RowVectorXd::Zero(n);
  law(0) = scene.d(0, 0);
  law.segment(2, q) = scene.c;
  Eigen::RowVectorXd applied = Eigen::RowVectorXd::Zero(n);
  if (d == 0) {
    applied = law;
  } else {
    applied(2 + q + d - 1) = 1.0;  // oldest entry of the delay chain
  }
  a.topLeftCorner(2, 2) = plant.ad;
  a.topRows(2) += bp * applied;
  a.block(2, 0, q, 1) = scene.b;
  a.block(2, 2, q, q) = scene.a;
  if (d > 0) {
    a.row(2 + q) = law;
    for (Eigen::Index i = 1; i < d; ++i) a(2 + q + i, 2 + q + i - 1) = 1.0;
  }
  return test::eigenvalues(a);
}

/// Roots of Hulin eq. (1): K T^2 z(z+1) + B T (z^2-1) + 2 m z^{1+d} (z-1)^2.
std::vector<std::complex<double>> hulin_roots(double stiffness, double damping, double mass, int d) {
  std::vector<double> c(static_cast<std::size_t>(4 + d), 0.0);  // degree 3 + d, highest first
  const auto at = [&](int power) -> double& { return c[static_cast<std::size_t>(3 + d - power)]; };
  at(3 + d) += 2.0 * mass;
  at(2 + d) += -4.0 * mass;
  at(1 + d) += 2.0 * mass;
  at(2) += stiffness * period * period + damping * period;
  at(1) += stiffness * period * period;
  at(0) += -damping * period;
  return test::polynomial_roots(c);
}

TEST(WallScene, LinearModelWithRigidMassGivesHulinEquation1) {
  const double mass = 0.1;
  for (const int d : {0, 1, 2}) {
    for (const auto& [stiffness, damping] :
         {std::pair{9000.0, 46.0}, std::pair{2000.0, 4.6}, std::pair{500.0, 20.0}}) {
      const WallParameters p{stiffness, damping, 0.3, WallSide::lower, d};
      const DiscreteLinearScene model =
          d == 0 ? Damped(p, period).linear_model() : Full(p, period).linear_model();
      EXPECT_EQ(model.output_delay_samples, d);
      EXPECT_LT(test::match_roots(closed_loop_poles(model, mass), hulin_roots(stiffness, damping, mass, d)),
                1e-6)
          << "d=" << d << " K=" << stiffness;
    }
  }
}

TEST(WallScene, HulinSection7Example) {
  // alpha = 0.09, beta = 0.46, m = 0.1 kg, T = 1 ms, d = 1: K = 9 kN/m and
  // B = beta m / T = 46 N s/m is stable; the printed 4.6 N s/m is not.
  const double mass = 0.1;
  const auto radius = [&](double damping) {
    double r = 0.0;
    for (const auto& z : closed_loop_poles(
             Full(WallParameters{9000.0, damping, 0.0, WallSide::upper, 1}, period).linear_model(), mass)) {
      r = std::max(r, std::abs(z));
    }
    return r;
  };
  EXPECT_LT(radius(46.0), 1.0);
  EXPECT_GT(radius(4.6), 1.0);
}

TEST(WallScene, HulinRemark2MaximumStiffnessPointIsOnTheBoundary) {
  // d = 0: [alpha, beta] = [12 - 8 sqrt 2, 2 sqrt 2 - 2] lies on the stability boundary.
  const double mass = 0.1;
  const double alpha = 12.0 - 8.0 * std::sqrt(2.0);
  const double beta = 2.0 * std::sqrt(2.0) - 2.0;
  double r = 0.0;
  for (const auto& z : hulin_roots(alpha * mass / (period * period), beta * mass / period, mass, 0)) {
    r = std::max(r, std::abs(z));
  }
  EXPECT_NEAR(r, 1.0, 1e-6);
  // The scene itself: its linear model closed around the rigid mass is stable
  // just below the point and unstable just above it (same damping).
  const auto scene_radius = [&](double a) {
    const WallParameters p{a * mass / (period * period), beta * mass / period, 0.3, WallSide::lower, 0};
    double radius = 0.0;
    for (const auto& z : closed_loop_poles(Damped(p, period).linear_model(), mass)) {
      radius = std::max(radius, std::abs(z));
    }
    return radius;
  };
  EXPECT_LT(scene_radius(alpha * (1.0 - 1e-6)), 1.0);
  EXPECT_GT(scene_radius(alpha * (1.0 + 1e-6)), 1.0);
  EXPECT_NEAR(scene_radius(alpha), 1.0, 1e-6);
}

}  // namespace
}  // namespace hapticd::world::wall_scene_test
