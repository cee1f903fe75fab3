// Proof that the RT cycle (Engine::run_cycle, including the plan hand-over)
// allocates nothing, for every scene alternative, under faults, with a
// scripted hand and with a full telemetry ring; on a six-axis stage, every
// task-space scene alternative (the several-axis cycle). The loop body is driven
// directly over a VirtualClock; hapticd_alloc_counter counts every operator
// new on this thread while an AllocationGuard lives.

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "daemon/engine/engine.hpp"
#include "drivers/device.hpp"
#include "drivers/loopback/loopback_device.hpp"
#include "rt/clock.hpp"
#include "rt/loop_timing.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/loopback_start.hpp"
#include "world/scene_catalog.hpp"

namespace engine_alloc_test {

namespace {

using hapticd::daemon::TelemetrySample;
using hapticd::daemon::engine::Engine;
using hapticd::daemon::engine::EngineOptions;
using hapticd::daemon::engine::FaultReason;
using hapticd::daemon::engine::LoopPlan;
using hapticd::testing::AllocationGuard;
namespace loopback = hapticd::drivers::loopback;
namespace world = hapticd::world;
namespace rt = hapticd::rt;

constexpr double period_s = 1e-3;
constexpr int guarded_cycles = 10'000;

template <class P>
void escape(P p) {
  asm volatile("" : : "g"(p) : "memory");
}

loopback::LoopbackConfig rotary_config() {
  auto config = loopback::LoopbackConfig::defaults(hapticd::drivers::Motion::rotary);
  config.damping = 0.002;
  return config;
}

EngineOptions quiet_options(std::size_t telemetry_capacity = 1u << 14) {
  EngineOptions options;
  options.realtime.priority = 0;
  options.realtime.lock_memory = false;
  options.realtime.hold_dma_latency = false;
  options.telemetry_capacity = telemetry_capacity;
  // Every test here runs with the position-step rule the daemon would set
  // for the loopback wheel (its default max_velocity, its encoder).
  const auto config = rotary_config();
  options.position_rule.max_velocity = hapticd::daemon::engine::default_max_velocity(true, config.mass, 1.0);
  options.position_rule.resolution = config.resolution();
  options.position_rule.period_s = period_s;
  return options;
}

std::unique_ptr<LoopPlan> make_plan(const std::string& scene, const world::ParameterSet& parameters,
                                    double torque_limit, world::Motion motion = world::Motion::rotary) {
  auto outcome = world::plan_scene(scene, parameters, period_s, motion);
  if (const auto* error = std::get_if<world::SceneError>(&outcome)) {
    ADD_FAILURE() << scene << ": " << error->message;
    return nullptr;
  }
  auto plan = std::make_unique<LoopPlan>();
  plan->scene = std::get<world::ScenePlan>(outcome).scene_object;
  plan->torque_limit = torque_limit;
  return plan;
}

struct NamedPlan {
  std::string label;
  std::unique_ptr<LoopPlan> plan;
};

/// One plan per AnyScene alternative and integrator.
std::vector<NamedPlan> every_scene_plan() {
  std::vector<NamedPlan> out;
  const std::array<std::string, 5> integrators{"forward-euler", "semi-implicit-euler", "trapezoid", "rk4",
                                               "exact"};
  for (const auto& integrator : integrators) {
    out.push_back({"spring-wheel b=0 " + integrator,
                   make_plan("spring-wheel", {{"integrator", integrator}, {"damping", 0.0}}, 0.5)});
    out.push_back(
        {"spring-wheel b=0.5 absolute " + integrator,
         make_plan("spring-wheel",
                   {{"integrator", integrator}, {"damping", 0.5}, {"damping_reference", "absolute"}}, 0.5)});
    out.push_back(
        {"spring-wheel b=0.5 relative " + integrator,
         make_plan("spring-wheel",
                   {{"integrator", integrator}, {"damping", 0.5}, {"damping_reference", "relative"}}, 0.5)});
  }
  for (const double damping : {0.0, 0.2}) {
    for (const double delay : {0.0, 2.0}) {
      out.push_back(
          {"wall B=" + std::to_string(damping) + " d=" + std::to_string(delay),
           make_plan("wall",
                     {{"stiffness", 50.0}, {"damping", damping}, {"delay", delay}, {"position", 0.02}}, 0.5,
                     world::Motion::linear)});
    }
  }
  for (const double hysteresis : {0.0, 0.01}) {
    out.push_back({"relay eps=" + std::to_string(hysteresis),
                   make_plan("relay", {{"amplitude", 0.3}, {"hysteresis", hysteresis}}, 0.5)});
    // The relay experiment's extra delay t_d (Diaz & Gil eq. 25) is its own alternative.
    out.push_back(
        {"relay eps=" + std::to_string(hysteresis) + " delay=3",
         make_plan("relay", {{"amplitude", 0.3}, {"hysteresis", hysteresis}, {"delay", 3.0}}, 0.5)});
  }
  out.push_back({"chirp", make_plan("chirp",
                                    {{"amplitude", 0.3},
                                     {"start_frequency", 1.0},
                                     {"end_frequency", 50.0},
                                     {"sweep", 2.0},
                                     {"duration", 10.0}},
                                    0.5)});
  // The passivity observer/controller wraps the wall and the springs: an alternative of its own.
  for (const double damping : {0.0, 0.2}) {
    for (const double delay : {0.0, 2.0}) {
      const std::string mode = delay == 0.0 ? "observer" : "controller";
      out.push_back(
          {"wall passivity=" + mode + " B=" + std::to_string(damping) + " d=" + std::to_string(delay),
           make_plan("wall",
                     {{"stiffness", 50.0},
                      {"damping", damping},
                      {"delay", delay},
                      {"position", 0.02},
                      {"passivity", mode}},
                     0.5, world::Motion::linear)});
    }
  }
  for (const std::string reference : {"none", "absolute", "relative"}) {
    world::ParameterSet parameters{{"passivity", "controller"}, {"damping", reference == "none" ? 0.0 : 0.5}};
    if (reference != "none") parameters.emplace("damping_reference", reference);
    out.push_back(
        {"spring-wheel passivity=controller " + reference, make_plan("spring-wheel", parameters, 0.5)});
  }
  out.push_back({"free", make_plan("free", {}, 0.5)});
  return out;
}

struct Rig {
  explicit Rig(std::size_t telemetry_capacity = 1u << 14, const EngineOptions* options = nullptr)
      : loopback(rotary_config()),
        engine(options ? *options : quiet_options(telemetry_capacity), device, clock),
        schedule(clock, rt::Nanos{1'000'000}) {
    hapticd::testing::start(device);
    schedule.start();
  }
  ~Rig() { device.disable(); }
  void cycle() { engine.run_cycle(schedule.wait_next()); }
  /// Runs `n` cycles inside a fresh guard; returns the allocations counted.
  std::size_t guarded(int n) {
    AllocationGuard guard;
    for (int i = 0; i < n; ++i) cycle();
    return guard.count();
  }

