// The safety rules of the RT cycle (DESIGN.md "Safety"), observed through
// run_cycle() + drain() over a VirtualClock and a loopback device:
// torque limit, NaN, device fault, read errors, overrun streak, estop,
// plan hand-over at the boundary with a reset at the measured position.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "daemon/engine/engine.hpp"
#include "drivers/device.hpp"
#include "drivers/loopback/loopback_device.hpp"
#include "rt/clock.hpp"
#include "rt/loop_timing.hpp"
#include "tests/support/loopback_start.hpp"
#include "world/scene_catalog.hpp"

namespace engine_safety_test {

namespace {

using hapticd::daemon::TelemetrySample;
using hapticd::daemon::engine::Engine;
using hapticd::daemon::engine::EngineOptions;
using hapticd::daemon::engine::FaultReason;
using hapticd::daemon::engine::LoopPlan;
namespace loopback = hapticd::drivers::loopback;
namespace world = hapticd::world;
namespace rt = hapticd::rt;
using namespace std::chrono_literals;

constexpr double period_s = 1e-3;
constexpr rt::Nanos period{1'000'000};

loopback::LoopbackConfig rotary_config() {
  auto config = loopback::LoopbackConfig::defaults(hapticd::drivers::Motion::rotary);
  config.damping = 0.002;
  return config;
}

EngineOptions quiet_options() {
  EngineOptions options;
  options.realtime.priority = 0;
  options.realtime.lock_memory = false;
  options.realtime.hold_dma_latency = false;
  options.telemetry_capacity = 1u << 12;
  return options;
}

std::unique_ptr<LoopPlan> make_plan(const std::string& scene, const world::ParameterSet& parameters,
                                    double torque_limit) {
  auto outcome = world::plan_scene(scene, parameters, period_s, world::Motion::rotary);
  if (const auto* error = std::get_if<world::SceneError>(&outcome)) {
    ADD_FAILURE() << scene << ": " << error->message;
    return nullptr;
  }
  auto plan = std::make_unique<LoopPlan>();
  plan->scene = std::get<world::ScenePlan>(outcome).scene_object;
  plan->torque_limit = torque_limit;
  return plan;
}

/// Default spring-wheel (k = 1.02 N m/rad, 1 Hz, exact integrator, b = 0).
std::unique_ptr<LoopPlan> wheel(double torque_limit = 0.8) {
  return make_plan("spring-wheel", {}, torque_limit);
}

class EngineSafety : public ::testing::Test {
 protected:
  void SetUp() override { options = quiet_options(); }
  /// Builds the engine with the current options; the device optionally displaced first.
  void build(std::optional<double> initial_position = std::nullopt) {
    if (initial_position) plant.set_initial_state(*initial_position, 0.0);
    engine = std::make_unique<Engine>(options, device, clock);
    hapticd::testing::start(device);
    schedule.start();
  }
  void TearDown() override {
    engine.reset();
    device.disable();
  }
  /// Runs one cycle and returns its telemetry sample.
  TelemetrySample cycle() {
    engine->run_cycle(schedule.wait_next());
    TelemetrySample s;
    const std::size_t n = engine->drain(std::span<TelemetrySample>(&s, 1));
    EXPECT_EQ(n, 1u);
    return s;
  }
  std::vector<TelemetrySample> cycles(int n) {
    std::vector<TelemetrySample> out;
    for (int i = 0; i < n; ++i) out.push_back(cycle());
    return out;
  }
  static bool has(const TelemetrySample& s, std::uint32_t flag) { return (s.flags & flag) != 0; }

