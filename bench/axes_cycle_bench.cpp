// One whole RT cycle of the engine (Engine::run_cycle: read, scene, safety,
// write, telemetry push) on the loopback, one axis against a Cartesian
// stage of 2 and 6 axes (issue 22: every axis read and written in one call,
// tau = J^T F with one common saturation factor). VirtualClock: no sleeping;
// the ring is drained outside the timing.

#include <benchmark/benchmark.h>

#include <memory>
#include <string>
#include <vector>

#include "daemon/engine/engine.hpp"
#include "drivers/device.hpp"
#include "drivers/loopback/loopback_device.hpp"
#include "rt/clock.hpp"
#include "rt/loop_timing.hpp"
#include "world/scene_catalog.hpp"

namespace {

namespace loopback = hapticd::drivers::loopback;
namespace world = hapticd::world;
using hapticd::daemon::TelemetrySample;
using hapticd::daemon::engine::Engine;
using hapticd::daemon::engine::EngineOptions;
using hapticd::daemon::engine::LoopPlan;

constexpr double period_s = 1e-3;

/// N linear axes held on sines through the scene's surface (1 axis: today's loopback).
loopback::LoopbackStage stage(int axes) {
  loopback::LoopbackStage s;
  for (int i = 0; i < axes; ++i) {
    s.axes.push_back(loopback::LoopbackConfig::defaults(hapticd::drivers::Motion::linear));
    s.hands.push_back(hapticd::drivers::simulation::parse_hand_script(
        "mode=hold trajectory=sine amplitude=0.01 frequency=" + std::to_string(1 + i)));
  }
  return s;
}

void run_cycles(benchmark::State& state, int axes, const std::string& scene, const world::ParameterSet& p) {
  hapticd::rt::VirtualClock clock;
  hapticd::drivers::Device device("loopback", std::make_unique<loopback::LoopbackDevice>(stage(axes)));
  EngineOptions options;
  options.realtime.priority = 0;
  options.realtime.lock_memory = false;
  options.realtime.hold_dma_latency = false;
  options.telemetry_capacity = 1u << 13;
  Engine engine(options, device, clock);
  hapticd::rt::PeriodicSchedule schedule(clock, hapticd::rt::Nanos{1'000'000});
  device.configure({period_s});
  device.enable();
  schedule.start();
  auto planned =
      std::get<world::ScenePlan>(world::plan_scene(scene, p, period_s, world::Motion::linear, axes));
  auto plan = std::make_unique<LoopPlan>();
  plan->scene = planned.scene_object;
  plan->task_scene = planned.task_object;
  plan->torque_limit = 5.0;
  engine.publish(std::move(plan));
  std::vector<TelemetrySample> drained(1u << 13);
  std::size_t since_drain = 0;
  for (auto _ : state) {
    engine.run_cycle(schedule.wait_next());
    if (++since_drain == 4096) {
      state.PauseTiming();
      while (engine.drain(drained) > 0) {
      }
      since_drain = 0;
      state.ResumeTiming();
    }
  }
  device.disable();
}

void BM_CycleOneAxisWall(benchmark::State& state) {
  run_cycles(state, 1, "wall", {{"stiffness", 500.0}, {"damping", 2.0}, {"delay", 1.0}});
}
BENCHMARK(BM_CycleOneAxisWall);

void BM_CycleTwoAxesPlaneWall(benchmark::State& state) {
  run_cycles(state, 2, "plane-wall",
             {{"normal", "1,1"}, {"stiffness", 500.0}, {"damping", 2.0}, {"delay", 1.0}});
}
BENCHMARK(BM_CycleTwoAxesPlaneWall);

void BM_CycleSixAxesPlaneWall(benchmark::State& state) {
  run_cycles(state, 6, "plane-wall",
             {{"normal", "1,1,1,1,1,1"}, {"stiffness", 500.0}, {"damping", 2.0}, {"delay", 1.0}});
}
BENCHMARK(BM_CycleSixAxesPlaneWall);

void BM_CycleSixAxesBox(benchmark::State& state) {
  run_cycles(state, 6, "box",
             {{"low", "-0.005,-0.005,-0.005,-0.005,-0.005,-0.005"},
              {"high", "0.005,0.005,0.005,0.005,0.005,0.005"},
              {"stiffness", 500.0},
              {"damping", 2.0},
              {"delay", 1.0}});
}
BENCHMARK(BM_CycleSixAxesBox);

}  // namespace

BENCHMARK_MAIN();
