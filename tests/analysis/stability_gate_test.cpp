// The stability gate as a pure function (analysis/stability_gate.hpp): the
// daemon's plan_on_device wraps it (tests/daemon/planner_test.cpp covers
// that path); here what only the pure function's callers can ask.
#include "analysis/stability_gate.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace hapticd::analysis {
namespace {

const world::ParameterSet wheel{{"integrator", std::string("exact")}};

// Found by `hapticctl report stability`: an infinite inertia builds a plant
// whose matrices are finite (1/inf = 0: the device never moves), so the
// verdict came from a non-finite number and the set was accepted.
TEST(StabilityGate, NonFiniteDeviceMassCannotBeAssessed) {
  for (const double mass :
       {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()}) {
    for (const bool force : {false, true}) {
      const GateDevice device = rigid_device(mass, 0.01, 1e-3, 0, world::Motion::rotary);
      const GateOutcome outcome = gate_scene("spring-wheel", wheel, device, force);
      const auto* refused = std::get_if<GateRefusal>(&outcome);
      ASSERT_NE(refused, nullptr) << "mass " << mass << " force " << force;
      EXPECT_FALSE(refused->assessed);
      EXPECT_NE(refused->message.find("cannot be assessed"), std::string::npos) << refused->message;
      // The reason survives the verdict it came from (it once dangled: garbage bytes).
      EXPECT_NE(refused->message.find("the device's mass or inertia"), std::string::npos) << refused->message;
      ASSERT_TRUE(refused->stability.has_value());
      EXPECT_EQ(refused->stability->reason.rfind("the device's mass or inertia ", 0), 0u)
          << refused->stability->reason;
    }
  }
}

TEST(StabilityGate, NonFiniteDeviceDampingCannotBeAssessed) {
  const GateDevice device =
      rigid_device(0.01, std::numeric_limits<double>::infinity(), 1e-3, 0, world::Motion::rotary);
  const GateOutcome outcome = gate_scene("spring-wheel", wheel, device, false);
  const auto* refused = std::get_if<GateRefusal>(&outcome);
  ASSERT_NE(refused, nullptr);
  EXPECT_FALSE(refused->assessed);
}

TEST(StabilityGate, FiniteDeviceIsJudgedAsBefore) {
  const GateDevice device = rigid_device(0.01, 0.01, 1e-3, 0, world::Motion::rotary);
  const GateOutcome outcome = gate_scene("spring-wheel", wheel, device, false);
  const auto* accepted = std::get_if<GateAccepted>(&outcome);
  ASSERT_NE(accepted, nullptr);
  EXPECT_TRUE(accepted->stability.stable);
  EXPECT_EQ(accepted->stability.verdict, VerdictState::marginal);  // the undamped wheel held: |lambda| = 1
}

}  // namespace
}  // namespace hapticd::analysis
