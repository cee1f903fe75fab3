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

}  // namespace gravity_test
