#include "world/integrator.hpp"

#include <cmath>
#include <stdexcept>
#include <unsupported/Eigen/MatrixFunctions>

namespace hapticd::world {

namespace {
constexpr std::array<std::string_view, 5> integrator_name_table{"forward-euler", "semi-implicit-euler",
                                                                "trapezoid", "rk4", "exact"};
}

std::string_view to_string(Integrator integrator) noexcept {
  return integrator_name_table[static_cast<std::size_t>(integrator)];
}

std::optional<Integrator> parse_integrator(std::string_view name) noexcept {
  for (std::size_t i = 0; i < integrator_name_table.size(); ++i) {
    if (integrator_name_table[i] == name) return static_cast<Integrator>(i);
  }
  if (name == "euler") return Integrator::forward_euler;
  if (name == "tustin" || name == "trapezoidal") return Integrator::trapezoid;
  if (name == "zoh") return Integrator::exact;
  return std::nullopt;
}

std::string_view integrator_names() noexcept {
  return "forward-euler, semi-implicit-euler, trapezoid, rk4, exact";
}

Eigen::MatrixXd balanced_exp(const Eigen::MatrixXd& m) {
  // Osborne's iteration (as in LAPACK dgebal, without permutation): scale
  // row i down and column i up by a power of two until their off-diagonal
  // 1-norms are within a factor 2. Rows or columns that are zero (the input
  // rows of a ZOH augmentation) are left alone.
  const Eigen::Index n = m.rows();
  Eigen::MatrixXd balanced = m;
  Eigen::VectorXd scale = Eigen::VectorXd::Ones(n);
  for (bool converged = false; !converged;) {
    converged = true;
    for (Eigen::Index i = 0; i < n; ++i) {
      double column = balanced.col(i).cwiseAbs().sum() - std::abs(balanced(i, i));
      double row = balanced.row(i).cwiseAbs().sum() - std::abs(balanced(i, i));
      if (!(column > 0.0) || !(row > 0.0) || !std::isfinite(column + row)) continue;
      const double before = column + row;
      double f = 1.0;
      while (column < row / 2.0) {
        column *= 2.0;
        row /= 2.0;
        f *= 2.0;
      }
      while (column >= row * 2.0) {
        column /= 2.0;
        row *= 2.0;
        f /= 2.0;
      }
      if (column + row < 0.95 * before) {
        converged = false;
        scale(i) *= f;
        balanced.col(i) *= f;
        balanced.row(i) /= f;
      }
    }
  }
  return scale.asDiagonal() * balanced.exp() * scale.cwiseInverse().asDiagonal();
}

DiscreteStateSpace discretize_zoh(const ContinuousStateSpace& sys, double period_s) {
  const Eigen::Index n = sys.a.rows();
  const Eigen::Index m = sys.b.cols();
  Eigen::MatrixXd augmented = Eigen::MatrixXd::Zero(n + m, n + m);
  augmented.topLeftCorner(n, n) = sys.a * period_s;
  augmented.topRightCorner(n, m) = sys.b * period_s;
  const Eigen::MatrixXd e = balanced_exp(augmented);
  return {e.topLeftCorner(n, n), e.topRightCorner(n, m), period_s};
}

DiscreteStateSpace discretize(const ContinuousStateSpace& sys, double period_s, Integrator integrator) {
  const Eigen::Index n = sys.a.rows();
  const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(n, n);
  const Eigen::MatrixXd ta = sys.a * period_s;
  switch (integrator) {
    case Integrator::forward_euler:
      return {identity + ta, sys.b * period_s, period_s};
    case Integrator::semi_implicit_euler: {
      if (n % 2 != 0) throw std::invalid_argument("semi-implicit Euler needs [positions; velocities]");
      // Step 1 updates the velocity rows from the old state; step 2 the
      // position rows from the state that already holds the new velocity.
      const Eigen::Index half = n / 2;
      Eigen::MatrixXd select_velocity = Eigen::MatrixXd::Zero(n, n);
      select_velocity.bottomRightCorner(half, half).setIdentity();
      const Eigen::MatrixXd select_position = identity - select_velocity;
      const Eigen::MatrixXd velocity_step = identity + select_velocity * ta;
      const Eigen::MatrixXd position_step = identity + select_position * ta;
      return {position_step * velocity_step,
              position_step * select_velocity * sys.b * period_s + select_position * sys.b * period_s,
              period_s};
    }
    case Integrator::trapezoid: {
      const Eigen::MatrixXd lhs = identity - 0.5 * ta;
      const auto lu = lhs.partialPivLu();
      return {lu.solve(identity + 0.5 * ta), lu.solve(sys.b * period_s), period_s};
    }
    case Integrator::rk4: {
      // For x' = A x + B u with u held, one RK4 step is the Taylor series of
      // the exact map truncated after (TA)^4.
      const Eigen::MatrixXd ta2 = ta * ta;
      const Eigen::MatrixXd ta3 = ta2 * ta;
      const Eigen::MatrixXd ta4 = ta3 * ta;
      const Eigen::MatrixXd ad = identity + ta + ta2 / 2.0 + ta3 / 6.0 + ta4 / 24.0;
      const Eigen::MatrixXd phi = identity + ta / 2.0 + ta2 / 6.0 + ta3 / 24.0;
      return {ad, phi * sys.b * period_s, period_s};
    }
    case Integrator::exact:
      return discretize_zoh(sys, period_s);
  }
  throw std::invalid_argument("unknown integrator");
}

}  // namespace hapticd::world
