// The engine on a device with several axes (issue 22): a two-axis Cartesian
// loopback stage under `plane-wall` with n = (1, 1)/sqrt 2, the hand pushing
// along x: the force is along n with magnitude K times the penetration along
// n (to rounding), zero outside; one common saturation factor keeps its
// direction; the per-axis reading rules latch with the axis named; a clear
// restarts without a torque step. run_cycle is driven over a VirtualClock.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "daemon/engine/engine.hpp"
#include "drivers/device.hpp"
#include "drivers/loopback/loopback_device.hpp"
#include "rt/clock.hpp"
#include "rt/loop_timing.hpp"
#include "world/scene_catalog.hpp"

namespace engine_axes_test {

namespace {

using hapticd::daemon::TelemetrySample;
using hapticd::daemon::engine::Engine;
using hapticd::daemon::engine::EngineOptions;
using hapticd::daemon::engine::FaultReason;
using hapticd::daemon::engine::LoopPlan;
namespace loopback = hapticd::drivers::loopback;
namespace simulation = hapticd::drivers::simulation;
namespace world = hapticd::world;
namespace rt = hapticd::rt;

constexpr double period_s = 1e-3;

loopback::LoopbackStage stage(const std::vector<double>& masses, const std::vector<std::string>& hands) {
  loopback::LoopbackStage s;
  for (std::size_t i = 0; i < masses.size(); ++i) {
    auto axis = loopback::LoopbackConfig::defaults(hapticd::drivers::Motion::linear);
    axis.mass = masses[i];
    axis.counts = 1e9;  // 1 nm
    axis.max_force = 1e3;
    s.axes.push_back(axis);
    s.hands.push_back(simulation::parse_hand_script(hands[i]));
  }
  return s;
}

EngineOptions quiet_options() {
  EngineOptions options;
  options.realtime.priority = 0;
  options.realtime.lock_memory = false;
  options.realtime.hold_dma_latency = false;
  options.position_rule.max_velocity = 5.0;
  options.position_rule.resolution = 1e-9;
  options.position_rule.period_s = period_s;
  return options;
}

std::unique_ptr<LoopPlan> task_plan(const std::string& scene, const world::ParameterSet& parameters, int axes,
                                    double torque_limit) {
  auto outcome = world::plan_scene(scene, parameters, period_s, world::Motion::linear, axes);
  if (const auto* error = std::get_if<world::SceneError>(&outcome)) {
    ADD_FAILURE() << scene << ": " << error->message;
    return nullptr;
  }
  auto plan = std::make_unique<LoopPlan>();
  plan->task_scene = std::get<world::ScenePlan>(outcome).task_object;
  plan->torque_limit = torque_limit;
  return plan;
}

struct StageRig {
  explicit StageRig(const loopback::LoopbackStage& s)
      : device("loopback", std::make_unique<loopback::LoopbackDevice>(s)),
        plant(device.hooks_as<loopback::LoopbackDevice>()),
        engine(quiet_options(), device, clock),
        schedule(clock, rt::Nanos{1'000'000}) {
    device.configure({period_s});
    device.enable();
    schedule.start();
  }
  ~StageRig() { device.disable(); }
  void run(int n) {
    for (int i = 0; i < n; ++i) engine.run_cycle(schedule.wait_next());
  }
  std::vector<TelemetrySample> drain() {
    std::vector<TelemetrySample> out, buffer(4096);
    for (std::size_t n; (n = engine.drain(buffer)) > 0;)
      out.insert(out.end(), buffer.begin(), buffer.begin() + n);
    return out;
  }