  EngineOptions options;
  rt::VirtualClock clock;
  hapticd::testing::LoopbackRig device_rig{rotary_config()};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  std::unique_ptr<Engine> engine;
  rt::PeriodicSchedule schedule{clock, period};
};

using hapticd::daemon::flag_fault_latched;
using hapticd::daemon::flag_overrun;
using hapticd::daemon::flag_read_error;
using hapticd::daemon::flag_torque_limited;

}  // namespace

TEST_F(EngineSafety, NoPlanMeansZeroOutput) {
  build(0.2);
  plant.set_hand("mode=hold trajectory=sine amplitude=0.3 frequency=5");
  for (const auto& s : cycles(50)) {
    EXPECT_EQ(s.applied, 0.0);
    EXPECT_EQ(s.command, 0.0);
  }
}

TEST_F(EngineSafety, TorqueLimitClipsBothSigns) {
  build();
  // Relay of 1 N m with the device at 0: reference -0.1 gives -1, +0.1 gives +1.
  engine->publish(make_plan("relay", {{"amplitude", 1.0}, {"reference", -0.1}}, 0.25));
  plant.set_hand("mode=hold trajectory=constant position=0");
  for (const auto& s : cycles(20)) {
    EXPECT_DOUBLE_EQ(s.command, -1.0);
    EXPECT_EQ(s.applied, -0.25);
    EXPECT_TRUE(has(s, flag_torque_limited));
  }
  engine->publish(make_plan("relay", {{"amplitude", 1.0}, {"reference", 0.1}}, 0.25));
  for (const auto& s : cycles(20)) {
    EXPECT_DOUBLE_EQ(s.command, 1.0);
    EXPECT_EQ(s.applied, 0.25);
    EXPECT_TRUE(has(s, flag_torque_limited));
  }
  EXPECT_EQ(engine->counters().torque_limited, 40u);
  // Within the limit: no flag, applied == command.
  engine->publish(make_plan("relay", {{"amplitude", 0.2}, {"reference", 0.1}}, 0.25));
  for (const auto& s : cycles(20)) {
    EXPECT_EQ(s.applied, 0.2);
    EXPECT_FALSE(has(s, flag_torque_limited));
  }
  EXPECT_EQ(engine->fault(), FaultReason::none);
}

TEST_F(EngineSafety, TorqueLimitHoldsForAnOscillatingSpring) {
  build();
  plant.set_hand("mode=hold trajectory=step position=0 amplitude=0.5 at=0.01");
  engine->publish(wheel(0.1));
  std::size_t limited = 0;
  for (const auto& s : cycles(2000)) {
    EXPECT_LE(std::abs(s.applied), 0.1);
    if (std::abs(s.command) > 0.1) {
      ++limited;
      EXPECT_TRUE(has(s, flag_torque_limited));
      EXPECT_EQ(s.applied, std::copysign(0.1, s.command));
    } else {
      EXPECT_FALSE(has(s, flag_torque_limited));
      EXPECT_EQ(s.applied, s.command);
    }
  }
  EXPECT_GT(limited, 100u);  // k * 0.5 rad = 0.5 N m of stretch at the step
}

TEST_F(EngineSafety, NanPositionZeroesThatCycleAndLatchesUntilCleared) {
  build();
  plant.set_hand("mode=hold trajectory=step position=0 amplitude=0.3 at=0.005");
  engine->publish(wheel());
  const auto before = cycles(100);
  EXPECT_GT(std::abs(before.back().applied), 0.01);  // the wheel swings against the held device

  plant.inject_fault(loopback::Fault::nan, 1);
  const TelemetrySample nan_cycle = cycle();
  EXPECT_EQ(nan_cycle.applied, 0.0);
  EXPECT_TRUE(has(nan_cycle, flag_fault_latched));
  EXPECT_EQ(engine->fault(), FaultReason::non_finite_position);
  EXPECT_EQ(plant.snapshot().commanded_force, 0.0);

  // The position is finite again, but the latch holds the output at zero.
  for (const auto& s : cycles(200)) {
    EXPECT_EQ(s.applied, 0.0);
    EXPECT_TRUE(has(s, flag_fault_latched));
  }
  EXPECT_EQ(engine->fault(), FaultReason::non_finite_position);

  engine->clear_fault();
  // Restart at equilibrium: the device is held still, so the wheel starts
  // relaxed at the measured position and no torque step appears.
  const auto after = cycles(100);
  EXPECT_FALSE(has(after.front(), flag_fault_latched));
  for (const auto& s : after) EXPECT_NEAR(s.applied, 0.0, 1e-12);
  EXPECT_EQ(engine->fault(), FaultReason::none);
  EXPECT_EQ(engine->counters().faults_latched, 1u);
}

TEST_F(EngineSafety, ClearRestartsAtTheMeasuredPositionEvenIfTheDeviceMovedDuringTheLatch) {
  build();
  plant.set_hand("mode=hold trajectory=constant position=0");
  engine->publish(wheel());
  cycles(10);
  engine->estop();
  EXPECT_EQ(cycle().applied, 0.0);
  // The hand moves the device while the output is held at zero.
  plant.set_hand("mode=hold trajectory=ramp from=0 to=0.4 rate=2 at=0");
  cycles(300);  // ends at 0.4 rad, still
  engine->clear_fault();
  for (const auto& s : cycles(50)) EXPECT_NEAR(s.applied, 0.0, 1e-12);
}

/// The loopback, except that its read() lets the control thread's
/// fault.clear land once, mid-cycle: after the engine's top-of-cycle latch
/// check and before the command (what a real device's slow read() allows).
class ClearingMidCycle final : public hapticd::drivers::DeviceHooks {
 public:
  explicit ClearingMidCycle(loopback::LoopbackDevice& inner) : inner_(inner) {}
  void configure(const hapticd::drivers::LoopContext& loop) override { inner_.configure(loop); }
  void enable() override { inner_.enable(); }
  std::string clear_fault() override { return inner_.clear_fault(); }
  void disable() noexcept override { inner_.disable(); }
  void close() noexcept override { inner_.close(); }
  hapticd::drivers::IoResult read(hapticd::drivers::Reading& out) noexcept override {
    const auto result = inner_.read(out);
    if (engine != nullptr && clear_next_read) {
      engine->clear_fault();
      clear_next_read = false;
    }
    return result;
  }
  hapticd::drivers::IoResult write(double force) noexcept override { return inner_.write(force); }
  hapticd::drivers::DeviceModel model() const override { return inner_.model(); }
  hapticd::drivers::DeviceHealth health() const override { return inner_.health(); }
  Engine* engine = nullptr;
  bool clear_next_read = false;

