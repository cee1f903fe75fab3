// Levenberg-Marquardt and the statistics of its minimum.

#include "analysis/least_squares.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace hapticd::analysis::least_squares_test {
namespace {

// y = a e^{-b t} + c with Gaussian noise: the fit recovers (a, b, c), and the
// 95 % intervals cover the truth.
TEST(LeastSquares, RecoversAnExponentialWithHonestIntervals) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  const double a = 2.0, b = 1.3, c = 0.5;
  Eigen::VectorXd t(200), y(200);
  for (int i = 0; i < 200; ++i) {
    t(i) = 0.025 * i;
    y(i) = a * std::exp(-b * t(i)) + c + noise(rng);
  }
  LeastSquaresProblem p;
  p.residuals = [&](const Eigen::VectorXd& th) {
    return Eigen::VectorXd((th(0) * (-th(1) * t.array()).exp() + th(2) - y.array()).matrix());
  };
  p.start = Eigen::Vector3d(1.0, 3.0, 0.0);
  p.scale = Eigen::Vector3d(1.0, 1.0, 1.0);
  const LeastSquaresFit fit = levenberg_marquardt(p);
  ASSERT_TRUE(fit.converged) << fit.stop_reason;
  const double truth[] = {a, b, c};
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(fit.parameters(j), truth[j], fit.half_width(j)) << j;
    EXPECT_LT(fit.half_width(j), 0.1) << j;
    EXPECT_GT(fit.half_width(j), 1e-4) << j;
  }
  EXPECT_NEAR(std::sqrt(fit.residual_variance), 0.01, 0.002);
}

// Two parameters that only ever appear as a sum: their correlation is -1,
// their own intervals are wide, the interval of their sum is narrow.
TEST(LeastSquares, ParametersThatOnlyAppearTogetherAreReportedAsSuch) {
  Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(50, 0.0, 1.0);
  Eigen::VectorXd y = 3.0 * x + Eigen::VectorXd::Constant(50, 1.0);
  for (int i = 0; i < 50; ++i) y(i) += 1e-3 * std::sin(17.0 * i);
  LeastSquaresProblem p;
  p.residuals = [&](const Eigen::VectorXd& th) {
    return Eigen::VectorXd(((th(0) + th(1)) * x.array() + th(2) - y.array()).matrix());
  };
  p.start = Eigen::Vector3d(1.0, 1.0, 0.0);
  p.scale = Eigen::Vector3d(1.0, 1.0, 1.0);
  const LeastSquaresFit fit = levenberg_marquardt(p);
  EXPECT_NEAR(fit.parameters(0) + fit.parameters(1), 3.0, 1e-3);
  EXPECT_LT(fit.correlation(0, 1), -0.999);
  EXPECT_GT(fit.half_width(0), 1e3);
  EXPECT_LT(fit.half_width_of(Eigen::Vector3d(1.0, 1.0, 0.0)), 1e-2);
  EXPECT_LT(fit.conditioning, 1e-8);
}

TEST(LeastSquares, RefusesWhatItCannotStart) {
  LeastSquaresProblem p;
  p.residuals = [](const Eigen::VectorXd& th) { return Eigen::VectorXd::Constant(1, th(0)); };
  p.start = Eigen::Vector2d(1.0, 1.0);
  p.scale = Eigen::Vector2d(1.0, 1.0);
  EXPECT_THROW(levenberg_marquardt(p), std::invalid_argument);  // 1 residual, 2 parameters
  p.residuals = [](const Eigen::VectorXd&) { return Eigen::VectorXd::Constant(3, std::nan("")); };
  EXPECT_THROW(levenberg_marquardt(p), std::invalid_argument);
  p.scale = Eigen::Vector2d(0.0, 1.0);
  EXPECT_THROW(levenberg_marquardt(p), std::invalid_argument);
}

}  // namespace
}  // namespace hapticd::analysis::least_squares_test