  rt::VirtualClock clock;
  hapticd::drivers::Device device;
  loopback::LoopbackDevice& plant;
  Engine engine;
  rt::PeriodicSchedule schedule;
};

/// The channels of a two-axis sample: x, y, F_x, F_y, out_x, out_y, then the scene's.
struct TwoAxes {
  double x, y, fx, fy, ox, oy, penetration;
};
TwoAxes two_axes(const TelemetrySample& s) {
  return {s.channels[0], s.channels[1], s.channels[2], s.channels[3],
          s.channels[4], s.channels[5], s.channels[6]};
}

TEST(EngineAxes, APlaneWallAlongOneOneRendersKTimesThePenetrationAlongN) {
  // The hand moves x from +5 mm through the plane n . x = 0 to -5 mm and back; y held at 0.
  StageRig rig(stage({0.1, 0.3},
                     {"mode=hold trajectory=sine amplitude=0.005 frequency=1 phase=1.5707963", "mode=hold"}));
  const double k = 2000.0;
  rig.engine.publish(task_plan(
      "plane-wall", {{"normal", "1,1"}, {"stiffness", k}, {"damping", 0.0}, {"delay", 0.0}}, 2, 100.0));
  rig.run(1000);
  const auto samples = rig.drain();
  ASSERT_EQ(samples.size(), 1000U);
  const double n = 1.0 / std::sqrt(2.0);
  int inside = 0, outside = 0;
  double deepest = 0.0;
  for (const auto& s : samples) {
    ASSERT_EQ(s.channel_count, 7U);
    const TwoAxes a = two_axes(s);
    const double depth = std::max(0.0, -(a.x + a.y) * n);
    deepest = std::max(deepest, depth);
    // Along n with magnitude K depth, to rounding.
    EXPECT_NEAR(a.fx, k * depth * n, 1e-12) << s.cycle;
    EXPECT_NEAR(a.fy, k * depth * n, 1e-12) << s.cycle;
    EXPECT_EQ(a.ox, a.fx) << "J = I and nothing saturated";
    EXPECT_EQ(a.oy, a.fy);
    EXPECT_EQ(a.y, 0.0) << "the hand holds y";
    EXPECT_NEAR(a.penetration, (a.x + a.y) * -n, 1e-15);
    (depth > 0 ? inside : outside) += 1;
    if (depth == 0) {
      EXPECT_EQ(a.fx, 0.0);
      EXPECT_EQ(a.fy, 0.0);
    }
    EXPECT_EQ(s.position, a.x) << "the first axis in the one-axis fields";
    EXPECT_EQ(s.command, a.fx);
    EXPECT_EQ(s.applied, a.ox);
    EXPECT_EQ(s.flags, 0U);
  }
  EXPECT_GT(inside, 400);
  EXPECT_GT(outside, 400);
  EXPECT_NEAR(deepest, 0.005 * n, 1e-8);
  // What the plant felt: the applied force along n on both axes.
  const auto x_plant = rig.plant.simulator(0).snapshot();
  const auto y_plant = rig.plant.simulator(1).snapshot();
  EXPECT_EQ(x_plant.applied_force, samples.back().channels[4]);
  EXPECT_EQ(y_plant.applied_force, samples.back().channels[5]);
}

TEST(EngineAxes, OneCommonSaturationFactorKeepsTheForceDirection) {
  StageRig rig(stage({0.1, 0.3}, {"mode=hold trajectory=constant position=-0.004",
                                  "mode=hold trajectory=constant position=-0.001"}));
  rig.engine.publish(task_plan(
      "plane-wall",
      {{"normal", "3,1"}, {"stiffness", 5000.0}, {"damping", 0.0}, {"delay", 0.0}, {"offset", 0.001}}, 2,
      2.0));
  rig.run(3);
  const auto samples = rig.drain();
  const TwoAxes a = two_axes(samples.back());
  // Loaded outside? The wall starts disarmed if the device is inside: this one starts inside.
  EXPECT_EQ(a.fx, 0.0) << "disarmed: loaded with the device inside, no torque step";
  // Out (1 mm a period, within the position rule), then in again.
  rig.plant.simulator(0).set_hand("mode=hold trajectory=ramp from=-0.004 to=0.01 rate=1");
  rig.run(20);
  rig.plant.simulator(0).set_hand("mode=hold trajectory=ramp from=0.01 to=-0.004 rate=1");
  rig.run(20);
  const auto pushed = rig.drain();
  const auto& last = pushed.back();
  const TwoAxes b = two_axes(last);
  const double s = std::sqrt(10.0);
  const double depth = 0.001 - (3 * b.x + b.y) / s;
  ASSERT_GT(depth, 0.0);
  EXPECT_NEAR(b.fx, 5000.0 * depth * 3 / s, 1e-9);
  EXPECT_NEAR(b.fy, 5000.0 * depth * 1 / s, 1e-9);
  EXPECT_GT(std::abs(b.fx), 2.0) << "the scene's force exceeds the 2 N limit";
  EXPECT_NEAR(std::max(std::abs(b.ox), std::abs(b.oy)), 2.0, 1e-12) << "the largest axis at its limit";
  EXPECT_NEAR(b.ox * b.fy - b.oy * b.fx, 0.0, 1e-12) << "parallel: the direction is kept";
  EXPECT_NE(last.flags & hapticd::daemon::flag_torque_limited, 0U);
  EXPECT_GT(rig.engine.counters().torque_limited, 0U);
}

TEST(EngineAxes, AJumpOnOneAxisLatchesNamingItAndAClearRestartsWithoutAStep) {
  StageRig rig(stage({0.1, 0.3, 0.2}, {"mode=hold", "mode=hold", "mode=hold"}));
  rig.engine.publish(task_plan("box", {{"low", "-0.01,-0.01,-0.01"}, {"high", "0.01,0.01,0.01"}}, 3, 10.0));
  rig.run(10);
  rig.plant.simulator(1).inject_fault(simulation::Fault::encoder_jump, 20'000'000);  // 20 mm in one period
  rig.run(2);
  EXPECT_EQ(rig.engine.fault(), FaultReason::encoder_jump);
  const auto jump = rig.engine.position_jump();
  ASSERT_TRUE(jump.has_value());
  EXPECT_EQ(jump->axis, 1);
  EXPECT_NE(rig.engine.fault_description().find("(axis 2)"), std::string::npos)
      << rig.engine.fault_description();
  const auto latched = rig.drain();
  EXPECT_NE(latched.back().flags & hapticd::daemon::flag_fault_latched, 0U);
  for (int i = 6; i < 9; ++i) EXPECT_EQ(latched.back().channels[i], 0.0) << "zero output on every axis";
  // The jumped axis now reads 2 cm, 1 cm past the box's face: a clear
  // restarts at equilibrium there, the face disarmed until the device is out.
  rig.engine.clear_fault();
  rig.run(5);
  EXPECT_EQ(rig.engine.fault(), FaultReason::none);
  for (const auto& s : rig.drain()) {
    for (int i = 6; i < 9; ++i) EXPECT_EQ(s.channels[i], 0.0) << "no torque step after the clear";
  }
}

TEST(EngineAxes, NonFiniteReadingsAndReadErrorsLatchAsOnOneAxis) {
  StageRig rig(stage({0.1, 0.3}, {"mode=hold", "mode=hold"}));
  rig.engine.publish(task_plan("free", {}, 2, 10.0));
  rig.run(3);
  rig.plant.simulator(1).inject_fault(simulation::Fault::nan, 1);
  rig.run(1);
  EXPECT_EQ(rig.engine.fault(), FaultReason::non_finite_position);
  rig.engine.clear_fault();
  rig.plant.simulator(0).inject_fault(simulation::Fault::read_error, 20);
  rig.run(12);
  EXPECT_EQ(rig.engine.fault(), FaultReason::read_error_streak);
  EXPECT_EQ(rig.engine.counters().read_errors, 12U) << "every failed read counted, latched at the 10th";
}

TEST(EngineAxes, KinematicsThatDoNotFitTheDeviceAreRefused) {
  rt::VirtualClock clock;
  hapticd::drivers::Device device(
      "loopback", std::make_unique<loopback::LoopbackDevice>(stage({0.1, 0.3}, {"mode=free", "mode=free"})));
  EngineOptions options = quiet_options();
  options.kinematics = world::CartesianKinematics(3);
  EXPECT_THROW(Engine(options, device, clock), std::invalid_argument);
}

}  // namespace

}  // namespace engine_axes_test
