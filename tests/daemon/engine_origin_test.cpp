// The origin in the RT cycle (issue 23, item 4: calibration): device.zero
// makes the position read in the next cycle the origin, subtracted from
// every reading from then on; the scene restarts at equilibrium there (no
// torque step); the position-step rule keeps checking the device's own
// readings, so a new origin is no encoder jump; [device] require_calibration
// holds the output at zero until an origin is in force. Observed through
// run_cycle() + drain() over a VirtualClock and a scripted device.

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <numbers>
#include <thread>
#include <vector>

#include "daemon/engine/engine.hpp"
#include "drivers/loopback/loopback_device.hpp"
#include "rt/clock.hpp"
#include "rt/loop_timing.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/loopback_start.hpp"
#include "world/scene_catalog.hpp"

namespace engine_origin_test {

namespace {

using hapticd::daemon::flag_fault_latched;
using hapticd::daemon::flag_position_jump;
using hapticd::daemon::flag_uncalibrated;
using hapticd::daemon::TelemetrySample;
using hapticd::daemon::engine::Engine;
using hapticd::daemon::engine::EngineOptions;
using hapticd::daemon::engine::FaultReason;
using hapticd::daemon::engine::LoopPlan;
using hapticd::daemon::engine::OriginHandover;
using hapticd::daemon::engine::OriginRequest;
using hapticd::testing::AllocationGuard;
namespace drivers = hapticd::drivers;
namespace world = hapticd::world;
namespace rt = hapticd::rt;
using namespace std::chrono_literals;

constexpr double period_s = 1e-3;
constexpr double resolution = 2.0 * std::numbers::pi / 16384.0;
constexpr double torque_limit = 0.8;

/// read() returns `position` (an error while `failing`), write() keeps the force.
class ScriptedDevice final : public drivers::DeviceHooks {
 public:
  drivers::IoResult read(drivers::Reading& out) noexcept override {
    if (failing) return drivers::IoResult::error;
    out.position = position;
    return drivers::IoResult::ok;
  }
  drivers::IoResult write(double force) noexcept override {
    last_written = force;
    return drivers::IoResult::ok;
  }
  drivers::DeviceModel model() const override { return {}; }