 private:
  loopback::LoopbackDevice& inner_;
};

// Regression (found by the usb-hid end-to-end test, about 1 run in 9): a
// clear landing between the cycle's first latch check and the command
// computed a command from the stale scene state, without the reset at the
// measured position: a torque step of 0.18 N m at the resume.
TEST_F(EngineSafety, ClearLandingMidCycleTakesEffectNextCycleWithTheReset) {
  hapticd::drivers::Device clearing_device("clearing", std::make_unique<ClearingMidCycle>(plant));
  auto& clearing = clearing_device.hooks_as<ClearingMidCycle>();
  engine = std::make_unique<Engine>(options, clearing_device, clock);
  clearing.engine = engine.get();
  clearing_device.configure({plant.config().period_s});
  clearing_device.enable();
  schedule.start();
  plant.set_hand("mode=hold trajectory=constant position=0");
  engine->publish(wheel());
  cycles(10);
  engine->estop();
  cycle();
  plant.set_hand("mode=hold trajectory=ramp from=0 to=0.4 rate=2 at=0");
  cycles(300);  // the device moved 0.4 rad while the output was held at zero
  clearing.clear_next_read = true;
  const TelemetrySample during = cycle();
  EXPECT_EQ(during.applied, 0.0) << "the cycle that saw the clear mid-way stays at zero";
  EXPECT_EQ(engine->fault(), FaultReason::none);
  for (const auto& s : cycles(20)) EXPECT_NEAR(s.applied, 0.0, 1e-12) << "relaxed restart, no step";
}

TEST_F(EngineSafety, DeviceFaultZeroesAndLatches) {
  build();
  plant.set_hand("mode=hold trajectory=step position=0 amplitude=0.3 at=0.005");
  engine->publish(wheel());
  cycles(100);
  plant.inject_fault(loopback::Fault::fault);  // until cleared
  const TelemetrySample s = cycle();
  EXPECT_EQ(s.applied, 0.0);
  EXPECT_TRUE(has(s, flag_fault_latched));
  EXPECT_EQ(engine->fault(), FaultReason::device_fault);
  plant.clear_faults();
  for (const auto& t : cycles(20)) EXPECT_EQ(t.applied, 0.0);
  EXPECT_EQ(engine->fault(), FaultReason::device_fault);
  engine->clear_fault();
  for (const auto& t : cycles(20)) EXPECT_NEAR(t.applied, 0.0, 1e-12);  // relaxed restart
  EXPECT_EQ(engine->fault(), FaultReason::none);
}

TEST_F(EngineSafety, ReadErrorsZeroTheCycleAndLatchAtTheLimit) {
  options.read_error_limit = 3;
  build();
  plant.set_hand("mode=hold trajectory=sine amplitude=0.3 frequency=2");
  engine->publish(wheel());
  cycles(100);
  // Two consecutive errors: zero output in those cycles, no latch.
  plant.inject_fault(loopback::Fault::read_error, 2);
  for (const auto& s : cycles(2)) {
    EXPECT_TRUE(has(s, flag_read_error));
    EXPECT_EQ(s.applied, 0.0);
    EXPECT_FALSE(has(s, flag_fault_latched));
  }
  const TelemetrySample recovered = cycle();
  EXPECT_FALSE(has(recovered, flag_read_error));
  EXPECT_NE(recovered.applied, 0.0);
  EXPECT_EQ(engine->fault(), FaultReason::none);
  // Three consecutive: the third latches.
  plant.inject_fault(loopback::Fault::read_error, 3);
  const auto errors = cycles(3);
  EXPECT_FALSE(has(errors[1], flag_fault_latched));
  EXPECT_TRUE(has(errors[2], flag_fault_latched));
  for (const auto& s : errors) EXPECT_EQ(s.applied, 0.0);
  EXPECT_EQ(engine->fault(), FaultReason::read_error_streak);
  for (const auto& s : cycles(20)) EXPECT_EQ(s.applied, 0.0);
  EXPECT_EQ(engine->counters().read_errors, 5u);
}

TEST_F(EngineSafety, OverrunStreakLatchesAndZeroesInTheSameCycle) {
  options.overrun_limit = 3;
  build();
  plant.set_hand("mode=hold trajectory=step position=0 amplitude=0.3 at=0.005");
  engine->publish(wheel());
  cycles(100);
  // Two late cycles, then an on-time one: the streak restarts.
  for (int i = 0; i < 2; ++i) {
    clock.stall_next_sleep(rt::Nanos{2'500'000});
    const TelemetrySample s = cycle();
    EXPECT_TRUE(has(s, flag_overrun));
    EXPECT_NE(s.applied, 0.0);
  }
  EXPECT_FALSE(has(cycle(), flag_overrun));
  EXPECT_EQ(engine->fault(), FaultReason::none);
  // Three in a row: the third latches, and its output is already zero.
  std::vector<TelemetrySample> late;
  for (int i = 0; i < 3; ++i) {
    clock.stall_next_sleep(rt::Nanos{2'500'000});
    late.push_back(cycle());
  }
  EXPECT_NE(late[1].applied, 0.0);
  EXPECT_FALSE(has(late[1], flag_fault_latched));
  EXPECT_TRUE(has(late[2], flag_fault_latched));
  EXPECT_EQ(late[2].applied, 0.0);
  EXPECT_EQ(plant.snapshot().commanded_force, 0.0);
  EXPECT_EQ(engine->fault(), FaultReason::overrun_streak);
  for (const auto& s : cycles(10)) EXPECT_EQ(s.applied, 0.0);
  EXPECT_EQ(engine->stats().max_overrun_streak, 3u);
}

TEST_F(EngineSafety, EstopZeroesTheNextCycle) {
  build();
  plant.set_hand("mode=hold trajectory=step position=0 amplitude=0.3 at=0.005");
  engine->publish(wheel());
  EXPECT_NE(cycles(100).back().applied, 0.0);
  engine->estop();
  const TelemetrySample s = cycle();
  EXPECT_EQ(s.applied, 0.0);
  EXPECT_TRUE(has(s, flag_fault_latched));
  EXPECT_EQ(engine->fault(), FaultReason::estop);
  EXPECT_EQ(plant.snapshot().commanded_force, 0.0);
}

TEST_F(EngineSafety, FirstPlanOnADisplacedDeviceStartsRelaxed) {
  // The device rests at 0.3 rad before the loop starts; the plan is installed
  // in the very first cycle. A reset at a stale position (0) would command
  // k * 0.3 = 0.3 N m at once.
  build(0.3);
  plant.set_hand("mode=hold trajectory=constant position=0.3");
  engine->publish(wheel());
  const TelemetrySample first = cycle();
  EXPECT_NEAR(first.position, 0.3, 1e-3);
  EXPECT_EQ(first.command, 0.0);
  for (const auto& s : cycles(100)) EXPECT_NEAR(s.applied, 0.0, 1e-12);
}

TEST_F(EngineSafety, FirstWallOnADisplacedDeviceDoesNotPush) {
  // Device already inside the wall when it is loaded: no K * depth step.
  build(0.3);
  plant.set_hand("mode=hold trajectory=constant position=0.3");
  engine->publish(make_plan("wall", {{"stiffness", 100.0}, {"damping", 0.0}, {"position", 0.0}}, 0.8));
  for (const auto& s : cycles(50)) EXPECT_EQ(s.applied, 0.0);
}

TEST_F(EngineSafety, NewPlanTakesEffectAtTheBoundaryResetAtTheMeasuredPosition) {
  build();
  // The hand moves the device the whole time, so the position of the
  // previous cycle is not the position of the switching cycle.
  plant.set_hand("mode=hold trajectory=sine amplitude=0.4 frequency=2");
  engine->publish(make_plan("free", {}, 0.8));
  const auto free_run = cycles(500);
  for (const auto& s : free_run) EXPECT_EQ(s.applied, 0.0);
  ASSERT_GT(std::abs(free_run.back().position - free_run[free_run.size() - 2].position), 1e-3);

  const auto publication = engine->publish(wheel());
  EXPECT_FALSE(engine->wait_applied(publication.seq, 0ms).has_value());  // not before the boundary
  const TelemetrySample first = cycle();
  const auto applied_at = engine->wait_applied(publication.seq, 0ms);
  ASSERT_TRUE(applied_at.has_value());
  EXPECT_EQ(*applied_at, first.cycle);
  EXPECT_EQ(first.channel_count, 2u);  // the wheel's channels, from this very cycle
  EXPECT_EQ(first.command, 0.0);       // relaxed at the measured position
  // From then on the wheel reacts to the moving device.
  const auto wheel_run = cycles(100);
  EXPECT_NE(wheel_run.back().applied, 0.0);

  // Switch again, this time while the wheel is stretched: again no step.
  engine->publish(wheel());
  EXPECT_EQ(cycle().command, 0.0);
}

TEST_F(EngineSafety, LatestPublicationWinsAtTheBoundary) {
  build();
  plant.set_hand("mode=hold trajectory=constant position=0");
  const auto first = engine->publish(make_plan("relay", {{"amplitude", 0.1}, {"reference", -1.0}}, 0.8));
  const auto second = engine->publish(make_plan("relay", {{"amplitude", 0.2}, {"reference", -1.0}}, 0.8));
  EXPECT_EQ(second.superseded_seq, first.seq);
  const TelemetrySample s = cycle();
  EXPECT_DOUBLE_EQ(s.applied, -0.2);
  EXPECT_EQ(engine->wait_applied(second.seq, 0ms), std::optional<std::uint64_t>(s.cycle));
  EXPECT_FALSE(engine->wait_applied(first.seq, 0ms).has_value());  // never in effect
}

TEST(EngineThread, PublishThenWaitAppliedReturnsTheCycle) {
  rt::RealClock clock;
  hapticd::testing::LoopbackRig device_rig{rotary_config()};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  plant.set_hand("mode=hold trajectory=constant position=0");
  hapticd::testing::start(device);
  Engine engine(quiet_options(), device, clock);
  const auto& report = engine.start();
  ASSERT_FALSE(report.fatal) << report.message();
  std::vector<TelemetrySample> buffer(4096);
  std::vector<TelemetrySample> seen;
  for (int round = 0; round < 5; ++round) {
    const double amplitude = 0.05 * (round + 1);
    const auto publication =
        engine.publish(make_plan("relay", {{"amplitude", amplitude}, {"reference", -1.0}}, 0.8));
    const auto cycle = engine.wait_applied(publication.seq, 5s);
    ASSERT_TRUE(cycle.has_value());
    EXPECT_GE(*cycle, 1u);
    EXPECT_LE(*cycle, engine.cycle());
    // Wait until the engine is a few cycles past, then check the telemetry:
    // samples before the cycle have the old amplitude, from it on the new one.
    while (engine.cycle() < *cycle + 3) std::this_thread::sleep_for(1ms);
    for (;;) {
      const std::size_t n = engine.drain(buffer);
      seen.insert(seen.end(), buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n));
      if (n == 0) break;
    }
    bool found = false;
    for (const auto& s : seen) {
      if (s.cycle < *cycle) {
        EXPECT_NE(s.applied, -amplitude) << "cycle " << s.cycle;
      } else {
        EXPECT_DOUBLE_EQ(s.applied, -amplitude) << "cycle " << s.cycle;
      }
      if (s.cycle == *cycle) found = true;
    }
    EXPECT_TRUE(found);
    seen.clear();
  }
  engine.stop();
  EXPECT_TRUE(engine.finished());
  device.disable();
}

}  // namespace engine_safety_test