  rt::VirtualClock clock;
  hapticd::testing::LoopbackRig loopback;
  hapticd::drivers::Device& device = loopback.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = loopback.plant;
  Engine engine;
  rt::PeriodicSchedule schedule;
};

struct DrainSummary {
  std::size_t samples = 0;
  std::size_t nonzero_applied = 0;
  std::size_t torque_limited = 0;
  std::size_t fault_latched = 0;
  std::size_t read_error = 0;
  std::size_t overrun = 0;
  std::set<std::uint32_t> channel_counts;
};

DrainSummary drain_all(Engine& engine, std::vector<TelemetrySample>& buffer) {
  DrainSummary s;
  for (;;) {
    const std::size_t n = engine.drain(buffer);
    for (std::size_t i = 0; i < n; ++i) {
      const auto& sample = buffer[i];
      ++s.samples;
      if (sample.applied != 0.0) ++s.nonzero_applied;
      if (sample.flags & hapticd::daemon::flag_torque_limited) ++s.torque_limited;
      if (sample.flags & hapticd::daemon::flag_fault_latched) ++s.fault_latched;
      if (sample.flags & hapticd::daemon::flag_read_error) ++s.read_error;
      if (sample.flags & hapticd::daemon::flag_overrun) ++s.overrun;
      s.channel_counts.insert(sample.channel_count);
    }
    if (n == 0) break;
  }
  return s;
}

}  // namespace

TEST(EngineAlloc, CounterIsLinkedAndCountsADeliberateAllocation) {
  ASSERT_TRUE(hapticd::testing::allocation_counting_active());
  std::size_t n = 0;
  {
    AllocationGuard guard;
    void* p = ::operator new(64);
    escape(p);
    ::operator delete(p);
    auto v = std::make_unique<std::vector<double>>(16);
    escape(v.get());
    v.reset();
    n = guard.count();
  }
  EXPECT_EQ(n, 3u);
}

namespace {
/// A driver whose RT path allocates: shows that an allocation made inside
/// run_cycle (not only in the test body) is counted by the guard. A test
/// component: read, write and the model, over the loopback's simulator.
class AllocatingHooks final : public hapticd::drivers::DeviceHooks {
 public:
  explicit AllocatingHooks(const loopback::LoopbackConfig& config) : plant_(config) {}
  hapticd::drivers::DeviceModel model() const override { return plant_.model(); }
  hapticd::drivers::IoResult read(hapticd::drivers::Reading& out) noexcept override {
    void* p = ::operator new(32, std::nothrow);
    escape(p);
    ::operator delete(p);
    return plant_.read(out);
  }
  hapticd::drivers::IoResult write(double force) noexcept override { return plant_.write(force); }

