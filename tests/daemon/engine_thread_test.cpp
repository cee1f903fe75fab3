// The engine with its real loop thread while the control side publishes,
// estops and clears, and a consumer drains telemetry: the hand-over, latch
// and ring are lock-free, so this is what ThreadSanitizer (tests/run_sanitizers.sh tsan)
// checks. Functional checks only; no timing assertions.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "daemon/engine/engine.hpp"
#include "drivers/loopback/loopback_device.hpp"
#include "rt/clock.hpp"
#include "tests/support/loopback_start.hpp"
#include "world/scene_catalog.hpp"

namespace engine_thread_test {

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

constexpr double torque_limit = 0.5;

std::unique_ptr<LoopPlan> plan_number(int i) {
  world::ParameterSet parameters;
  std::string scene;
  world::Motion motion = world::Motion::rotary;
  switch (i % 5) {
    case 0:
      scene = "spring-wheel";
      break;
    case 1:
      scene = "spring-wheel";
      parameters = {{"damping", 0.05}, {"integrator", "trapezoid"}};
      break;
    case 2:
      scene = "wall";
      parameters = {{"stiffness", 20.0 + i}, {"damping", 0.1}, {"delay", 1.0}, {"position", 0.05}};
      motion = world::Motion::linear;
      break;
    case 3:
      scene = "relay";
      parameters = {{"amplitude", 0.01 * (i % 50 + 1)}, {"hysteresis", 0.01}};
      break;
    default:
      scene = "free";
      break;
  }
  auto outcome = world::plan_scene(scene, parameters, 1e-3, motion);
  auto plan = std::make_unique<LoopPlan>();
  plan->scene = std::get<world::ScenePlan>(outcome).scene_object;
  plan->torque_limit = torque_limit;
  return plan;
}

}  // namespace

TEST(EngineThreads, PublishEstopClearAndDrainConcurrently) {
  auto config = loopback::LoopbackConfig::defaults(hapticd::drivers::Motion::rotary);
  config.damping = 0.002;
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  plant.set_hand("mode=hold trajectory=sine amplitude=0.2 frequency=3");
  hapticd::testing::start(device);

  EngineOptions options;
  options.realtime.priority = 0;
  options.realtime.lock_memory = false;
  options.realtime.hold_dma_latency = false;
  options.period = rt::Nanos{500'000};
  options.overrun_limit = 0;  // a loaded or sanitized machine is late often: not the subject here
  options.telemetry_capacity = 1u << 12;
  rt::RealClock clock;
  Engine engine(options, device, clock);

  // Consumer: drains telemetry the whole time and checks each sample.
  std::atomic<bool> consuming{true};
  std::uint64_t samples = 0, last_cycle = 0, order_errors = 0, limit_errors = 0, latched_output = 0;
  std::thread consumer([&] {
    std::vector<TelemetrySample> buffer(512);
    for (;;) {
      const bool more = consuming.load(std::memory_order_acquire);
      const std::size_t n = engine.drain(buffer);
      for (std::size_t i = 0; i < n; ++i) {
        const auto& s = buffer[i];
        ++samples;
        if (s.cycle <= last_cycle) ++order_errors;
        last_cycle = s.cycle;
        if (!(std::abs(s.applied) <= torque_limit)) ++limit_errors;
        if ((s.flags & hapticd::daemon::flag_fault_latched) && s.applied != 0.0) ++latched_output;
      }
      if (!more && n == 0) break;
      if (n == 0) std::this_thread::sleep_for(200us);
    }
  });

  const auto& report = engine.start();
  ASSERT_FALSE(report.fatal) << report.message();

  int waited = 0, applied_seen = 0, superseded = 0, resets = 0;
  for (int i = 0; i < 200; ++i) {
    const auto publication = engine.publish(plan_number(i));
    if (publication.superseded_seq != 0) ++superseded;
    if (i % 10 == 0) {
      ++waited;
      const auto cycle = engine.wait_applied(publication.seq, 10s);
      if (cycle) ++applied_seen;
    }
    if (i % 17 == 5) engine.estop();
    if (i % 17 == 9) engine.clear_fault();
    if (i % 23 == 3) plant.inject_fault(loopback::Fault::nan, 1);
    if (i % 23 == 12) engine.clear_fault();
    if (i % 50 == 25) plant.set_hand("mode=hold trajectory=sine amplitude=0.1 frequency=2");
    if (i % 40 == 7) {  // stats.reset from the control thread, done by the loop thread
      const auto since = engine.reset_stats(10s);
      ASSERT_TRUE(since.has_value());
      const auto stats = engine.stats();
      EXPECT_LE(stats.cycles, engine.cycle() - *since + 1);
      ++resets;
    }
    if (i % 20 == 0) {
      const auto stats = engine.stats();
      const auto counters = engine.counters();
      EXPECT_LE(counters.faults_latched, stats.cycles);
    }
    std::this_thread::sleep_for(std::chrono::microseconds(500 + 100 * (i % 7)));
  }
  engine.clear_fault();
  // Let the loop run with the last plan for a moment, then stop it.
  const std::uint64_t seen = engine.cycle();
  const auto until = std::chrono::steady_clock::now() + 10s;
  while (engine.cycle() < seen + 20 && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(1ms);
  EXPECT_EQ(engine.fault(), FaultReason::none);
  engine.stop();
  EXPECT_TRUE(engine.finished());
  consuming.store(false, std::memory_order_release);
  consumer.join();
  device.disable();

  EXPECT_EQ(applied_seen, waited);
  EXPECT_EQ(resets, 5);
  EXPECT_GE(engine.cycle(), seen + 20);
  EXPECT_GT(samples, 100u);
  EXPECT_EQ(order_errors, 0u);
  EXPECT_EQ(limit_errors, 0u);
  EXPECT_EQ(latched_output, 0u);
  EXPECT_EQ(samples + engine.counters().telemetry_dropped, engine.cycle());
  EXPECT_GE(engine.counters().faults_latched, 1u);  // the NaN injections
}

}  // namespace engine_thread_test
