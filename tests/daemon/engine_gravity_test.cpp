// Gravity compensation and the workspace wall on a device with several axes
// (issue 22 item 7), on a two-axis Cartesian loopback stage whose y axis is
// vertical (the plant carries the weight -m g on y): the feedforward m g,
// added after the scene, holds y still with the free scene and no hand;
// without it y falls; the feedforward saturates with the scene's force by
// one common factor; the workspace box holds the device inside while the
// scene is free and the hand pushes outward, penetrating F/K. The
// pantograph in a vertical plane: the link masses' feedforward dV/dq holds
// its handle still; without it the handle falls. One vertical axis alone:
// its weight after the scene, limited with it, allocating nothing.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "daemon/engine/engine.hpp"
#include "drivers/device.hpp"
#include "drivers/loopback/loopback_device.hpp"
#include "rt/clock.hpp"
#include "rt/loop_timing.hpp"
#include "tests/support/alloc_counter.hpp"
#include "world/gravity.hpp"
#include "world/scene_catalog.hpp"

namespace engine_gravity_test {

namespace {

using hapticd::daemon::TelemetrySample;
using hapticd::daemon::engine::Engine;
using hapticd::daemon::engine::EngineOptions;
using hapticd::daemon::engine::LoopPlan;
namespace loopback = hapticd::drivers::loopback;
namespace simulation = hapticd::drivers::simulation;
namespace world = hapticd::world;
namespace rt = hapticd::rt;

constexpr double period_s = 1e-3;
constexpr double y_mass = 0.3;  // kg
const double weight = y_mass * world::standard_gravity;

/// x horizontal (0.1 kg), y vertical (0.3 kg, weighing -m g), free hands unless given.
loopback::LoopbackStage vertical_stage(const std::string& x_hand = "mode=free",
                                       const std::string& y_hand = "mode=free") {
  loopback::LoopbackStage s;
  for (const double mass : {0.1, y_mass}) {
    auto axis = loopback::LoopbackConfig::defaults(hapticd::drivers::Motion::linear);
    axis.mass = mass;
    axis.counts = 1e9;  // 1 nm
    axis.max_force = 1e3;
    s.axes.push_back(axis);
  }
  s.axes[1].weight = -weight;
  s.hands = {simulation::parse_hand_script(x_hand), simulation::parse_hand_script(y_hand)};
  return s;
}

EngineOptions options_with(std::optional<world::GravityModel> gravity,
                           std::optional<world::AnyTaskScene> workspace) {
  EngineOptions options;
  options.realtime.priority = 0;
  options.realtime.lock_memory = false;
  options.realtime.hold_dma_latency = false;
  options.position_rule.max_velocity = 50.0;
  options.position_rule.resolution = 1e-9;
  options.position_rule.period_s = period_s;
  options.gravity = std::move(gravity);
  options.workspace = std::move(workspace);
  return options;
}

world::GravityModel y_up() {
  world::StageWeight stage{world::AxisVector::Zero(2)};
  stage.holding(1) = weight;
  return stage;
}

world::AnyTaskScene task_scene(const std::string& name, const world::ParameterSet& parameters) {
  auto outcome = world::plan_scene(name, parameters, period_s, world::Motion::linear, 2);
  if (const auto* error = std::get_if<world::SceneError>(&outcome)) ADD_FAILURE() << error->message;
  return std::get<world::ScenePlan>(outcome).task_object;
}

std::unique_ptr<LoopPlan> plan_of(const std::string& name, const world::ParameterSet& parameters,
                                  double torque_limit) {
  auto plan = std::make_unique<LoopPlan>();
  plan->task_scene = task_scene(name, parameters);
  plan->torque_limit = torque_limit;
  return plan;
}

struct Rig {
  Rig(const loopback::LoopbackStage& s, EngineOptions options)
      : device("loopback", std::make_unique<loopback::LoopbackDevice>(s)),
        plant(device.hooks_as<loopback::LoopbackDevice>()),
        engine(std::move(options), device, clock),
        schedule(clock, rt::Nanos{1'000'000}) {
    device.configure({period_s});
    device.enable();
    schedule.start();
  }
  ~Rig() { device.disable(); }
  std::vector<TelemetrySample> run(int n) {
    std::vector<TelemetrySample> out, buffer(4096);
    for (int i = 0; i < n; ++i) {
      engine.run_cycle(schedule.wait_next());
      for (std::size_t got; (got = engine.drain(buffer)) > 0;)
        out.insert(out.end(), buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(got));
    }
    return out;
  }
  rt::VirtualClock clock;
  hapticd::drivers::Device device;
  loopback::LoopbackDevice& plant;
  Engine engine;
  rt::PeriodicSchedule schedule;
};

/// One vertical axis: y of the stage above alone, a wall far below it.
std::unique_ptr<LoopPlan> one_axis_wall(double torque_limit, double position) {
  auto outcome = world::plan_scene(
      "wall", {{"stiffness", 1000.0}, {"position", position}, {"side", std::string("lower")}}, period_s,
      world::Motion::linear, 1);
  if (const auto* error = std::get_if<world::SceneError>(&outcome)) ADD_FAILURE() << error->message;
  auto plan = std::make_unique<LoopPlan>();
  plan->scene = std::get<world::ScenePlan>(outcome).scene_object;
  plan->torque_limit = torque_limit;
  return plan;
}

TEST(EngineGravity, OneVerticalAxisTakesItsWeightAfterTheSceneInsideTheLimitAllocatingNothing) {
  loopback::LoopbackStage s = vertical_stage();
  s.axes = {s.axes[1]};
  s.hands = {s.hands[1]};
  Rig rig(s, options_with(world::StageWeight{world::AxisVector::Constant(1, weight)}, std::nullopt));
  rig.engine.publish(one_axis_wall(10.0, -1.0));
  rig.run(5);
  {
    hapticd::testing::AllocationGuard guard;
    for (int i = 0; i < 100; ++i) rig.engine.run_cycle(rig.schedule.wait_next());
    const auto allocations = guard.count();
    EXPECT_EQ(allocations, 0U);
  }
  const auto samples = rig.run(1000);
  const std::size_t wall_channels = world::channel_count(one_axis_wall(10.0, -1.0)->scene);
  double drift = 0.0;
  for (const auto& sample : samples) {
    ASSERT_EQ(sample.channel_count, 1U + wall_channels) << "gravity, then the wall's";
    EXPECT_EQ(sample.channels[0], weight) << "m g, recorded first";
    EXPECT_EQ(sample.command, 0.0) << "the wall far below: no force";
    EXPECT_EQ(sample.applied, weight) << "scene plus feedforward";
    drift = std::max(drift, std::abs(sample.position));
  }
  EXPECT_LE(drift, 1e-9) << "held to the encoder's count";
  // A torque limit below m g: the sum goes out limited, flagged.
  rig.engine.publish(one_axis_wall(2.0, -1.0));
  const auto limited = rig.run(3);
  EXPECT_EQ(limited.back().applied, 2.0);
  EXPECT_EQ(limited.back().channels[0], weight) << "the feedforward asked for, before the limit";
  EXPECT_NE(limited.back().flags & hapticd::daemon::flag_torque_limited, 0U);
}

TEST(EngineGravity, TheFeedforwardHoldsAVerticalAxisStillWithTheFreeScene) {
  Rig rig(vertical_stage(), options_with(y_up(), std::nullopt));
  rig.engine.publish(plan_of("free", {}, 10.0));
  const auto samples = rig.run(2000);
  ASSERT_EQ(samples.size(), 2000U);
  double drift = 0.0;
  for (const auto& s : samples) {
    // position_x, position_y, force_x, force_y, output_x, output_y, gravity_x, gravity_y
    ASSERT_EQ(s.channel_count, 8U);
    EXPECT_EQ(s.channels[2], 0.0) << "the free scene's force";
    EXPECT_EQ(s.channels[3], 0.0);
    EXPECT_EQ(s.channels[6], 0.0) << "x is horizontal";
    EXPECT_EQ(s.channels[7], weight) << "m g on y";
    EXPECT_EQ(s.channels[5], weight) << "sent as it is: below the limit";
    drift = std::max(drift, std::abs(s.channels[1]));
  }
  // The feedforward is the plant's weight to the last bit: no net force, so
  // no motion at all (a bound of one encoder count, 1 nm).
  EXPECT_LE(drift, 1e-9);
}

TEST(EngineGravity, WithoutTheFeedforwardTheAxisFalls) {
  Rig rig(vertical_stage(), options_with(std::nullopt, std::nullopt));
  rig.engine.publish(plan_of("free", {}, 10.0));
  const auto samples = rig.run(200);
  ASSERT_EQ(samples.back().channel_count, 6U) << "no gravity channels without [gravity]";
  // Free fall over 0.2 s: g t^2 / 2 = 0.196 m.
  EXPECT_NEAR(samples.back().channels[1], -0.5 * world::standard_gravity * 0.2 * 0.2, 0.01);
}

TEST(EngineGravity, TheFeedforwardSaturatesWithTheScenesForceByOneCommonFactor) {
  // The hand holds the device 5 mm inside a plane wall along x: F = (10, 0) N;
  // with m g = 2.94 N on y the sum (10, 2.94) is above a 2 N limit: both scaled
  // by 2 / 10, the direction of the sum kept.
  Rig rig(vertical_stage("mode=hold trajectory=constant position=-0.005", "mode=hold"),
          options_with(y_up(), std::nullopt));
  rig.engine.publish(
      plan_of("plane-wall", {{"normal", "1,0"}, {"stiffness", 2000.0}, {"damping", 0.0}}, 2.0));
  rig.run(5);
  rig.plant.simulator(0).set_hand("mode=hold trajectory=ramp from=-0.005 to=0.001 rate=1");
  rig.run(10);
  rig.plant.simulator(0).set_hand("mode=hold trajectory=ramp from=0.001 to=-0.005 rate=1");
  const auto samples = rig.run(10);
  const auto& s = samples.back();
  const double fx = s.channels[2], ox = s.channels[4], oy = s.channels[5];
  ASSERT_NEAR(fx, 2000.0 * 0.005, 1e-6);
  EXPECT_NEAR(ox, 2.0, 1e-12) << "x at its limit";
  EXPECT_NEAR(oy, weight * 2.0 / fx, 1e-9) << "the feedforward scaled by the same factor";
  EXPECT_NE(s.flags & hapticd::daemon::flag_torque_limited, 0U);
}

TEST(EngineGravity, EachJointItsOwnLimitWithOneCommonFactor) {
  // As above, with x's limit 20 N and y's 2 N ([device] axis_torque_limit):
  // the sum (10, 2.94) N passes x's limit and not y's, so both are scaled
  // by 2 / 2.94, the direction of the sum kept.
  Rig rig(vertical_stage("mode=hold trajectory=constant position=-0.005", "mode=hold"),
          options_with(y_up(), std::nullopt));
  auto plan = plan_of("plane-wall", {{"normal", "1,0"}, {"stiffness", 2000.0}, {"damping", 0.0}}, 30.0);
  plan->axis_torque_limits = world::AxisVector::Zero(2);
  plan->axis_torque_limits << 20.0, 2.0;
  rig.engine.publish(std::move(plan));
  rig.run(5);
  {
    // The per-joint limits on the RT path: a fixed-capacity copy, nothing allocated.
    hapticd::testing::AllocationGuard guard;
    for (int i = 0; i < 100; ++i) rig.engine.run_cycle(rig.schedule.wait_next());
    EXPECT_EQ(guard.count(), 0U);
  }
  rig.plant.simulator(0).set_hand("mode=hold trajectory=ramp from=-0.005 to=0.001 rate=1");
  rig.run(10);
  rig.plant.simulator(0).set_hand("mode=hold trajectory=ramp from=0.001 to=-0.005 rate=1");
  const auto samples = rig.run(10);
  const auto& s = samples.back();
  const double fx = s.channels[2], ox = s.channels[4], oy = s.channels[5];
  ASSERT_NEAR(fx, 2000.0 * 0.005, 1e-6);
  EXPECT_NEAR(oy, 2.0, 1e-12) << "y at its own limit";
  EXPECT_NEAR(ox, fx * 2.0 / weight, 1e-9) << "x scaled by y's factor: the direction kept";
  EXPECT_NE(s.flags & hapticd::daemon::flag_torque_limited, 0U);
}

TEST(EngineGravity, TheWorkspaceBoxHoldsTheDeviceInsideWhileTheHandPushesOut) {
  const double k = 2000.0, b = 20.0, push = 2.0, high = 0.01;
  auto workspace =
      task_scene("box", {{"low", "-0.01,-0.01"}, {"high", "0.01,0.01"}, {"stiffness", k}, {"damping", b}});
  Rig rig(vertical_stage("mode=force force=2", "mode=free"), options_with(y_up(), workspace));
  // A limit the impact stays below: a saturated wall would scale the
  // feedforward with it (one common factor), and y would sag meanwhile.
  rig.engine.publish(plan_of("free", {}, 30.0));
  const auto samples = rig.run(3000);
  double deepest = 0.0;
  for (const auto& s : samples) {
    ASSERT_EQ(s.channel_count, 9U) << "the axes' 6, gravity's 2, the workspace's penetration";
    deepest = std::max(deepest, s.channels[0] - high);
    if (s.channels[0] > high) {
      EXPECT_NEAR(s.channels[8], s.channels[0] - high, 1e-15);
    }
  }
  const auto& last = samples.back();
  // At rest against the face: the wall's K p balances the hand, p = F / K = 1 mm.
  EXPECT_NEAR(last.channels[0] - high, push / k, 1e-6);
  EXPECT_NEAR(last.channels[2], -push, 1e-3) << "the workspace's force in the task force";
  // The hand's work over the 1 cm approach, E = F d, goes into the wall:
  // K p^2 / 2 <= F p + E bounds the deepest point (the damping only lowers it).
  const double bound = push / k + std::sqrt(std::pow(push / k, 2) + 2 * push * 0.01 / k);
  EXPECT_LT(deepest, bound);
  EXPECT_GT(deepest, push / k) << "it did push into the wall";
  EXPECT_LE(std::abs(last.channels[1]), 1e-9) << "y held by the feedforward meanwhile";
}

/// The loopback pantograph of the default links in a vertical plane (y
/// up): its links and handle weigh `masses`; the handle at the workspace's
/// centre, no hand; 1e9 counts a revolution (6 nrad).
loopback::LoopbackStage weighted_pantograph(const world::PantographMasses& masses) {
  loopback::LoopbackStage stage;
  auto joint = loopback::LoopbackConfig::defaults(hapticd::drivers::Motion::rotary);
  joint.mass = 5e-4;
  joint.damping = 0.0;
  joint.counts = 1e9;
  stage.axes = {joint, joint};
  stage.hands.resize(2);
  loopback::LoopbackStage::Pantograph linkage;
  linkage.model.x_min = -0.02, linkage.model.x_max = 0.06, linkage.model.y_min = 0.07,
  linkage.model.y_max = 0.12;
  linkage.start = {0.02, 0.095};
  linkage.hand = simulation::parse_task_hand_script("mode=free", linkage.start);
  linkage.weight = masses;
  stage.pantograph = linkage;
  return stage;
}

const world::PantographMasses link_masses{0.02, 0.03, 0.03, 0.02, 0.01, world::standard_gravity};

EngineOptions pantograph_options(std::optional<world::GravityModel> gravity) {
  EngineOptions options = options_with(std::move(gravity), std::nullopt);
  options.position_rule.rotary = true;
  options.kinematics = world::PantographKinematics(world::PantographGeometry{});
  return options;
}

TEST(EngineGravity, TheFeedforwardHoldsThePantographsLinksStill) {
  Rig rig(weighted_pantograph(link_masses), pantograph_options(link_masses));
  rig.engine.publish(plan_of("free", {}, 1.0));
  const auto samples = rig.run(2000);
  ASSERT_EQ(samples.size(), 2000U);
  const world::PantographKinematics k(world::PantographGeometry{});
  double drift = 0.0;
  for (const auto& s : samples) {
    // position_q1, position_q2, force_x, force_y, output_q1, output_q2,
    // handle_x, handle_y, gravity_q1, gravity_q2
    ASSERT_EQ(s.channel_count, 10U);
    world::AxisVector q(2);
    q << s.channels[0], s.channels[1];
    world::TaskState state;
    k.solve(q, state);
    const world::AxisVector holding = world::pantograph_gravity_torques(k, link_masses, q, state);
    EXPECT_NEAR(s.channels[8], holding(0), 1e-15) << "dV/dq at the joints read";
    EXPECT_NEAR(s.channels[9], holding(1), 1e-15);
    EXPECT_EQ(s.channels[4], s.channels[8]) << "the feedforward sent as it is: below the limit";
    EXPECT_GT(std::abs(s.channels[8]) + std::abs(s.channels[9]), 1e-3) << "the links do weigh";
    drift = std::max(drift, std::hypot(s.channels[6] - 0.02, s.channels[7] - 0.095));
  }
  // The feedforward and the plant's weight are the same function of the
  // same joints but for one count (6 nrad): the handle stays within 1 um.
  EXPECT_LE(drift, 1e-6);
}

TEST(EngineGravity, WithoutTheFeedforwardThePantographsHandleFalls) {
  Rig rig(weighted_pantograph(link_masses), pantograph_options(std::nullopt));
  rig.engine.publish(plan_of("free", {}, 1.0));
  const auto samples = rig.run(50);
  ASSERT_EQ(samples.back().channel_count, 8U) << "no gravity channels without [gravity]";
  EXPECT_LT(samples.back().channels[7], 0.095 - 1e-3) << "the handle 1 mm lower or more after 50 ms";
}

TEST(EngineGravity, OneAxisRefusesAnotherDevicesGravityAndAWorkspace) {
  hapticd::drivers::Device device("loopback",
                                  std::make_unique<loopback::LoopbackDevice>(
                                      loopback::LoopbackConfig::defaults(hapticd::drivers::Motion::linear)));
  rt::VirtualClock clock;
  EXPECT_THROW(Engine(options_with(y_up(), std::nullopt), device, clock), std::invalid_argument)
      << "two holding forces for one axis";
  world::PantographMasses links{0.1, 0.1, 0.1, 0.1, 0.0, world::standard_gravity};
  EXPECT_THROW(Engine(options_with(links, std::nullopt), device, clock), std::invalid_argument);
  EXPECT_THROW(Engine(options_with(std::nullopt, task_scene("box", {})), device, clock),
               std::invalid_argument);
}

}  // namespace

}  // namespace engine_gravity_test
