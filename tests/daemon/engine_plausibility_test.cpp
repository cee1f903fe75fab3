// The position-plausibility rule of the RT cycle (issue 17, item 1): a
// reading that steps more than max_velocity x interval + one count from the
// previous one is an encoder or link fault, not motion. Observed through
// run_cycle() + drain() over a VirtualClock and a scripted device whose
// read() returns exactly the positions the test gives it.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "daemon/engine/engine.hpp"
#include "rt/clock.hpp"
#include "rt/loop_timing.hpp"
#include "world/scene_catalog.hpp"

namespace engine_plausibility_test {

namespace {

using hapticd::daemon::flag_fault_latched;
using hapticd::daemon::flag_position_jump;
using hapticd::daemon::flag_read_error;
using hapticd::daemon::flag_stale_position;
using hapticd::daemon::TelemetrySample;
using hapticd::daemon::engine::default_max_velocity;
using hapticd::daemon::engine::Engine;
using hapticd::daemon::engine::EngineOptions;
using hapticd::daemon::engine::FaultReason;
using hapticd::daemon::engine::LoopPlan;
using hapticd::daemon::engine::PositionJump;
using hapticd::daemon::engine::PositionStepGuard;
using hapticd::daemon::engine::PositionStepRule;
namespace drivers = hapticd::drivers;
namespace world = hapticd::world;
namespace rt = hapticd::rt;

constexpr double period_s = 1e-3;
constexpr double counts_per_turn = 16384.0;
constexpr double resolution = 2.0 * std::numbers::pi / counts_per_turn;  // rad per count
constexpr double max_velocity = 50.0;                                    // rad/s
constexpr double step_limit = max_velocity * period_s + resolution;      // rad per period
constexpr double two_to_31 = 2147483648.0;
constexpr double torque_limit = 0.8;

/// A device whose read() returns `position` (or an error when `error_next`
/// is set, once) and whose write() records the force: the engine sees
/// exactly the readings the test scripts.
/// A test component (ros2_control's): read, write and the model, nothing
/// else; the framework's Device holds its lifecycle.
class ScriptedDevice final : public drivers::DeviceHooks {
 public:
  drivers::IoResult read(drivers::Reading& out) noexcept override {
    if (error_next) {
      error_next = false;
      return drivers::IoResult::error;
    }
    out.position = position;
    out.stale = stale;
    return drivers::IoResult::ok;
  }
  drivers::IoResult write(double force) noexcept override {
    written.push_back(force);
    return drivers::IoResult::ok;
  }
  drivers::DeviceModel model() const override { return {}; }

  double position = 0.0;
  bool error_next = false;
  bool stale = false;  ///< read() says its position is the last one (a late TPDO)
  std::vector<double> written;
};

PositionStepRule wheel_rule() {
  PositionStepRule rule;
  rule.max_velocity = max_velocity;
  rule.resolution = resolution;
  rule.period_s = period_s;
  rule.rotary = true;
  return rule;
}

std::unique_ptr<LoopPlan> wheel() {
  // Freudenberg's 1 Hz virtual wheel: turning the device at 2 rad/s asks for
  // about k v / w_n = 0.3 N m, a jump of 2^31 counts for 10^6 N m.
  auto outcome = world::plan_scene("spring-wheel", {}, period_s, world::Motion::rotary);
  if (const auto* error = std::get_if<world::SceneError>(&outcome)) {
    ADD_FAILURE() << error->message;
    return nullptr;
  }
  auto plan = std::make_unique<LoopPlan>();
  plan->scene = std::get<world::ScenePlan>(outcome).scene_object;
  plan->torque_limit = torque_limit;
  return plan;
}

class EnginePlausibility : public ::testing::Test {
 protected:
  void build(PositionStepRule rule = wheel_rule()) {
    EngineOptions options;
    options.realtime.priority = 0;
    options.realtime.lock_memory = false;
    options.realtime.hold_dma_latency = false;
    options.telemetry_capacity = 1u << 12;
    options.position_rule = rule;
    engine = std::make_unique<Engine>(options, framework, clock);
    if (framework.status().state == drivers::DeviceState::closed) framework.configure({period_s});
    framework.enable();
    schedule.start();
    engine->publish(wheel());
  }
  TelemetrySample cycle() {
    engine->run_cycle(schedule.wait_next());
    TelemetrySample s;
    EXPECT_EQ(engine->drain(std::span<TelemetrySample>(&s, 1)), 1u);
    return s;
  }
  /// The hand turns the wheel at `velocity` rad/s for n periods (torque flows).
  std::vector<TelemetrySample> turn(double velocity, int n) {
    std::vector<TelemetrySample> out;
    for (int i = 0; i < n; ++i) {
      device.position += velocity * period_s;
      out.push_back(cycle());
    }
    return out;
  }
  static bool has(const TelemetrySample& s, std::uint32_t flag) { return (s.flags & flag) != 0; }

