// Cost of one scene step() for every scene variant and integrator, the Eigen
// fixed-size 2x2 mat-vec as the reference, the accuracy/cost trade-off of
// the integrators on the Freudenberg 2.1 wheel, and the one-off cost of
// discretizing when parameters change.

#include <array>
#include <cmath>
#include <cstddef>

#include <benchmark/benchmark.h>
#include <Eigen/Dense>

#include "world/any_scene.hpp"
#include "world/integrator.hpp"
#include "world/scene_catalog.hpp"

namespace {

using namespace hapticd::world;

constexpr double period = 1e-3;
constexpr std::size_t input_count = 1024;  // power of two

/// A slow sine around 0 (crosses the wall surface and the relay reference).
const std::array<double, input_count>& inputs() {
  static const std::array<double, input_count> values = [] {
    std::array<double, input_count> v{};
    for (std::size_t i = 0; i < input_count; ++i) v[i] = 0.01 * std::sin(0.0123 * static_cast<double>(i));
    return v;
  }();
  return values;
}

template <class S>
void run(benchmark::State& state, S scene) {
  const auto& in = inputs();
  scene.reset(in[0]);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(scene.step(in[i]));
    i = (i + 1) & (input_count - 1);
  }
  state.SetItemsProcessed(state.iterations());
}

SpringParameters spring(double damping, Integrator integrator) {
  return {scene_defaults::wheel_stiffness, scene_defaults::wheel_inertia, damping, integrator};
}

template <SpringDamping D>
void BM_Spring(benchmark::State& state) {
  const auto integrator = all_integrators[static_cast<std::size_t>(state.range(0))];
  state.SetLabel(std::string(to_string(integrator)));
  const double b = D == SpringDamping::none ? 0.0 : period * scene_defaults::wheel_stiffness;
  run(state, SpringScene<D>(spring(b, integrator), period));
}
BENCHMARK_TEMPLATE(BM_Spring, SpringDamping::none)->DenseRange(0, 4)->ArgName("integrator");
BENCHMARK_TEMPLATE(BM_Spring, SpringDamping::absolute)->DenseRange(0, 4)->ArgName("integrator");
BENCHMARK_TEMPLATE(BM_Spring, SpringDamping::relative)->DenseRange(0, 4)->ArgName("integrator");

template <WallDamping Dm, WallDelay Dl>
void BM_Wall(benchmark::State& state) {
  WallParameters p;
  p.stiffness = scene_defaults::wall_stiffness;
  p.damping = Dm == WallDamping::none ? 0.0 : scene_defaults::wall_damping;
  p.delay_samples = Dl == WallDelay::none ? 0 : 1;
  p.position = 0.0;
  run(state, WallScene<Dm, Dl>(p, period));
}
BENCHMARK_TEMPLATE(BM_Wall, WallDamping::none, WallDelay::none);
BENCHMARK_TEMPLATE(BM_Wall, WallDamping::none, WallDelay::samples);
BENCHMARK_TEMPLATE(BM_Wall, WallDamping::backward_difference, WallDelay::none);
BENCHMARK_TEMPLATE(BM_Wall, WallDamping::backward_difference, WallDelay::samples);

void BM_RelayPlain(benchmark::State& state) {
  run(state, RelayScene<RelayHysteresis::none>({1.0, 0.0, 0.0}));
}
void BM_RelayBand(benchmark::State& state) {
  run(state, RelayScene<RelayHysteresis::band>({1.0, 0.002, 0.0}));
}
void BM_Free(benchmark::State& state) { run(state, FreeScene{}); }
BENCHMARK(BM_RelayPlain);
BENCHMARK(BM_RelayBand);
BENCHMARK(BM_Free);

/// The same step through the AnyScene variant (what the RT loop calls).
void BM_AnySceneWall(benchmark::State& state) {
  PlanResult r = plan_scene("wall", {}, period);
  AnyScene scene = std::get<ScenePlan>(std::move(r)).scene_object;
  const auto& in = inputs();
  reset(scene, in[0]);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(step(scene, in[i]));
    i = (i + 1) & (input_count - 1);
  }
}
void BM_AnySceneSpringRelative(benchmark::State& state) {
  PlanResult r = plan_scene("spring-wheel", {{"damping", "auto"}}, period);
  AnyScene scene = std::get<ScenePlan>(std::move(r)).scene_object;
  const auto& in = inputs();
  reset(scene, in[0]);
  std::size_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(step(scene, in[i]));
    i = (i + 1) & (input_count - 1);
  }
}
BENCHMARK(BM_AnySceneWall);
BENCHMARK(BM_AnySceneSpringRelative);

/// Reference: x = A x + B u with Eigen fixed-size types.
void BM_Eigen2x2MatVec(benchmark::State& state) {
  Eigen::Matrix2d a;
  a << 0.99998, 0.001, -0.0395, 0.99998;
  const Eigen::Vector2d b(2e-5, 0.0395);
  Eigen::Vector2d x(0.0, 0.0);
  const auto& in = inputs();
  std::size_t i = 0;
  for (auto _ : state) {
    x = a * x + b * in[i];
    benchmark::DoNotOptimize(x);
    i = (i + 1) & (input_count - 1);
  }
}
BENCHMARK(BM_Eigen2x2MatVec);

/// Accuracy vs cost: max |F - F_exact| / (k z0) over a 10 s step response of
/// the Freudenberg wheel (b = 0), T in {0.1, 1, 10} ms, per integrator,
/// against the closed form F(t) = -k z0 cos(w_n t) (Freudenberg 2.4, the
/// torque on the device), so the exact integrator's error is measured too.
void BM_IntegratorAccuracy(benchmark::State& state) {
  const auto integrator = all_integrators[static_cast<std::size_t>(state.range(0))];
  const double t = static_cast<double>(state.range(1)) * 1e-4;
  state.SetLabel(std::string(to_string(integrator)) + " T=" + std::to_string(t * 1e3) + "ms");
  const double k = scene_defaults::wheel_stiffness;
  const double z0 = hapticd::world::units::deg_to_rad(45.0);
  const double wn = std::sqrt(k / scene_defaults::wheel_inertia);
  SpringScene<SpringDamping::none> scene(spring(0.0, integrator), t);
  scene.reset(0.0);
  const auto steps = static_cast<long>(std::lround(10.0 / t));
  double worst = 0.0;
  for (long n = 0; n <= steps; ++n) {
    const double exact = -k * z0 * std::cos(wn * static_cast<double>(n) * t);
    worst = std::max(worst, std::abs(scene.step(z0) - exact));
  }
  state.counters["max_error_rel"] = worst / (k * z0);
  // Time per step of this integrator on the held step.
  scene.reset(0.0);
  for (auto _ : state) benchmark::DoNotOptimize(scene.step(z0));
  // Cost of simulating one second of the world: CPU time / simulated time.
  state.counters["cpu_s_per_sim_s"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * t, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_IntegratorAccuracy)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {1, 10, 100}})
    ->ArgNames({"integrator", "T_1e-4s"});

/// One-off cost when parameters change (control thread, not RT): the
/// discretization of the relative-damping spring for each integrator.
void BM_Discretize(benchmark::State& state) {
  const auto integrator = all_integrators[static_cast<std::size_t>(state.range(0))];
  state.SetLabel(std::string(to_string(integrator)));
  const auto model = spring_continuous_model(spring(0.01, integrator), SpringDamping::relative);
  for (auto _ : state) benchmark::DoNotOptimize(discretize(model, period, integrator));
}
BENCHMARK(BM_Discretize)->DenseRange(0, 4)->ArgName("integrator");

}  // namespace

BENCHMARK_MAIN();