  double position = 0.0;
  bool failing = false;
  double last_written = 0.0;
};

std::unique_ptr<LoopPlan> wheel() {
  auto outcome = world::plan_scene("spring-wheel", {}, period_s, world::Motion::rotary);
  auto plan = std::make_unique<LoopPlan>();
  plan->scene = std::get<world::ScenePlan>(outcome).scene_object;
  plan->torque_limit = torque_limit;
  return plan;
}

class EngineOrigin : public ::testing::Test {
 protected:
  void build(bool require_calibration = false) {
    EngineOptions options;
    options.realtime.priority = 0;
    options.realtime.lock_memory = false;
    options.realtime.hold_dma_latency = false;
    options.telemetry_capacity = 1u << 14;
    options.position_rule.max_velocity = 50.0;
    options.position_rule.resolution = resolution;
    options.position_rule.period_s = period_s;
    options.require_calibration = require_calibration;
    engine = std::make_unique<Engine>(options, framework, clock);
    framework.configure({period_s});
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
  /// The hand turns the wheel at `velocity` rad/s for n periods.
  std::vector<TelemetrySample> turn(double velocity, int n) {
    std::vector<TelemetrySample> out;
    for (int i = 0; i < n; ++i) {
      device.position += velocity * period_s;
      out.push_back(cycle());
    }
    return out;
  }

  rt::VirtualClock clock;
  drivers::Device framework{"scripted", std::make_unique<ScriptedDevice>()};
  ScriptedDevice& device = framework.hooks_as<ScriptedDevice>();
  std::unique_ptr<Engine> engine;
  rt::PeriodicSchedule schedule{clock, rt::Nanos{1'000'000}};
};

}  // namespace

// The hand-over alone: one request at a time, its fields read only after
// its ticket, its outcome only once done.
TEST(OriginHandoverTest, OneRequestAtATimeAndItsOutcomeOnceDone) {
  OriginHandover h;
  OriginHandover::Pending p;
  EXPECT_TRUE(h.idle());
  EXPECT_FALSE(h.pending(p));
  const auto ticket = h.request(OriginRequest::set_value, 1.25, 10);
  ASSERT_EQ(ticket, 1u);
  EXPECT_FALSE(h.idle());
  EXPECT_EQ(h.request(OriginRequest::zero_here, 0.0, 10), 0u) << "refused while the last is pending";
  EXPECT_FALSE(h.outcome(ticket).has_value());
  ASSERT_TRUE(h.pending(p));
  EXPECT_EQ(p.kind, OriginRequest::set_value);
  EXPECT_EQ(p.value, 1.25);
  EXPECT_EQ(p.valid_until_cycle, 10u);
  h.complete(true, 7, 1.25, 0.0);
  EXPECT_TRUE(h.idle());
  EXPECT_FALSE(h.pending(p));
  const auto outcome = h.outcome(ticket);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_TRUE(outcome->taken);
  EXPECT_EQ(outcome->cycle, 7u);
  EXPECT_EQ(outcome->origin, 1.25);
  EXPECT_EQ(h.request(OriginRequest::zero_here, 0.0, 20), 2u);
}

// device.zero while a hand turns the wheel far from the power-up position:
// from the cycle it is taken, every position is the device's minus the
// origin (the scene, the sample), the scene restarts at equilibrium there
// (no torque step), and the origin change is not an encoder jump, though it
// is 10^5 times the step limit.
TEST_F(EngineOrigin, ZeroShiftsEveryPositionByTheOriginWithoutATorqueStepOrAJump) {
  build();
  device.position = 5000.0;  // an incremental encoder, far from where it powered up
  const auto before = turn(2.0, 300);
  ASSERT_GT(std::abs(before.back().applied), 0.05) << "torque flows before the zero";
  EXPECT_NEAR(before.back().position, device.position, 1e-12) << "no origin: the device's position";
  EXPECT_FALSE(engine->calibrated());

  const auto ticket = engine->request_zero(2000ms);
  ASSERT_NE(ticket, 0u);
  const double raw_at_zero = device.position + 2.0 * period_s;  // what the next cycle reads
  const auto first = turn(2.0, 1).front();
  const auto outcome = engine->origin_outcome(ticket);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_TRUE(outcome->taken);
  EXPECT_EQ(outcome->cycle, first.cycle);
  EXPECT_DOUBLE_EQ(outcome->origin, raw_at_zero);
  EXPECT_EQ(outcome->previous, 0.0);
  EXPECT_TRUE(engine->calibrated());
  EXPECT_DOUBLE_EQ(engine->origin(), raw_at_zero);

  EXPECT_EQ(first.position, 0.0) << "the cycle it is taken reads zero";
  EXPECT_LT(std::abs(first.applied), 1e-9) << "the scene restarted at equilibrium: no torque step";
  EXPECT_EQ(first.flags & (flag_position_jump | flag_fault_latched), 0u);
  EXPECT_EQ(engine->fault(), FaultReason::none);
  TelemetrySample last;
  for (int i = 0; i < 300; ++i) {
    device.position += 2.0 * period_s;
    last = cycle();
    EXPECT_EQ(last.position, device.position - raw_at_zero) << "cycle " << last.cycle;
  }
  EXPECT_GT(std::abs(last.applied), 0.05) << "the scene renders on from the new origin";
  EXPECT_EQ(engine->counters().position_jumps, 0u);

  // The rule still checks the device's own readings: a real jump latches.
  device.position += 1e4 * resolution;
  const auto jump = cycle();
  EXPECT_NE(jump.flags & flag_position_jump, 0u);
  EXPECT_EQ(engine->fault(), FaultReason::encoder_jump);
}

// No valid reading (a read error every period) within the request's window:
// the request is dropped, not taken later, and the origin stays.
TEST_F(EngineOrigin, AZeroWithoutAValidReadingExpiresAndLeavesTheOriginAlone) {
  build();
  turn(0.0, 10);
  device.failing = true;
  const auto ticket = engine->request_zero(5ms);
  for (int i = 0; i < 3; ++i) cycle();
  EXPECT_FALSE(engine->origin_outcome(ticket).has_value()) << "still within its window";
  for (int i = 0; i < 10; ++i) cycle();
  const auto outcome = engine->origin_outcome(ticket);
  ASSERT_TRUE(outcome.has_value());
  EXPECT_FALSE(outcome->taken);
  EXPECT_FALSE(engine->calibrated());
  device.failing = false;
  EXPECT_EQ(cycle().position, device.position) << "no origin was set";
}

// [device] require_calibration: zero output, flagged, until the device is
// zeroed; then the scene renders from equilibrium at the new origin.
TEST_F(EngineOrigin, RequiredCalibrationHoldsTheOutputAtZeroUntilZeroed) {
  build(true);
  device.position = 3.0;
  for (const auto& s : turn(2.0, 500)) {
    EXPECT_EQ(s.applied, 0.0) << "cycle " << s.cycle;
    EXPECT_EQ(s.command, 0.0);
    EXPECT_NE(s.flags & flag_uncalibrated, 0u);
    EXPECT_EQ(s.flags & flag_fault_latched, 0u) << "not a fault";
  }
  EXPECT_EQ(device.last_written, 0.0);
  const auto ticket = engine->request_zero(2000ms);
  const auto first = cycle();
  ASSERT_TRUE(engine->origin_outcome(ticket).has_value());
  EXPECT_EQ(first.flags & flag_uncalibrated, 0u);
  EXPECT_LT(std::abs(first.applied), 1e-9);
  const auto after = turn(2.0, 300);
  EXPECT_GT(std::abs(after.back().applied), 0.05);
  for (const auto& s : after) EXPECT_EQ(s.flags & flag_uncalibrated, 0u);
}

// A preset origin (restored from the state directory, or a homed device)
// is in force from the first cycle: calibrated, nothing held.
TEST_F(EngineOrigin, APresetOriginIsInForceFromTheFirstCycle) {
  build(true);
  engine->preset_origin(1.5);
  device.position = 1.75;
  const auto first = cycle();
  EXPECT_DOUBLE_EQ(first.position, 0.25);
  EXPECT_EQ(first.flags & flag_uncalibrated, 0u);
  EXPECT_TRUE(engine->calibrated());
}

// The origin's hand-over and its subtraction on the RT side allocate nothing:
// requests taken, dropped, under a latched fault and with the output held.
TEST_F(EngineOrigin, ZeroingAndHoldingDoNotAllocate) {
  build(true);
  device.position = 2.0;
  auto run = [&](double velocity, int n) {
    for (int i = 0; i < n; ++i) {
      device.position += velocity * period_s;
      engine->run_cycle(schedule.wait_next());
    }
  };
  std::array<bool, 4> taken{};
  std::array<bool, 4> done{};
  auto settle = [&](std::size_t i, std::uint64_t ticket) {
    const auto outcome = engine->origin_outcome(ticket);
    done[i] = outcome.has_value();
    taken[i] = outcome.has_value() && outcome->taken;
  };
  std::size_t allocs = 0;
  bool done_before_a_cycle = true;
  {
    AllocationGuard guard;
    run(1.0, 200);  // held: not calibrated
    auto ticket = engine->request_zero(100ms);
    done_before_a_cycle = engine->origin_outcome(ticket).has_value();
    run(1.0, 200);
    settle(0, ticket);
    ticket = engine->request_zero(100ms);
    run(1.0, 1);
    settle(1, ticket);
    engine->estop();
    ticket = engine->request_zero(100ms);  // taken while latched: the reading is valid
    run(1.0, 10);
    settle(2, ticket);
    engine->clear_fault();
    device.failing = true;
    ticket = engine->request_zero(3ms);  // dropped: no valid reading
    run(0.0, 10);
    settle(3, ticket);
    device.failing = false;
    run(1.0, 200);
    allocs = guard.count();
  }
  EXPECT_EQ(allocs, 0u);
  EXPECT_FALSE(done_before_a_cycle);
  for (std::size_t i = 0; i < taken.size(); ++i) {
    EXPECT_TRUE(done[i]) << i;
    EXPECT_EQ(taken[i], i != 3) << i;
  }
  EXPECT_EQ(engine->counters().position_jumps, 0u);
  std::vector<TelemetrySample> buffer(1024);
  std::size_t held = 0, samples = 0;
  while (const std::size_t n = engine->drain(buffer)) {
    samples += n;
    for (std::size_t i = 0; i < n; ++i) held += (buffer[i].flags & flag_uncalibrated) != 0 ? 1 : 0;
  }
  EXPECT_EQ(samples, 621u);
  EXPECT_EQ(held, 200u) << "held until the first zero was taken";
}

// The hand-over with the real loop thread, for ThreadSanitizer
// (tests/run_sanitizers.sh runs every daemon test under it): device.zero
// from the control thread while the loop runs, a hand turns the wheel,
// estops and clears land, and a consumer drains. Every zero is taken at a
// cycle whose sample reads exactly 0, and no sample steps the torque.
TEST(EngineOriginThreads, ZerosFromTheControlThreadWhileTheLoopRuns) {
  auto config = hapticd::drivers::loopback::LoopbackConfig::defaults(drivers::Motion::rotary);
  config.damping = 0.002;
  hapticd::testing::LoopbackRig rig{config};
  rig.plant.set_hand("mode=hold trajectory=sine amplitude=0.3 frequency=2");
  hapticd::testing::start(rig.device);
  EngineOptions options;
  options.realtime.priority = 0;
  options.realtime.lock_memory = false;
  options.realtime.hold_dma_latency = false;
  options.overrun_limit = 0;
  options.require_calibration = true;
  rt::RealClock clock;
  Engine engine(options, rig.device, clock);
  engine.publish(wheel());

  std::atomic<bool> consuming{true};
  std::vector<TelemetrySample> samples;
  std::thread consumer([&] {
    std::vector<TelemetrySample> buffer(512);
    for (;;) {
      const bool more = consuming.load(std::memory_order_acquire);
      const std::size_t n = engine.drain(buffer);
      samples.insert(samples.end(), buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n));
      if (!more && n == 0) break;
      if (n == 0) std::this_thread::sleep_for(200us);
    }
  });
  ASSERT_FALSE(engine.start().fatal);
  std::vector<std::uint64_t> zero_cycles;
  for (int i = 0; i < 20; ++i) {
    if (i % 7 == 3) engine.estop();
    const auto outcome = engine.zero_here(2000ms);
    ASSERT_TRUE(outcome.has_value()) << i;
    EXPECT_TRUE(outcome->taken) << i;
    EXPECT_DOUBLE_EQ(engine.origin(), outcome->origin);
    zero_cycles.push_back(outcome->cycle);
    if (i % 7 == 3) engine.clear_fault();
    std::this_thread::sleep_for(std::chrono::milliseconds(5 + i % 4));
  }
  engine.stop();
  consuming.store(false, std::memory_order_release);
  consumer.join();
  rig.device.disable();

  EXPECT_TRUE(engine.calibrated());
  std::size_t matched = 0;
  for (const auto& s : samples) {
    for (const auto cycle : zero_cycles) {
      if (s.cycle != cycle) continue;
      ++matched;
      EXPECT_EQ(s.position, 0.0) << "cycle " << cycle;
      EXPECT_LT(std::abs(s.applied), 1e-9) << "no torque step at cycle " << cycle;
    }
    if (s.cycle < zero_cycles.front()) {
      EXPECT_EQ(s.applied, 0.0) << "held until the first zero";
    }
  }
  EXPECT_EQ(matched, zero_cycles.size());
}

}  // namespace engine_origin_test