  rt::VirtualClock clock;
  drivers::Device framework{"scripted", std::make_unique<ScriptedDevice>()};
  ScriptedDevice& device = framework.hooks_as<ScriptedDevice>();
  std::unique_ptr<Engine> engine;
  rt::PeriodicSchedule schedule{clock, rt::Nanos{1'000'000}};
};

}  // namespace

// The attack: a TPDO or register pair whose position jumps by 2^31
// counts once. Before the rule the jump was rendered as motion: torque sat
// at torque_limit until stop, no fault, no flag.
TEST_F(EnginePlausibility, AJumpOf2To31CountsZeroesThatPeriodAndLatchesWithTheFigures) {
  build();
  const auto before = turn(2.0, 200);
  ASSERT_GT(std::abs(before.back().applied), 0.01) << "torque must flow before the jump";
  ASSERT_EQ(engine->fault(), FaultReason::none);

  device.position += two_to_31 * resolution;  // 823,550 rad
  const TelemetrySample jump = cycle();
  EXPECT_EQ(jump.applied, 0.0) << "zero output in the very period of the jump";
  EXPECT_EQ(device.written.back(), 0.0);
  EXPECT_TRUE(has(jump, flag_fault_latched)) << "the recording shows the fault on that sample";
  EXPECT_TRUE(has(jump, flag_position_jump));
  EXPECT_EQ(jump.position, device.position) << "the recording keeps what the device said";
  EXPECT_EQ(engine->fault(), FaultReason::encoder_jump);
  EXPECT_EQ(engine->counters().position_jumps, 1u);

  const auto figures = engine->position_jump();
  ASSERT_TRUE(figures.has_value());
  EXPECT_NEAR(figures->step, two_to_31 * resolution, 1e-6);
  EXPECT_NEAR(figures->limit, step_limit, 1e-12);
  EXPECT_NEAR(figures->interval_s, period_s, 1e-12);
  const std::string text = engine->fault_description();
  EXPECT_NE(text.find("encoder jump / velocity limit"), std::string::npos) << text;
  EXPECT_NE(text.find("+2147483648 counts"), std::string::npos) << text;
  EXPECT_NE(text.find("max_velocity 50 rad/s x 1 ms + 1 count"), std::string::npos) << text;

  // Held at zero while latched, never at the torque limit; the position
  // stays offset (a counter that lost counts) and is not refused again.
  for (const auto& s : turn(2.0, 300)) {
    EXPECT_EQ(s.applied, 0.0);
    EXPECT_TRUE(has(s, flag_fault_latched));
    EXPECT_FALSE(has(s, flag_position_jump));
  }
  EXPECT_EQ(engine->counters().position_jumps, 1u);

  // fault clear: the scene restarts at equilibrium at the new position (no
  // torque step) and torque flows again as the hand turns.
  engine->clear_fault();
  const auto after = turn(2.0, 200);
  EXPECT_EQ(engine->fault(), FaultReason::none);
  EXPECT_LT(std::abs(after.front().applied), 0.01) << "no torque step at the clear";
  EXPECT_GT(std::abs(after.back().applied), 0.01) << "the output resumes";
  for (const auto& s : after) EXPECT_LT(std::abs(s.applied), torque_limit) << "cycle " << s.cycle;
  EXPECT_FALSE(engine->position_jump().has_value()) << "no figures once cleared";
  EXPECT_EQ(engine->fault_description(), "");
}

// A late CiA 402 TPDO: the driver keeps the last position and says so. The
// period is rendered (no fault, torque flows) and the recording flags it, so
// a run can tell a stale position from a device at rest.
TEST_F(EnginePlausibility, AStalePositionIsRenderedAndFlagged) {
  build();
  for (const auto& s : turn(2.0, 200)) EXPECT_FALSE(has(s, flag_stale_position)) << "cycle " << s.cycle;
  device.stale = true;
  const TelemetrySample stale = cycle();  // the position has not moved
  EXPECT_TRUE(has(stale, flag_stale_position));
  EXPECT_FALSE(has(stale, flag_fault_latched));
  EXPECT_FALSE(has(stale, flag_read_error));
  EXPECT_GT(std::abs(stale.applied), 0.01) << "rendered: the wheel still holds the hand";
  EXPECT_EQ(stale.position, device.position);
  device.stale = false;
  const auto after = turn(2.0, 2);
  EXPECT_FALSE(has(after[0], flag_stale_position));
  EXPECT_EQ(engine->fault(), FaultReason::none);
}

TEST_F(EnginePlausibility, AStepAtTheLimitIsMotionAndOneCountMoreIsNot) {
  build();
  turn(1.0, 50);
  device.position += step_limit * (1.0 - 1e-9);
  EXPECT_FALSE(has(cycle(), flag_position_jump));
  EXPECT_EQ(engine->fault(), FaultReason::none) << "max_velocity x period + one count is motion";
  device.position -= step_limit * (1.0 - 1e-9);  // back at the same speed: motion too
  EXPECT_EQ(engine->fault(), FaultReason::none);
  cycle();
  EXPECT_EQ(engine->fault(), FaultReason::none);
  device.position += step_limit + resolution;
  const TelemetrySample s = cycle();
  EXPECT_TRUE(has(s, flag_position_jump));
  EXPECT_EQ(s.applied, 0.0);
  EXPECT_EQ(engine->fault(), FaultReason::encoder_jump);
}

TEST_F(EnginePlausibility, ANegativeJumpIsRefusedToo) {
  build();
  turn(-3.0, 100);
  device.position -= 1000.0 * resolution;  // 1000 counts back in one period: 383 rad/s
  const TelemetrySample s = cycle();
  EXPECT_EQ(s.applied, 0.0);
  EXPECT_EQ(engine->fault(), FaultReason::encoder_jump);
  ASSERT_TRUE(engine->position_jump().has_value());
  EXPECT_LT(engine->position_jump()->step, 0.0);
  EXPECT_NE(engine->fault_description().find("-1000 counts"), std::string::npos)
      << engine->fault_description();
}

TEST_F(EnginePlausibility, TheFirstReadingHasNoReferenceAndIsNotChecked) {
  device.position = 1e5;  // wherever the encoder's count happens to be at start
  build();
  for (int i = 0; i < 20; ++i) EXPECT_FALSE(has(cycle(), flag_position_jump));
  EXPECT_EQ(engine->fault(), FaultReason::none);
}

TEST_F(EnginePlausibility, TheIntervalSinceTheLastValidReadingCountsAfterAReadError) {
  build();
  turn(1.0, 50);
  device.error_next = true;
  EXPECT_TRUE(has(cycle(), flag_read_error));
  // Two periods since the last valid reading: 1.5 periods' worth of the
  // fastest motion is motion, not a jump.
  device.position += 1.5 * max_velocity * period_s;
  cycle();
  EXPECT_EQ(engine->fault(), FaultReason::none);
}

TEST_F(EnginePlausibility, ALateWakeUpWidensTheLimitByTheTimeThatPassed) {
  build();
  turn(1.0, 50);
  clock.stall_next_sleep(rt::Nanos{2'000'000});  // this reading comes 3 ms after the last one
  device.position += 2.5 * max_velocity * period_s;
  cycle();
  EXPECT_EQ(engine->fault(), FaultReason::none);
}

// At a clear the device's own fault clear may move the reading (the
// loopback's encoder-jump offset ends with it): the scene restarts at
// equilibrium at the first reading after the clear, so that reading is the
// new reference, unchecked, and no fault latches again.
TEST_F(EnginePlausibility, TheFirstReadingAfterAClearIsTheNewReference) {
  build();
  turn(1.0, 50);
  device.position += 5000.0 * resolution;
  cycle();
  ASSERT_EQ(engine->fault(), FaultReason::encoder_jump);
  turn(0.0, 10);
  engine->clear_fault();
  device.position -= 5000.0 * resolution;  // the device's clear took the offset back
  const auto after = turn(1.0, 100);
  EXPECT_EQ(engine->fault(), FaultReason::none);
  EXPECT_LT(std::abs(after.front().applied), 0.01) << "no torque step at the clear";
  for (const auto& s : after) EXPECT_FALSE(has(s, flag_position_jump));
}

TEST_F(EnginePlausibility, AnEstopLatchedFirstKeepsItsReasonAndNoJumpFigures) {
  build();
  turn(1.0, 50);
  engine->estop();
  device.position += 5000.0 * resolution;
  const TelemetrySample s = cycle();
  EXPECT_TRUE(has(s, flag_position_jump)) << "the sample says what the reading was";
  EXPECT_EQ(engine->fault(), FaultReason::estop) << "the first reason latched wins";
  EXPECT_FALSE(engine->position_jump().has_value());
  EXPECT_EQ(engine->fault_description(), "estop");
}

TEST_F(EnginePlausibility, NoRuleNoCheck) {
  build(PositionStepRule{});  // max_velocity 0: what an engine built without a rule does
  turn(1.0, 50);
  device.position += 5000.0 * resolution;
  cycle();
  EXPECT_EQ(engine->fault(), FaultReason::none);
}

TEST(PositionStepGuard, ALimitWithoutResolutionIsTheVelocityTimesTheInterval) {
  PositionStepRule rule;
  rule.max_velocity = 5.0;  // m/s
  rule.period_s = 1e-3;
  rule.rotary = false;
  PositionStepGuard guard(rule);
  PositionJump jump;
  EXPECT_FALSE(guard.implausible(0.0, 0.0, jump));
  EXPECT_FALSE(guard.implausible(0.005, 0.001, jump));
  EXPECT_TRUE(guard.implausible(0.0101, 0.002, jump));
  EXPECT_DOUBLE_EQ(jump.limit, 0.005);
  EXPECT_NEAR(jump.step, 0.0051, 1e-15);
  // A step too large to subtract is a jump, not a NaN comparison that passes.
  EXPECT_TRUE(guard.implausible(1e308, 0.003, jump));
  EXPECT_TRUE(guard.implausible(-1e308, 0.004, jump));
  EXPECT_TRUE(std::isinf(jump.step));
  guard.forget();
  EXPECT_FALSE(guard.implausible(42.0, 0.005, jump)) << "no reference after forget()";
}

TEST(PositionStepGuard, TheDefaultMaxVelocityIsTheHandPlusTheMotorOverOneTurnOrADeskWorkspace) {
  // docs/config.md works these out for the shipped devices.
  EXPECT_NEAR(default_max_velocity(true, 0.01, 1.0), 50.0 + std::sqrt(2.0 * 2.0 * std::numbers::pi / 0.01),
              1e-12);
  EXPECT_NEAR(default_max_velocity(true, 0.01, 1.0), 85.45, 0.01);    // the loopback wheel
  EXPECT_NEAR(default_max_velocity(true, 0.0258, 0.8), 69.74, 0.01);  // config/canopen.toml
  EXPECT_NEAR(default_max_velocity(false, 0.1, 2.0), 7.0, 1e-12);     // 0.1 kg linear, 2 N
  EXPECT_EQ(default_max_velocity(false, 0.0, 2.0), 5.0) << "no mass: the hand's bound alone";
  EXPECT_EQ(default_max_velocity(true, NAN, 2.0), 50.0);
  // A lighter device is flung faster by the same motor.
  EXPECT_GT(default_max_velocity(true, 0.001, 1.0), default_max_velocity(true, 0.01, 1.0));
}

}  // namespace engine_plausibility_test
