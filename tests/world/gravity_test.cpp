// Gravity compensation of the pantograph (world/gravity.hpp): the torques
// are the gradient of the links' potential energy, checked against finite
// differences of V(q) computed from the link positions alone.

#include "world/gravity.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace gravity_test {

namespace {

using namespace hapticd::world;

/// V(q) = g sum m_k y_k from the elbow and handle positions, independently
/// of the code under test.
double potential(const PantographKinematics& k, const PantographMasses& m, double q1, double q2) {
  AxisVector q(2);
  q << q1, q2;
  TaskState s;
  k.solve(q, s);
  const PantographGeometry& g = k.geometry();
  const double elbow_left = g.a1 * std::sin(q1), elbow_right = g.a4 * std::sin(q2), handle = s.position(1);
  return m.gravity * (m.proximal_left * elbow_left / 2 + m.distal_left * (elbow_left + handle) / 2 +
                      m.distal_right * (elbow_right + handle) / 2 + m.proximal_right * elbow_right / 2 +
                      m.handle * handle);
}

TEST(Gravity, ThePantographsTorquesAreTheGradientOfItsPotentialEnergy) {
  const PantographKinematics k({});
  const PantographMasses m{0.02, 0.03, 0.035, 0.025, 0.05};
  for (const auto& [x, y] : {std::pair{0.02, 0.1}, {-0.01, 0.08}, {0.05, 0.12}}) {
    AxisVector task(2);
    task << x, y;
    const AxisVector q = *k.inverse(task);
    TaskState s;
    k.solve(q, s);
    ASSERT_EQ(s.status, KinematicsStatus::ok);
    const AxisVector tau = pantograph_gravity_torques(k, m, q, s);
    const double h = 1e-6;
    const double d1 = (potential(k, m, q(0) + h, q(1)) - potential(k, m, q(0) - h, q(1))) / (2 * h);
    const double d2 = (potential(k, m, q(0), q(1) + h) - potential(k, m, q(0), q(1) - h)) / (2 * h);
    EXPECT_NEAR(tau(0), d1, 1e-8) << x << ", " << y;
    EXPECT_NEAR(tau(1), d2, 1e-8) << x << ", " << y;
  }
}

TEST(Gravity, NoFeedforwardAtASingularConfiguration) {
  const PantographKinematics k({});
  TaskState singular;
  singular.status = KinematicsStatus::singular;
  AxisVector q(2);
  q << 1.0, 2.0;
  EXPECT_EQ(pantograph_gravity_torques(k, {0.1, 0.1, 0.1, 0.1, 0.1}, q, singular), AxisVector::Zero(2));
}

}  // namespace

namespace {

using namespace hapticd::world;

AxisVector vec(double a, double b) {
  AxisVector v(2);
  v << a, b;
  return v;
}

TEST(GravityFeedforward, TheSumOfJTransposeFAndTheFeedforwardIsScaledByOneCommonFactor) {
  // J = I: tau = F + tau_g = (3, 2); limits 1 N: factor 1/3 on the sum, its direction kept.
  const AxisMatrix identity = AxisMatrix::Identity(2, 2);
  AxisVector tau;
  const double factor = joint_torques(identity, vec(3, 0), vec(0, 2), vec(1, 1), tau);
  EXPECT_DOUBLE_EQ(factor, 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(tau(0), 1.0);
  EXPECT_DOUBLE_EQ(tau(1), 2.0 / 3.0);
  // Below the limits: the sum as it is.
  EXPECT_EQ(joint_torques(identity, vec(0.5, 0), vec(0, -0.25), vec(1, 1), tau), 1.0);
  EXPECT_EQ(tau, vec(0.5, -0.25));
  // A feedforward that cancels the force: zero, nothing scaled.
  EXPECT_EQ(joint_torques(identity, vec(0, 4), vec(0, -4), vec(1, 1), tau), 1.0);
  EXPECT_EQ(tau, vec(0, 0));
}

TEST(GravityFeedforward, ANonFiniteOrMisSizedFeedforwardGivesZeroTorques) {
  const AxisMatrix identity = AxisMatrix::Identity(2, 2);
  AxisVector tau;
  EXPECT_EQ(joint_torques(identity, vec(1, 0), vec(std::nan(""), 0), vec(1, 1), tau), 0.0);
  EXPECT_EQ(tau, vec(0, 0));
  AxisVector three = AxisVector::Zero(3);
  EXPECT_EQ(joint_torques(identity, vec(1, 0), three, vec(1, 1), tau), 0.0);
  EXPECT_EQ(tau, vec(0, 0));
}

TEST(GravityFeedforward, AStageWeightIsItsHoldingForceOnItsAxes) {
  StageWeight stage{vec(0, 0.3 * standard_gravity)};
  const Kinematics cartesian = CartesianKinematics(2);
  TaskState s;
  solve(cartesian, vec(0.01, -0.02), s);
  AxisVector tau;
  gravity_torques(stage, cartesian, vec(0.01, -0.02), s, tau);
  EXPECT_EQ(tau, vec(0, 0.3 * standard_gravity));
  // A pantograph's masses on a stage: no feedforward.
  gravity_torques(PantographMasses{0.1, 0.1, 0.1, 0.1, 0.1}, cartesian, vec(0.01, -0.02), s, tau);
  EXPECT_EQ(tau, vec(0, 0));
}

TEST(GravityFeedforward, ThePantographsFeedforwardAndAHandForceComposeByVirtualWork) {
  // tau = J^T F + dV/dq: the power of the joint torques equals the hand
  // force's power plus the rate of the potential energy, F . dx + dV, for a
  // small joint motion dq (J dq = dx), checked by finite differences.
  const PantographKinematics k({});
  const Kinematics kinematics = k;
  const PantographMasses m{0.02, 0.03, 0.035, 0.025, 0.05};
  const AxisVector q = *k.inverse(vec(0.01, 0.1));
  TaskState s;
  k.solve(q, s);
  ASSERT_EQ(s.status, KinematicsStatus::ok);
  AxisVector feedforward;
  gravity_torques(m, kinematics, q, s, feedforward);
  EXPECT_EQ(feedforward, pantograph_gravity_torques(k, m, q, s));
  const AxisVector force = vec(0.4, -0.3);
  AxisVector tau;
  ASSERT_EQ(joint_torques(s.jacobian, force, feedforward, vec(10, 10), tau), 1.0);
  for (const AxisVector& dq : {vec(1e-6, 0), vec(0, 1e-6), vec(7e-7, -4e-7)}) {
    TaskState moved;
    k.solve(q + dq, moved);
    TaskState back;
    k.solve(q - dq, back);
    const AxisVector dx = (moved.position - back.position) / 2;
    const double dv =
        (potential(k, m, q(0) + dq(0), q(1) + dq(1)) - potential(k, m, q(0) - dq(0), q(1) - dq(1))) / 2;
    EXPECT_NEAR(tau.dot(dq), force.dot(dx) + dv, 1e-13);
  }
  // Saturated, the sum keeps its direction.
  AxisVector limited;
  const double factor = joint_torques(s.jacobian, force * 100, feedforward, vec(0.01, 0.01), limited);
  ASSERT_LT(factor, 1.0);
  const AxisVector full = s.jacobian.transpose() * (force * 100) + feedforward;
  EXPECT_NEAR(limited(0) * full(1) - limited(1) * full(0), 0.0, 1e-15);
  EXPECT_NEAR(limited.cwiseAbs().maxCoeff(), 0.01, 1e-15);
}

}  // namespace

}  // namespace gravity_test
