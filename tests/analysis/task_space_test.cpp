// The device along a task-space direction (analysis/task_space.hpp): m_n for
// a Cartesian stage, exact with proportional damping and a stated bound
// otherwise; a 2-axis stage simulated with a plane wall holds below the
// one-axis Hulin limit with m_n and grows above it; the pantograph's worst
// case over its workspace.

#include "analysis/task_space.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <vector>

#include "analysis/wall_stability.hpp"

namespace task_space_test {

namespace {

using hapticd::analysis::cartesian_along;
using hapticd::analysis::JointModel;
using hapticd::analysis::pantograph_along;
using hapticd::analysis::TaskBox;
using hapticd::world::AxisVector;

AxisVector vec(double a, double b) {
  AxisVector v(2);
  v << a, b;
  return v;
}

TEST(TaskSpace, AlongAnAxisTheMassIsThatAxissMass) {
  const std::vector<JointModel> axes{{0.1, 0.0}, {0.3, 0.0}};
  EXPECT_DOUBLE_EQ(cartesian_along(axes, vec(1, 0)).mass, 0.1);
  EXPECT_DOUBLE_EQ(cartesian_along(axes, vec(0, -2)).mass, 0.3);
}

TEST(TaskSpace, AlongTheDiagonalTheMassIsTheHarmonicCombination) {
  // m_n = 1 / (0.5 / 0.1 + 0.5 / 0.3) = 0.15 kg.
  const std::vector<JointModel> proportional{{0.1, 0.2}, {0.3, 0.6}};
  const auto d = cartesian_along(proportional, vec(1, 1));
  EXPECT_NEAR(d.mass, 0.15, 1e-15);
  EXPECT_TRUE(d.exact);
  EXPECT_NEAR(d.damping, 2.0 * 0.15, 1e-15) << "c m_n with c = b / m = 2 /s";
  const std::vector<JointModel> unequal{{0.1, 0.2}, {0.3, 0.3}};  // 2 /s and 1 /s
  const auto bound = cartesian_along(unequal, vec(1, 1));
  EXPECT_FALSE(bound.exact);
  EXPECT_NEAR(bound.damping, 1.0 * 0.15, 1e-15) << "the least damping per unit mass";
  EXPECT_NE(bound.basis.find("a bound"), std::string::npos) << bound.basis;
}

TEST(TaskSpace, BadDirectionsAndMassesAreRefused) {
  const std::vector<JointModel> axes{{0.1, 0.0}, {0.3, 0.0}};
  EXPECT_THROW(cartesian_along(axes, vec(0, 0)), std::invalid_argument);
  EXPECT_THROW(cartesian_along(axes, vec(NAN, 1)), std::invalid_argument);
  const std::vector<JointModel> massless{{0.0, 0.0}, {0.3, 0.0}};
  EXPECT_THROW(cartesian_along(massless, vec(1, 0)), std::invalid_argument);
}

/// A 2-axis stage (masses m) under a bilateral plane wall with normal n,
/// Hulin's law d samples late through a zero-order hold, each axis
/// integrated exactly. Returns the penetration's amplitude in the last
/// tenth of the run over its amplitude in the first tenth.
double plane_wall_growth(const std::vector<double>& m, const AxisVector& normal, double k, double b, int d) {
  const double period = 1e-3;
  const AxisVector n = normal.normalized();
  double x[2] = {1e-3 * n(0), 1e-3 * n(1)}, v[2] = {0.0, 0.02};  // a tangential drift too
  std::deque<double> p(static_cast<std::size_t>(d) + 2, n(0) * x[0] + n(1) * x[1]);
  const int steps = 20000;
  double early = 0.0, late = 0.0;
  for (int k_step = 0; k_step < steps; ++k_step) {
    const double now = n(0) * x[0] + n(1) * x[1];
    p.push_back(now);
    p.pop_front();
    const double delayed = p[1], before = p[0];  // p_{k-d}, p_{k-d-1}
    const double f = -k * delayed - b * (delayed - before) / period;
    for (int i = 0; i < 2; ++i) {
      const double a = f * n(i) / m[static_cast<std::size_t>(i)];
      x[i] += v[i] * period + 0.5 * a * period * period;
      v[i] += a * period;
    }
    if (k_step < steps / 10) early = std::max(early, std::abs(now));
    if (k_step >= steps - steps / 10) late = std::max(late, std::abs(now));
  }
  return late / early;
}

TEST(TaskSpace, APlaneWallOnAStageHoldsExactlyUpToTheOneAxisLimitWithMn) {
  const std::vector<double> masses{0.1, 0.3};
  const std::vector<JointModel> axes{{0.1, 0.0}, {0.3, 0.0}};
  for (const AxisVector& n : {vec(1, 1), vec(1, -2), vec(3, 1)}) {
    for (const int d : {0, 1, 2}) {
      const double mn = cartesian_along(axes, n).mass;
      const auto hulin = hapticd::analysis::analyze_wall(mn, 1e-3, d, std::nullopt, std::nullopt);
      const double b = hulin.b_at_k_max;
      EXPECT_LT(plane_wall_growth(masses, n, 0.97 * hulin.k_max, b, d), 0.5)
          << "n = " << n.transpose() << ", d = " << d << ": decays below k_max = " << hulin.k_max;
      EXPECT_GT(plane_wall_growth(masses, n, 1.03 * hulin.k_max, b, d), 2.0)
          << "n = " << n.transpose() << ", d = " << d << ": grows above k_max";
    }
  }
}

TEST(TaskSpace, ThePantographsWorstCaseIsTheLightestConfigurationOfTheBox) {
  const hapticd::world::PantographKinematics k({});
  const std::vector<JointModel> joints{{2e-4, 0.0}, {2e-4, 0.0}};  // kg m^2 at each motor
  const TaskBox box{-0.02, 0.06, 0.07, 0.12};
  const auto worst = pantograph_along(k, joints, vec(0, 1), box);
  EXPECT_FALSE(worst.exact);
  EXPECT_NE(worst.basis.find("a bound"), std::string::npos);
  // No point of a fine independent grid is lighter (to the refinement's tolerance).
  for (double x = box.x_min; x <= box.x_max + 1e-12; x += 0.0025) {
    for (double y = box.y_min; y <= box.y_max + 1e-12; y += 0.0025) {
      hapticd::world::TaskState s;
      k.solve(*k.inverse(vec(x, y)), s);
      const double m = 1.0 / (s.jacobian.row(1).squaredNorm() / 2e-4);
      EXPECT_GE(m, worst.mass * (1.0 - 1e-6)) << "(" << x << ", " << y << ")";
    }
  }
  EXPECT_THROW(pantograph_along(k, joints, vec(0, 1), TaskBox{-0.02, 0.06, 0.07, 0.5}), std::invalid_argument)
      << "a box reaching beyond the linkage cannot be held";
}

}  // namespace

}  // namespace task_space_test