 private:
  loopback::LoopbackDevice plant_;
};
}  // namespace

TEST(EngineAlloc, GuardSeesAnAllocationInsideRunCycle) {
  rt::VirtualClock clock;
  hapticd::drivers::Device device("allocating", std::make_unique<AllocatingHooks>(rotary_config()));
  Engine engine(quiet_options(), device, clock);
  rt::PeriodicSchedule schedule(clock, rt::Nanos{1'000'000});
  device.configure({1e-3});
  device.enable();
  schedule.start();
  engine.publish(make_plan("spring-wheel", {}, 0.5));
  std::size_t n = 0;
  {
    AllocationGuard guard;
    for (int i = 0; i < 100; ++i) engine.run_cycle(schedule.wait_next());
    n = guard.count();
  }
  device.disable();
  EXPECT_EQ(n, 100u);
}

TEST(EngineAlloc, EverySceneAlternativeRunsAndInstallsWithoutAllocating) {
  Rig rig;
  rig.plant.set_hand("mode=hold trajectory=sine amplitude=0.1 frequency=3");
  std::vector<TelemetrySample> buffer(4096);
  auto plans = every_scene_plan();
  ASSERT_EQ(plans.size(), 32u);
  std::set<std::size_t> alternatives;
  for (auto& named : plans) {
    ASSERT_NE(named.plan, nullptr);
    alternatives.insert(named.plan->scene.index());
  }
  EXPECT_EQ(alternatives.size(), std::variant_size_v<world::AnyScene>);

  EXPECT_EQ(rig.guarded(5), 0u);  // no plan yet: output zero, nothing to install
  EXPECT_EQ(drain_all(rig.engine, buffer).nonzero_applied, 0u);
  for (auto& named : plans) {
    SCOPED_TRACE(named.label);
    const bool is_free = named.label == "free";
    const auto publication = rig.engine.publish(std::move(named.plan));  // allocates: control thread
    // The install (Mailbox::acquire + scene copy + reset) happens in the first guarded cycle.
    const std::size_t install_allocs = rig.guarded(1);
    const auto applied_at = rig.engine.wait_applied(publication.seq, std::chrono::milliseconds(0));
    const std::size_t run_allocs = rig.guarded(guarded_cycles);
    EXPECT_EQ(install_allocs, 0u);
    EXPECT_EQ(run_allocs, 0u);
    ASSERT_TRUE(applied_at.has_value());
    EXPECT_EQ(*applied_at, rig.engine.cycle() - static_cast<std::uint64_t>(guarded_cycles));
    const DrainSummary s = drain_all(rig.engine, buffer);
    EXPECT_EQ(s.samples, static_cast<std::size_t>(guarded_cycles) + 1);
    if (is_free) {
      EXPECT_EQ(s.nonzero_applied, 0u);
    } else {
      // The scene really ran: it produced force while the hand moved the device.
      EXPECT_GT(s.nonzero_applied, 100u);
    }
    EXPECT_EQ(s.fault_latched, 0u);
  }
  EXPECT_EQ(rig.engine.counters().telemetry_dropped, 0u);
}

TEST(EngineAlloc, HandSineFaultsClearAndOverrunsDoNotAllocate) {
  EngineOptions options = quiet_options();
  options.read_error_limit = 5;
  options.overrun_limit = 3;
  Rig rig(0, &options);
  rig.plant.set_hand("mode=hold trajectory=sine amplitude=0.2 frequency=2");
  rig.engine.publish(make_plan("spring-wheel", {{"damping", 0.5}}, 0.1));
  std::vector<TelemetrySample> buffer(4096);

  std::size_t allocs = rig.guarded(guarded_cycles);
  DrainSummary s = drain_all(rig.engine, buffer);
  EXPECT_GT(s.nonzero_applied, 1000u);
  EXPECT_GT(s.torque_limited, 0u);

  // Transient read errors (below the limit): zero output, counted, no latch.
  rig.plant.inject_fault(loopback::Fault::read_error, 3);
  allocs += rig.guarded(100);
  EXPECT_EQ(rig.engine.fault(), FaultReason::none);
  // NaN position: latch, then the clear/reset path.
  rig.plant.inject_fault(loopback::Fault::nan, 1);
  allocs += rig.guarded(100);
  EXPECT_EQ(rig.engine.fault(), FaultReason::non_finite_position);
  rig.engine.clear_fault();
  allocs += rig.guarded(100);
  EXPECT_EQ(rig.engine.fault(), FaultReason::none);
  // Device fault, then cleared.
  rig.plant.inject_fault(loopback::Fault::fault, 10);
  allocs += rig.guarded(100);
  EXPECT_EQ(rig.engine.fault(), FaultReason::device_fault);
  rig.engine.clear_fault();
  allocs += rig.guarded(100);
  // Read-error streak latches.
  rig.plant.inject_fault(loopback::Fault::read_error, 20);
  allocs += rig.guarded(100);
  EXPECT_EQ(rig.engine.fault(), FaultReason::read_error_streak);
  rig.engine.clear_fault();
  // Stall (stale reading, write errors) latches a write error.
  rig.plant.inject_fault(loopback::Fault::stall, 5);
  allocs += rig.guarded(100);
  EXPECT_EQ(rig.engine.fault(), FaultReason::write_error);
  rig.engine.clear_fault();
  // Overrun streak.
  {
    AllocationGuard guard;
    for (int i = 0; i < 5; ++i) {
      rig.clock.stall_next_sleep(rt::Nanos{2'500'000});
      rig.cycle();
    }
    for (int i = 0; i < 100; ++i) rig.cycle();
    allocs += guard.count();
  }
  EXPECT_EQ(rig.engine.fault(), FaultReason::overrun_streak);
  rig.engine.clear_fault();
  // Estop and clear, all inside one guard.
  {
    AllocationGuard guard;
    rig.engine.estop();
    for (int i = 0; i < 50; ++i) rig.cycle();
    rig.engine.clear_fault();
    for (int i = 0; i < guarded_cycles; ++i) rig.cycle();
    allocs += guard.count();
  }
  EXPECT_EQ(allocs, 0u);
  EXPECT_EQ(rig.engine.fault(), FaultReason::none);
  // Latched by the RT thread: nan, device fault, read errors, write error,
  // overrun streak (estop is latched by the caller and not counted here).
  EXPECT_EQ(rig.engine.counters().faults_latched, 5u);
  EXPECT_GE(rig.engine.counters().read_errors, 3u + 20u);
  s = drain_all(rig.engine, buffer);
  EXPECT_GT(s.fault_latched, 0u);
  EXPECT_GT(s.read_error, 0u);
  EXPECT_GE(s.overrun, 5u);
  EXPECT_GT(s.nonzero_applied, 1000u);  // the loop came back after the last clear
}

// The position-step rule (issue 17): a jump refused, its figures stored in
// the latch, the latched stretch, the clear and the restart, a jump while
// another fault is latched: nothing allocates on the RT side.
TEST(EngineAlloc, PositionJumpsLatchAndClearWithoutAllocating) {
  Rig rig;
  rig.plant.set_hand("mode=hold trajectory=sine amplitude=0.2 frequency=2");
  rig.engine.publish(make_plan("spring-wheel", {{"damping", 0.5}}, 0.5));
  std::vector<TelemetrySample> buffer(4096);
  std::size_t allocs = rig.guarded(1000);
  EXPECT_EQ(rig.engine.fault(), FaultReason::none) << "the hand's sine is motion";

  rig.plant.inject_fault(loopback::Fault::encoder_jump, std::int64_t{1} << 31);
  allocs += rig.guarded(100);
  EXPECT_EQ(rig.engine.fault(), FaultReason::encoder_jump);
  {
    AllocationGuard guard;
    rig.engine.clear_fault();
    for (int i = 0; i < 1000; ++i) rig.cycle();
    rig.engine.estop();
    rig.plant.inject_fault(loopback::Fault::encoder_jump, -5000);  // refused while latched
    for (int i = 0; i < 100; ++i) rig.cycle();
    rig.engine.clear_fault();
    for (int i = 0; i < 100; ++i) rig.cycle();
    rig.plant.inject_fault(loopback::Fault::encoder_jump, 5000);
    for (int i = 0; i < 100; ++i) rig.cycle();
    allocs += guard.count();
  }
  EXPECT_EQ(allocs, 0u);
  EXPECT_EQ(rig.engine.fault(), FaultReason::encoder_jump);
  EXPECT_EQ(rig.engine.counters().position_jumps, 3u);
  EXPECT_EQ(rig.engine.counters().faults_latched, 2u);
  const DrainSummary s = drain_all(rig.engine, buffer);
  EXPECT_GT(s.fault_latched, 0u);
  EXPECT_GT(s.nonzero_applied, 1000u);
}

TEST(EngineAlloc, FullTelemetryRingDropsWithoutAllocating) {
  Rig rig(64);
  rig.plant.set_hand("mode=hold trajectory=sine amplitude=0.2 frequency=2");
  rig.engine.publish(
      make_plan("wall", {{"stiffness", 50.0}, {"damping", 0.2}, {"delay", 1.0}}, 0.5, world::Motion::linear));
  const std::size_t allocs = rig.guarded(guarded_cycles);
  EXPECT_EQ(allocs, 0u);
  EXPECT_EQ(rig.engine.counters().telemetry_dropped, static_cast<std::uint64_t>(guarded_cycles - 64));
}

// stats.reset is carried out by the RT thread (the statistics' only writer)
// at its next cycle: without allocating, from that very cycle on.
TEST(EngineAlloc, StatisticsResetHappensInTheNextCycleWithoutAllocating) {
  Rig rig;
  rig.engine.publish(make_plan("spring-wheel", {{"damping", 0.5}}, 0.1));
  EXPECT_EQ(rig.guarded(100), 0u);
  EXPECT_EQ(rig.engine.stats().cycles, 100u);
  // No loop thread here: the request is left for the next run_cycle.
  EXPECT_FALSE(rig.engine.reset_stats(std::chrono::milliseconds(0)).has_value());
  EXPECT_EQ(rig.engine.stats().cycles, 100u);
  EXPECT_EQ(rig.guarded(10), 0u);
  EXPECT_EQ(rig.engine.stats_since_cycle(), 101u);
  const auto s = rig.engine.stats();
  EXPECT_EQ(s.cycles, 10u);
  EXPECT_EQ(s.latency.count, 10u);
  EXPECT_EQ(s.compute.count, 10u);
}

// ---- a device with several axes (issue 22): the task-space cycle ----

namespace {

/// A six-axis Cartesian loopback stage, each axis held on its own sine
/// through the scenes' surfaces (1 cm), its own mass.
std::unique_ptr<hapticd::drivers::Device> six_axis_stage() {
  loopback::LoopbackStage stage;
  for (int i = 0; i < 6; ++i) {
    auto axis = loopback::LoopbackConfig::defaults(hapticd::drivers::Motion::linear);
    axis.mass = 0.1 * (i + 1);
    stage.axes.push_back(axis);
    stage.hands.push_back(hapticd::drivers::simulation::parse_hand_script(
        "mode=hold trajectory=sine amplitude=0.02 frequency=" + std::to_string(1 + i) +
        " phase=" + std::to_string(0.5 * i)));
  }
  return std::make_unique<hapticd::drivers::Device>("loopback",
                                                    std::make_unique<loopback::LoopbackDevice>(stage));
}

/// Every task-space alternative on six axes: each shape with and without
/// damping and delay, and free.
std::vector<NamedPlan> every_task_plan() {
  std::vector<NamedPlan> out;
  const auto add = [&](const std::string& scene, world::ParameterSet parameters, const std::string& label) {
    auto outcome = world::plan_scene(scene, parameters, period_s, world::Motion::linear, 6);
    if (const auto* error = std::get_if<world::SceneError>(&outcome)) {
      ADD_FAILURE() << scene << ": " << error->message;
      return;
    }
    auto plan = std::make_unique<LoopPlan>();
    plan->task_scene = std::get<world::ScenePlan>(outcome).task_object;
    plan->torque_limit = 0.5;
    out.push_back({label, std::move(plan)});
  };
  for (const double damping : {0.0, 20.0}) {
    for (const double delay : {0.0, 2.0}) {
      const world::ParameterSet law{{"stiffness", 500.0}, {"damping", damping}, {"delay", delay}};
      const std::string tag = " B=" + std::to_string(damping) + " d=" + std::to_string(delay);
      auto plane = law;
      plane.emplace("normal", "1,1,1,1,1,1");
      add("plane-wall", plane, "plane-wall" + tag);
      auto sphere = law;
      sphere.emplace("radius", 0.03);  // |x| of the six sines wanders about 3.5 cm
      sphere.emplace("side", "inside");
      add("sphere", sphere, "sphere" + tag);
      auto box = law;
      box.emplace("low", "-0.01,-0.01,-0.01,-0.01,-0.01,-0.01");
      box.emplace("high", "0.01,0.01,0.01,0.01,0.01,0.01");
      add("box", box, "box" + tag);
    }
  }
  add("axis-springs", {{"stiffness", 200.0}, {"damping", 0.0}}, "axis-springs");
  add("axis-springs", {{"stiffness", 200.0}, {"damping", 2.0}, {"damping_reference", "absolute"}},
      "axis-springs absolute");
  add("axis-springs", {{"stiffness", 200.0}, {"damping", 2.0}}, "axis-springs relative");
  add("free", {}, "free");
  return out;
}

}  // namespace

TEST(EngineAlloc, SixAxesEveryTaskSceneFaultsAndClearsAllocateNothing) {
  rt::VirtualClock clock;
  auto device = six_axis_stage();
  EngineOptions options = quiet_options(1u << 10);
  options.position_rule.resolution = 3.14e-6;
  Engine engine(options, *device, clock);
  rt::PeriodicSchedule schedule(clock, rt::Nanos{1'000'000});
  device->configure({period_s});
  device->enable();
  schedule.start();
  auto& plant = device->hooks_as<loopback::LoopbackDevice>();
  const auto guarded = [&](int n) {
    AllocationGuard guard;
    for (int i = 0; i < n; ++i) engine.run_cycle(schedule.wait_next());
    return guard.count();
  };
  std::vector<TelemetrySample> buffer(4096);
  auto plans = every_task_plan();
  ASSERT_EQ(plans.size(), 16u);
  std::set<std::size_t> alternatives;
  for (auto& named : plans) alternatives.insert(named.plan->task_scene.index());
  EXPECT_EQ(alternatives.size(), std::variant_size_v<world::AnyTaskScene>);
  for (auto& named : plans) {
    SCOPED_TRACE(named.label);
    const bool is_free = named.label == "free";
    const bool no_channels = is_free || named.label.starts_with("axis-springs");
    engine.publish(std::move(named.plan));
    EXPECT_EQ(guarded(1), 0u) << "the install";
    EXPECT_EQ(guarded(2000), 0u);
    // A fault on one axis, its latch and the clear, then a full ring (not drained).
    plant.simulator(3).inject_fault(hapticd::drivers::simulation::Fault::nan, 1);
    EXPECT_EQ(guarded(3), 0u);
    EXPECT_EQ(engine.fault(), FaultReason::non_finite_position);
    engine.clear_fault();
    plant.simulator(5).inject_fault(hapticd::drivers::simulation::Fault::read_error, 3);
    EXPECT_EQ(guarded(1500), 0u);
    EXPECT_EQ(engine.fault(), FaultReason::none);
    const DrainSummary s = drain_all(engine, buffer);
    EXPECT_EQ(s.channel_counts, (std::set<std::uint32_t>{no_channels ? 18u : 19u})) << "6 x 3 + the scene's";
    if (is_free) {
      EXPECT_EQ(s.nonzero_applied, 0u);
    } else {
      EXPECT_GT(s.nonzero_applied, 100u) << "the scene pushed while the hands crossed its surface";
      EXPECT_GT(s.torque_limited, 0u) << "the common factor at the 0.5 N limit";
    }
  }
  EXPECT_GT(engine.counters().telemetry_dropped, 0u) << "the ring filled and dropped";
  device->disable();
}

// ---- the pantograph (issue 22): FK, J^T F and its faults on the RT thread ----

namespace {

/// The loopback pantograph of the default links, its handle held on a 1 Hz
/// sine along y through the scenes' surfaces.
std::unique_ptr<hapticd::drivers::Device> pantograph_device() {
  loopback::LoopbackStage stage;
  auto joint = loopback::LoopbackConfig::defaults(hapticd::drivers::Motion::rotary);
  joint.mass = 5e-4;
  joint.damping = 0.0;
  stage.axes = {joint, joint};
  stage.hands.resize(2);
  loopback::LoopbackStage::Pantograph linkage;
  linkage.model.x_min = -0.02, linkage.model.x_max = 0.06, linkage.model.y_min = 0.07,
  linkage.model.y_max = 0.12;
  linkage.start = {0.02, 0.095};
  linkage.hand = hapticd::drivers::simulation::parse_task_hand_script(
      "direction=0,1 mode=hold trajectory=sine amplitude=0.01 frequency=1", linkage.start);
  stage.pantograph = linkage;
  return std::make_unique<hapticd::drivers::Device>("loopback",
                                                    std::make_unique<loopback::LoopbackDevice>(stage));
}

/// Every task-space alternative on the pantograph's plane.
std::vector<NamedPlan> every_pantograph_plan() {
  std::vector<NamedPlan> out;
  const auto add = [&](const std::string& scene, world::ParameterSet parameters, const std::string& label) {
    auto outcome = world::plan_scene(scene, parameters, period_s, world::Motion::linear, 2);
    if (const auto* error = std::get_if<world::SceneError>(&outcome)) {
      ADD_FAILURE() << scene << ": " << error->message;
      return;
    }
    auto plan = std::make_unique<LoopPlan>();
    plan->task_scene = std::get<world::ScenePlan>(outcome).task_object;
    plan->torque_limit = 0.05;
    out.push_back({label, std::move(plan)});
  };
  for (const double damping : {0.0, 5.0}) {
    for (const double delay : {0.0, 2.0}) {
      const world::ParameterSet law{{"stiffness", 500.0}, {"damping", damping}, {"delay", delay}};
      const std::string tag = " B=" + std::to_string(damping) + " d=" + std::to_string(delay);
      auto plane = law;
      plane.emplace("normal", "0,-1");
      plane.emplace("offset", -0.1);  // the wall at y = 0.1 m
      add("plane-wall", plane, "plane-wall" + tag);
      auto sphere = law;
      sphere.emplace("center", "0.02,0.095");
      sphere.emplace("radius", 0.007);
      sphere.emplace("side", "inside");
      add("sphere", sphere, "sphere" + tag);
      auto box = law;
      box.emplace("low", "-0.01,0.09");
      box.emplace("high", "0.05,0.1");
      add("box", box, "box" + tag);
    }
  }
  add("free", {}, "free");
  return out;
}

}  // namespace

TEST(EngineAlloc, PantographEveryTaskSceneAndItsKinematicsFaultAllocateNothing) {
  rt::VirtualClock clock;
  auto device = pantograph_device();
  EngineOptions options = quiet_options(1u << 12);
  options.position_rule.resolution = 2 * 3.14159265358979 / 16384;
  options.position_rule.rotary = true;
  options.kinematics = world::PantographKinematics(world::PantographGeometry{});
  Engine engine(options, *device, clock);
  rt::PeriodicSchedule schedule(clock, rt::Nanos{1'000'000});
  device->configure({period_s});
  device->enable();
  schedule.start();
  auto& plant = device->hooks_as<loopback::LoopbackDevice>();
  const auto guarded = [&](int n) {
    AllocationGuard guard;
    for (int i = 0; i < n; ++i) engine.run_cycle(schedule.wait_next());
    return guard.count();
  };
  std::vector<TelemetrySample> buffer(4096);
  auto plans = every_pantograph_plan();
  ASSERT_EQ(plans.size(), 13u);
  for (auto& named : plans) {
    SCOPED_TRACE(named.label);
    const bool is_free = named.label == "free";
    engine.publish(std::move(named.plan));
    EXPECT_EQ(guarded(1), 0u) << "the install";
    EXPECT_EQ(guarded(2000), 0u);
    EXPECT_EQ(engine.fault(), FaultReason::none);
    const DrainSummary s = drain_all(engine, buffer);
    EXPECT_EQ(s.channel_counts, (std::set<std::uint32_t>{is_free ? 8u : 9u}))
        << "2 x 3 + the handle's x and y + the scene's";
    if (is_free) {
      EXPECT_EQ(s.nonzero_applied, 0u);
    } else {
      EXPECT_GT(s.nonzero_applied, 100u) << "the scene pushed while the hand crossed its surface";
    }
  }
  // The joints taken where the linkage is singular: the fault latches on
  // the RT thread, with nothing allocated, and the output is zero.
  plant.pantograph_hand()->set_script(
      hapticd::drivers::simulation::parse_task_hand_script("mode=free", {0.02, 0.095}));
  // Springs pull the joints towards (3.3, -0.2) rad, slowly (10 rad/s, half
  // damped, no encoder jump), along a line in joint space (equal joints):
  // the left arm stretches until J all but loses a direction.
  plant.simulator(0).set_hand("mode=impedance stiffness=0.05 damping=0.005 trajectory=constant position=3.3");
  plant.simulator(1).set_hand(
      "mode=impedance stiffness=0.05 damping=0.005 trajectory=constant position=-0.2");
  world::TaskState there;
  world::AxisVector q(2);
  q << 3.3, -0.2;
  world::PantographKinematics(world::PantographGeometry{}).solve(q, there);
  ASSERT_EQ(there.status, world::KinematicsStatus::singular) << "the joints' goal is not a place to render";
  EXPECT_EQ(guarded(1500), 0u);
  EXPECT_EQ(engine.fault(), FaultReason::kinematics_singular) << to_string(engine.fault());
  drain_all(engine, buffer);
  EXPECT_EQ(guarded(50), 0u);
  const DrainSummary after = drain_all(engine, buffer);
  EXPECT_EQ(after.nonzero_applied, 0u);
  EXPECT_EQ(after.fault_latched, after.samples);
  device->disable();
}

// [gravity] and [workspace] (issue 22 item 7): the feedforward and the
// workspace wall on top of every task scene, faults and clears included.
TEST(EngineAlloc, SixAxesWithGravityAndAWorkspaceWallAllocateNothing) {
  rt::VirtualClock clock;
  auto device = six_axis_stage();
  EngineOptions options = quiet_options(1u << 10);
  options.position_rule.resolution = 3.14e-6;
  world::StageWeight weight{world::AxisVector::Zero(6)};
  weight.holding(2) = 0.3 * world::standard_gravity;
  options.gravity = weight;
  auto workspace = world::plan_scene("box",
                                     {{"low", "-0.015,-0.015,-0.015,-0.015,-0.015,-0.015"},
                                      {"high", "0.015,0.015,0.015,0.015,0.015,0.015"},
                                      {"stiffness", 400.0},
                                      {"damping", 20.0},
                                      {"delay", 2.0}},
                                     period_s, world::Motion::linear, 6);
  ASSERT_TRUE(std::holds_alternative<world::ScenePlan>(workspace));
  options.workspace = std::get<world::ScenePlan>(workspace).task_object;
  Engine engine(options, *device, clock);
  rt::PeriodicSchedule schedule(clock, rt::Nanos{1'000'000});
  device->configure({period_s});
  device->enable();
  schedule.start();
  auto& plant = device->hooks_as<loopback::LoopbackDevice>();
  const auto guarded = [&](int n) {
    AllocationGuard guard;
    for (int i = 0; i < n; ++i) engine.run_cycle(schedule.wait_next());
    return guard.count();
  };
  std::vector<TelemetrySample> buffer(4096);
  for (auto& named : every_task_plan()) {
    SCOPED_TRACE(named.label);
    const std::uint32_t scene_channels =
        static_cast<std::uint32_t>(world::channel_count(named.plan->task_scene));
    engine.publish(std::move(named.plan));
    EXPECT_EQ(guarded(1), 0u) << "the install";
    EXPECT_EQ(guarded(2000), 0u);
    plant.simulator(3).inject_fault(hapticd::drivers::simulation::Fault::nan, 1);
    EXPECT_EQ(guarded(3), 0u);
    EXPECT_EQ(engine.fault(), FaultReason::non_finite_position);
    engine.clear_fault();
    EXPECT_EQ(guarded(1500), 0u);
    const DrainSummary s = drain_all(engine, buffer);
    EXPECT_EQ(s.channel_counts, (std::set<std::uint32_t>{25u + scene_channels}))
        << "6 x 3, 6 feedforwards, the workspace's penetration, the scene's";
    EXPECT_GT(s.nonzero_applied, 100u) << "the workspace wall on x, whose hand crosses its faces";
  }
  device->disable();
}

}  // namespace engine_alloc_test
