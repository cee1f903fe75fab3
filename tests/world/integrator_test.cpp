// Eigenvalues of the discretized undamped/damped spring for every integrator
// (Freudenberg 2.8-2.15, 2.24) and their order of accuracy on a step response.

#include <cmath>
#include <complex>

#include <gtest/gtest.h>
#include <unsupported/Eigen/MatrixFunctions>

#include "tests/world/test_support.hpp"
#include "world/integrator.hpp"
#include "world/spring_scene.hpp"

namespace hapticd::world::integrator_test {
namespace {

using test::eigenvalues;

constexpr double k = 1.0;
constexpr double j = 0.025;

Eigen::MatrixXd ad_for(double stiffness, double inertia, double damping, double period,
                       Integrator integrator) {
  const SpringParameters p{stiffness, inertia, damping, integrator};
  return discretize(spring_continuous_model(p, SpringDamping::absolute), period, integrator).ad;
}

TEST(Integrators, ForwardEulerUndampedGrowsAsFreudenberg213) {
  const double w = std::sqrt(k / j);
  for (const double t : {1e-4, 1e-3, 1e-2}) {
    for (const auto& l : eigenvalues(ad_for(k, j, 0.0, t, Integrator::forward_euler))) {
      EXPECT_NEAR(std::norm(l), 1.0 + t * t * w * w, 1e-12) << "T=" << t;
    }
  }
}

TEST(Integrators, SemiImplicitEulerIsAreaPreservingAndStableBelowTwo) {
  const double w = std::sqrt(k / j);
  for (const double wt : {0.01, 0.5, 1.0, 1.9}) {
    const Eigen::MatrixXd ad = ad_for(k, j, 0.0, wt / w, Integrator::semi_implicit_euler);
    EXPECT_NEAR(ad.determinant(), 1.0, 1e-12);
    for (const auto& l : eigenvalues(ad)) EXPECT_NEAR(std::abs(l), 1.0, 1e-12) << "wT=" << wt;
  }
  // Above wT = 2 the eigenvalues become real with one outside the unit circle.
  EXPECT_GT(test::spectral_radius(ad_for(k, j, 0.0, 2.1 / w, Integrator::semi_implicit_euler)), 1.0 + 1e-3);
}

TEST(Integrators, TrapezoidKeepsUnitModulus) {
  const double w = std::sqrt(k / j);
  for (const double wt : {0.01, 0.5, 3.0, 30.0}) {
    for (const auto& l : eigenvalues(ad_for(k, j, 0.0, wt / w, Integrator::trapezoid))) {
      EXPECT_NEAR(std::abs(l), 1.0, 1e-12) << "wT=" << wt;
    }
  }
}

TEST(Integrators, Rk4ModulusIsItsTaylorPolynomialOfExpJwT) {
  const double w = std::sqrt(k / j);
  for (const double wt : {0.01, 0.2, 1.0, 2.0}) {
    const std::complex<double> expected(1.0 - wt * wt / 2.0 + std::pow(wt, 4) / 24.0,
                                        wt - std::pow(wt, 3) / 6.0);
    for (const auto& l : eigenvalues(ad_for(k, j, 0.0, wt / w, Integrator::rk4))) {
      EXPECT_NEAR(std::abs(l), std::abs(expected), 1e-12);
      EXPECT_LT(std::abs(l), 1.0);
    }
  }
}

TEST(Integrators, ExactIsTheRotationOfTheHarmonicOscillator) {
  const double w = std::sqrt(k / j);
  const double t = 1e-3;
  const Eigen::MatrixXd ad = ad_for(k, j, 0.0, t, Integrator::exact);
  EXPECT_NEAR(ad(0, 0), std::cos(w * t), 1e-14);
  EXPECT_NEAR(ad(0, 1), std::sin(w * t) / w, 1e-14);
  EXPECT_NEAR(ad(1, 0), -w * std::sin(w * t), 1e-12);
  EXPECT_NEAR(ad(1, 1), std::cos(w * t), 1e-14);
}

// Stiff and extreme springs, where plain scaling-and-squaring on the
// non-normal A T = [[0, T], [-w^2 T, 0]] loses the rotation (before
// balancing: cos(w T) off by 2.4e-6 at w T = 100, by 0.94 at w T = 3.2e5).
TEST(Integrators, ExactStaysARotationOnStiffSprings) {
  struct Case {
    double stiffness, inertia, period, tolerance;
  };
  for (const Case c : {Case{1e4, 1e-4, 1e-3, 1e-13}, Case{1e6, 1e-4, 1e-3, 1e-13},
                       Case{1e8, 1e-6, 1e-3, 1e-12}, Case{1e9, 1e-6, 1e-2, 1e-9}}) {
    const double w = std::sqrt(c.stiffness / c.inertia);
    const double wt = w * c.period;
    const Eigen::MatrixXd ad = ad_for(c.stiffness, c.inertia, 0.0, c.period, Integrator::exact);
    EXPECT_NEAR(ad(0, 0), std::cos(wt), c.tolerance) << "w T = " << wt;
    EXPECT_NEAR(ad(1, 1), std::cos(wt), c.tolerance) << "w T = " << wt;
    EXPECT_NEAR(ad(0, 1) * w, std::sin(wt), c.tolerance) << "w T = " << wt;
    EXPECT_NEAR(ad(1, 0) / w, -std::sin(wt), c.tolerance) << "w T = " << wt;
    EXPECT_NEAR(ad.determinant(), 1.0, 10 * c.tolerance) << "w T = " << wt;
  }
}

TEST(Integrators, BalancedExpOfAFarFromNormalMatrixIsTheSimilarOne) {
  // M = S M' S^-1 with S = diag(g, 1): exp(M) = S exp(M') S^-1, and M' is
  // well scaled, so Eigen's plain exp of it is the reference. Plain exp of M
  // itself is off by 3e-8 here; g is no power of two, so balancing cannot
  // hit S exactly.
  const double g = 1e9;
  Eigen::MatrixXd well(2, 2);
  well << -1.0, 1.0, -4.0, -3.0;
  const Eigen::Vector2d s(g, 1.0);
  const Eigen::MatrixXd far = s.asDiagonal() * well * s.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd expected = s.asDiagonal() * well.exp() * s.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd e = balanced_exp(far);
  for (Eigen::Index r = 0; r < 2; ++r) {
    for (Eigen::Index c = 0; c < 2; ++c) EXPECT_NEAR(e(r, c) / expected(r, c), 1.0, 1e-14) << r << c;
  }
}

TEST(Integrators, ForwardEulerDampedStableIffTBelowTwoZetaOverWn) {
  // Freudenberg 2.14: |lambda_d| < 1 iff T < 2 zeta / w_n.
  const double w = std::sqrt(k / j);
  const double zeta = 0.05;
  const double b = 2.0 * zeta * w * j;
  const double t_crit = 2.0 * zeta / w;
  EXPECT_LT(test::spectral_radius(ad_for(k, j, b, 0.99 * t_crit, Integrator::forward_euler)), 1.0);
  EXPECT_GT(test::spectral_radius(ad_for(k, j, b, 1.01 * t_crit, Integrator::forward_euler)), 1.0);
  EXPECT_NEAR(test::spectral_radius(ad_for(k, j, b, t_crit, Integrator::forward_euler)), 1.0, 1e-12);
  // 2.13 in full.
  for (const double t : {0.3 * t_crit, 2.0 * t_crit}) {
    for (const auto& l : eigenvalues(ad_for(k, j, b, t, Integrator::forward_euler))) {
      EXPECT_NEAR(std::norm(l), 1.0 - 2.0 * t * zeta * w + t * t * w * w, 1e-12);
    }
  }
}

TEST(Integrators, DampingTkMakesForwardEulerLossless) {
  // Freudenberg 2.15 / 2.24: b = T k puts the forward-Euler roots on the unit circle.
  for (const double t : {1e-4, 1e-3, 5e-3}) {
    for (const auto& l : eigenvalues(ad_for(k, j, t * k, t, Integrator::forward_euler))) {
      EXPECT_NEAR(std::abs(l), 1.0, 1e-12) << "T=" << t;
    }
  }
}

/// Max |F - F_exact| / (k z0) over `duration` of the held-step response
/// (y = z0 from n = 0), against the closed form F = -k z0 cos(w_n t)
/// (Freudenberg 2.4; the torque on the device has the opposite sign of 2.2).
double step_error(Integrator integrator, double period, double duration) {
  const SpringParameters p{k, j, 0.0, integrator};
  SpringScene<SpringDamping::none> scene(p, period);
  scene.reset(0.0);
  const double z0 = 0.5;
  const double w = std::sqrt(k / j);
  double worst = 0.0;
  const auto n = static_cast<int>(std::lround(duration / period));
  for (int i = 0; i <= n; ++i) {
    const double exact = -k * z0 * std::cos(w * i * period);
    worst = std::max(worst, std::abs(scene.step(z0) - exact));
  }
  return worst / (k * z0);
}

TEST(Integrators, OrderOfAccuracyOnAStepResponse) {
  struct Case {
    Integrator integrator;
    double expected_ratio;
  };
  for (const Case c : {Case{Integrator::forward_euler, 2.0}, Case{Integrator::semi_implicit_euler, 2.0},
                       Case{Integrator::trapezoid, 4.0}, Case{Integrator::rk4, 16.0}}) {
    const double coarse = step_error(c.integrator, 2e-3, 1.0);
    const double fine = step_error(c.integrator, 1e-3, 1.0);
    const double ratio = coarse / fine;
    EXPECT_NEAR(ratio, c.expected_ratio, 0.12 * c.expected_ratio) << to_string(c.integrator) << " " << coarse;
  }
  EXPECT_LT(step_error(Integrator::exact, 1e-3, 1.0), 1e-12);
}

}  // namespace
}  // namespace hapticd::world::integrator_test
