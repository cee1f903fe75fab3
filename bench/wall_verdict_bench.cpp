// The stability gate's wall verdict (Hulin region, largest stiffness,
// damping range) on the control thread: what a param.set on a wall costs
// before it is accepted. Read it against the period the verdict protects:
// counter `per_period` is the verdict's time over a 1 ms period.
// (Was a timed unit test; speed targets live here, the VM stalls its vCPU.)
#include <benchmark/benchmark.h>

#include "analysis/wall_stability.hpp"

namespace {

void BM_WallVerdict(benchmark::State& state) {
  const int delay = static_cast<int>(state.range(0));
  for (auto _ : state) {
    const auto verdict = hapticd::analysis::analyze_wall(0.1, 1e-3, delay, 1000.0, 10.0);
    benchmark::DoNotOptimize(verdict.k_max);
  }
  state.counters["per_period"] =
      benchmark::Counter(1e-3, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

}  // namespace

BENCHMARK(BM_WallVerdict)->Arg(1)->Arg(3)->Arg(8)->ArgName("delay")->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
