// The stability gate as a pure function (analysis/stability_gate.hpp): the
// daemon's plan_on_device wraps it (tests/daemon/planner_test.cpp covers
// that path); here what only the pure function's callers can ask.
#include "analysis/stability_gate.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace hapticd::analysis::stability_gate_test {
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

// Colgate & Schenkel beside the stability verdict: Hulin's wall (section 7)
// is stable on his device but needs far more damping than it has to be
// passive. The gate asks the generic H(z) path (scene_passivity of the
// plan's linear model); the wall's own closed form is the reference.
TEST(StabilityGate, SaysWhetherTheSceneIsPassiveOnTheDevicesDamping) {
  const world::ParameterSet hulin{{"stiffness", 9000.0}, {"damping", 46.0}, {"delay", 1.0}};
  const double reference = analyze_wall_passivity(9000.0, 46.0, 1e-3, 1, 2.0).bound.required_damping;
  EXPECT_NEAR(reference, 50.72, 0.005);  // README: `hapticctl analyze passivity`
  for (const double b : {2.0, 60.0}) {
    const GateDevice device = rigid_device(0.1, b, 1e-3, 0, world::Motion::linear);
    const GateOutcome accepted_outcome = gate_scene("wall", hulin, device, false);
    const auto* accepted = std::get_if<GateAccepted>(&accepted_outcome);
    ASSERT_NE(accepted, nullptr);
    const SceneStability& v = accepted->stability;
    EXPECT_TRUE(v.stable);
    EXPECT_TRUE(v.passivity.bounded());
    EXPECT_NEAR(v.passivity.required_damping, reference, 1e-9 * reference);
    EXPECT_EQ(v.passive, b >= reference) << b;
    EXPECT_EQ(v.device_damping, b);
    EXPECT_NE(v.passivity_summary.find(b >= reference ? "passive on this device: it needs b >= 50.7"
                                                      : "not passive on this device: it needs b >= 50.7"),
              std::string::npos)
        << v.passivity_summary;
    EXPECT_NE(v.passivity_summary.find(" N s/m"), std::string::npos) << v.passivity_summary;
  }
  // d = 0: K T / 2 + B, at Nyquist.
  const GateDevice device = rigid_device(0.1, 2.0, 1e-3, 0, world::Motion::linear);
  const world::ParameterSet no_delay{{"stiffness", 9000.0}, {"damping", 46.0}, {"delay", 0.0}};
  const GateOutcome d0_outcome = gate_scene("wall", no_delay, device, false);
  const auto* d0 = std::get_if<GateAccepted>(&d0_outcome);
  ASSERT_NE(d0, nullptr);
  EXPECT_NEAR(d0->stability.passivity.required_damping, 9000.0 * 1e-3 / 2 + 46.0, 1e-9);
  EXPECT_NEAR(d0->stability.passivity.frequency_hz, 500.0, 1e-6);
}

TEST(StabilityGate, AnUndampedWheelIsPassiveAtNoDampingAndNoNumberMakesItPassive) {
  const GateDevice device = rigid_device(0.01, 0.01, 1e-3, 0, world::Motion::rotary);
  const GateOutcome accepted_outcome = gate_scene("spring-wheel", wheel, device, false);
  const auto* accepted = std::get_if<GateAccepted>(&accepted_outcome);
  ASSERT_NE(accepted, nullptr);
  EXPECT_FALSE(accepted->stability.passive);
  EXPECT_EQ(accepted->stability.passivity.state, PassivityState::unbounded);
  EXPECT_EQ(accepted->stability.passivity_summary.rfind("not passive at any device damping: ", 0), 0u)
      << accepted->stability.passivity_summary;

  const GateDevice bad =
      rigid_device(0.01, std::numeric_limits<double>::infinity(), 1e-3, 0, world::Motion::rotary);
  const world::ParameterSet damped{{"integrator", std::string("exact")}, {"damping", 0.5}};
  const GateOutcome refused_outcome = gate_scene("spring-wheel", damped, bad, true);
  const auto* refused = std::get_if<GateRefusal>(&refused_outcome);
  ASSERT_NE(refused, nullptr);
  ASSERT_TRUE(refused->stability.has_value());
  EXPECT_FALSE(refused->stability->passive);
  EXPECT_NE(refused->stability->passivity_summary.find("cannot be assessed"), std::string::npos);
}

}  // namespace
}  // namespace hapticd::analysis::stability_gate_test
