// Kinematics (world/kinematics.hpp): the pantograph's forward and inverse
// kinematics round trip, its Jacobian against finite differences over the
// workspace, J^T against virtual work, the common saturation factor, and
// what happens outside the workspace and at singularities.

#include "world/kinematics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "tests/support/alloc_counter.hpp"

namespace kinematics_test {

namespace {

using namespace hapticd::world;

AxisVector vec(double a, double b) {
  AxisVector v(2);
  v << a, b;
  return v;
}

/// Handle positions of the Hapkit/Haply-sized pantograph's working area.
std::vector<AxisVector> workspace_grid() {
  std::vector<AxisVector> points;
  for (double x = -0.04; x <= 0.08; x += 0.01)
    for (double y = 0.06; y <= 0.14; y += 0.01) points.push_back(vec(x, y));
  return points;
}

TEST(CartesianKinematics, IsTheIdentityOnEveryAxis) {
  const CartesianKinematics k(3);
  AxisVector q(3);
  q << 0.1, -0.2, 0.3;
  TaskState s;
  k.solve(q, s);
  EXPECT_EQ(s.status, KinematicsStatus::ok);
  EXPECT_EQ(s.position, q);
  EXPECT_TRUE(s.jacobian.isIdentity());
  EXPECT_THROW(CartesianKinematics(7), std::invalid_argument);
  EXPECT_THROW(CartesianKinematics(0), std::invalid_argument);
}

TEST(PantographKinematics, ForwardAndInverseRoundTripOverTheWorkspace) {
  const PantographKinematics k({});
  int reached = 0;
  for (const AxisVector& x : workspace_grid()) {
    const auto q = k.inverse(x);
    if (!q) continue;
    TaskState s;
    k.solve(*q, s);
    if (s.status != KinematicsStatus::ok) continue;
    ++reached;
    EXPECT_NEAR((s.position - x).norm(), 0.0, 1e-12) << x.transpose();
  }
  EXPECT_GT(reached, 60) << "most of the grid is in the workspace";
}

TEST(PantographKinematics, TheJacobianMatchesFiniteDifferences) {
  const PantographKinematics k({});
  const double h = 1e-6;
  int checked = 0;
  for (const AxisVector& x : workspace_grid()) {
    const auto q = k.inverse(x);
    if (!q) continue;
    TaskState s;
    k.solve(*q, s);
    if (s.status != KinematicsStatus::ok) continue;
    for (int j = 0; j < 2; ++j) {
      AxisVector plus = *q, minus = *q;
      plus(j) += h;
      minus(j) -= h;
      TaskState sp, sm;
      k.solve(plus, sp);
      k.solve(minus, sm);
      const AxisVector column = (sp.position - sm.position) / (2 * h);
      EXPECT_NEAR((column - s.jacobian.col(j)).norm(), 0.0, 1e-7 * (1.0 + s.jacobian.col(j).norm()))
          << "at " << x.transpose() << ", joint " << j;
    }
    ++checked;
  }
  EXPECT_GT(checked, 60);
}

TEST(PantographKinematics, TorquesAreTheForcesVirtualWork) {
  // tau . dq = F . dx for a small joint motion dq (to second order).
  const PantographKinematics k({});
  const AxisVector q = *k.inverse(vec(0.02, 0.1));
  TaskState s;
  k.solve(q, s);
  ASSERT_EQ(s.status, KinematicsStatus::ok);
  const AxisVector force = vec(1.5, -0.7), limits = vec(100.0, 100.0);
  AxisVector tau;
  EXPECT_EQ(joint_torques(s.jacobian, force, limits, tau), 1.0);
  const AxisVector dq = vec(2e-6, -1e-6);
  TaskState moved;
  k.solve(q + dq, moved);
  EXPECT_NEAR(tau.dot(dq), force.dot(moved.position - s.position), 1e-12);
}

TEST(PantographKinematics, SaturationKeepsTheForcesDirection) {
  const PantographKinematics k({});
  TaskState s;
  k.solve(*k.inverse(vec(0.03, 0.08)), s);
  ASSERT_EQ(s.status, KinematicsStatus::ok);
  const AxisVector force = vec(40.0, 25.0), limits = vec(0.5, 0.8);
  AxisVector tau;
  const double factor = joint_torques(s.jacobian, force, limits, tau);
  ASSERT_LT(factor, 1.0);
  EXPECT_LE(std::abs(tau(0)), 0.5 + 1e-12);
  EXPECT_LE(std::abs(tau(1)), 0.8 + 1e-12);
  EXPECT_TRUE(std::abs(tau(0)) >= 0.5 - 1e-12 || std::abs(tau(1)) >= 0.8 - 1e-12) << "one joint at its limit";
  // The force the torques render: F = J^-T tau, along the asked force.
  const AxisVector rendered = s.jacobian.transpose().inverse() * tau;
  EXPECT_NEAR(rendered.normalized().dot(force.normalized()), 1.0, 1e-12);
  EXPECT_NEAR(rendered.norm() / force.norm(), factor, 1e-12);
  AxisVector bad;
  EXPECT_EQ(joint_torques(s.jacobian, vec(NAN, 1.0), limits, bad), 0.0);
  EXPECT_EQ(bad, vec(0.0, 0.0));
}

TEST(PantographKinematics, OutsideTheWorkspaceAndAtSingularitiesNoNumberIsMadeUp) {
  const PantographKinematics k({});
  TaskState s;
  // Both arms pointing away from each other: the elbows 0.178 m apart, the
  // distal links (2 x 0.08 m here) cannot meet.
  PantographGeometry short_distal;
  short_distal.a2 = short_distal.a3 = 0.08;
  PantographKinematics(short_distal).solve(vec(std::numbers::pi, 0.0), s);
  EXPECT_EQ(s.status, KinematicsStatus::out_of_workspace);
  EXPECT_TRUE(s.position.allFinite() && s.jacobian.allFinite());
  // The handle at full stretch straight above: the distal links in line with
  // the proximal ones.
  const PantographGeometry g;
  const double reach = g.a1 + g.a2;
  const auto stretched = k.inverse(vec(g.a5 / 2, std::sqrt(reach * reach - g.a5 * g.a5 / 4) - 1e-9));
  ASSERT_TRUE(stretched.has_value());
  k.solve(*stretched, s);
  EXPECT_EQ(s.status, KinematicsStatus::singular);
  k.solve(vec(NAN, 1.0), s);
  EXPECT_EQ(s.status, KinematicsStatus::out_of_workspace);
  EXPECT_FALSE(k.inverse(vec(0.5, 0.5)).has_value()) << "half a metre away";
}

TEST(PantographKinematics, ALinkThatIsNotALengthIsRefusedByName) {
  PantographGeometry g;
  g.a3 = -0.09;
  try {
    PantographKinematics bad(g);
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "pantograph: link a3 must be a positive length in m");
  }
}

TEST(Kinematics, TheRtCallsAllocateNothing) {
  ASSERT_TRUE(hapticd::testing::allocation_counting_active());
  const Kinematics pantograph = PantographKinematics({});
  const AxisVector q = *std::get<PantographKinematics>(pantograph).inverse(vec(0.02, 0.1));
  const AxisVector force = vec(1.0, 2.0), limits = vec(0.3, 0.3);
  TaskState s;
  AxisVector tau;
  double factors = 0.0;
  std::size_t allocations = 0;
  {
    hapticd::testing::AllocationGuard guard;
    for (int i = 0; i < 100; ++i) {
      solve(pantograph, q, s);
      factors += joint_torques(s.jacobian, force, limits, tau);
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(s.status, KinematicsStatus::ok);
  EXPECT_GT(factors, 0.0);
}

}  // namespace

}  // namespace kinematics_test
