// Cost of the RT building blocks (ring, mailbox, histogram, statistics), and
// a measured 1 ms loop: PeriodicSchedule + RealClock on a SCHED_FIFO thread
// set up by hapticd::daemon::system::configure_realtime(), reporting wake-up latency percentiles as
// counters so bench/cyclictest_compare.sh can put them next to cyclictest's.
//
// Environment for the measured loop:
//   HAPTICD_LOOP_CYCLES     cycles to run (default 5000)
//   HAPTICD_LOOP_PERIOD_US  period in us (default 1000)
//   HAPTICD_LOOP_PRIORITY   SCHED_FIFO priority (default 80, as cyclictest -p80)
//   HAPTICD_LOOP_CPU        pin to this CPU (default: not pinned)

#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "daemon/system/rt_setup.hpp"
#include "rt/cycle_stats.hpp"
#include "rt/latency_stats.hpp"
#include "rt/loop_timing.hpp"
#include "rt/mailbox.hpp"
#include "rt/spsc_ring.hpp"

using namespace hapticd::rt;
using namespace hapticd::daemon::system;

namespace {

struct TelemetryLike {  // the size of one telemetry sample (~150 bytes)
  std::uint64_t cycle;
  double values[18];
};

struct PlanLike {
  std::array<double, 32> coefficients{};
};

long env_long(const char* name, long fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::strtol(v, nullptr, 10) : fallback;
}

void BM_RingPushPop(benchmark::State& state) {
  SpscRing<TelemetryLike> ring(1024);
  TelemetryLike in{}, out{};
  for (auto _ : state) {
    in.cycle++;
    benchmark::DoNotOptimize(ring.try_push(in));
    benchmark::DoNotOptimize(ring.try_pop(out));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_RingPushPop);

// Producer on this thread, consumer draining in bulk on another: cost per
// item actually transferred when the cache lines ping-pong between cores
// (the producer retries when full, so this is throughput, not the drop path).
void BM_RingTransferCrossThread(benchmark::State& state) {
  SpscRing<TelemetryLike> ring(4096);
  std::atomic<bool> stop{false};
  std::thread consumer([&] {
    std::array<TelemetryLike, 64> batch{};
    while (!stop.load(std::memory_order_relaxed)) benchmark::DoNotOptimize(ring.pop_bulk(batch));
  });
  TelemetryLike in{};
  for (auto _ : state) {
    in.cycle++;
    while (!ring.try_push(in)) {
    }
  }
  stop = true;
  consumer.join();
  state.SetItemsProcessed(state.iterations());
  state.counters["full_retries"] = static_cast<double>(ring.dropped());
}
BENCHMARK(BM_RingTransferCrossThread);

// The per-period cost when nothing new was published (the usual case).
void BM_MailboxAcquireIdle(benchmark::State& state) {
  Mailbox<PlanLike> box;
  box.publish(std::make_unique<PlanLike>());
  std::uint64_t cycle = 0;
  for (auto _ : state) benchmark::DoNotOptimize(box.acquire(++cycle));
}
BENCHMARK(BM_MailboxAcquireIdle);

// Full hand-over round trip on one thread: publish (allocates, writer side),
// acquire (RT side: exchange + retire), collect (writer frees).
void BM_MailboxHandOverRoundTrip(benchmark::State& state) {
  Mailbox<PlanLike> box;
  std::uint64_t cycle = 0;
  for (auto _ : state) {
    box.publish(std::make_unique<PlanLike>());
    benchmark::DoNotOptimize(box.acquire(++cycle));
  }
}
BENCHMARK(BM_MailboxHandOverRoundTrip);

void BM_HistogramRecord(benchmark::State& state) {
  auto h = std::make_unique<LatencyHistogram>();
  std::int64_t v = 0;
  for (auto _ : state) {
    v = (v + 7919) % 3'000'000;  // spans linear and log buckets
    h->record(Nanos{v});
  }
  benchmark::DoNotOptimize(h->snapshot().count);
}
BENCHMARK(BM_HistogramRecord);

void BM_CycleStatsRecord(benchmark::State& state) {
  auto stats = std::make_unique<CycleStats>();
  WakeUp w;
  for (auto _ : state) {
    ++w.cycle;
    w.latency = Nanos{static_cast<std::int64_t>(w.cycle % 500) * 1000};
    stats->record(w, Nanos{20'000});
  }
}
BENCHMARK(BM_CycleStatsRecord);

void BM_HistogramSnapshot(benchmark::State& state) {
  auto h = std::make_unique<LatencyHistogram>();
  for (int i = 0; i < 10000; ++i) h->record(Nanos{i * 100});
  for (auto _ : state) benchmark::DoNotOptimize(h->snapshot().percentile(0.99));
}
BENCHMARK(BM_HistogramSnapshot);

// The measured loop. One iteration = the whole run; wall time is reported as
// manual time, latencies as counters (us). Exact percentiles from the raw
// samples, plus the histogram's (what the daemon would report).
void BM_PeriodicLoop(benchmark::State& state) {
  const auto cycles = static_cast<std::size_t>(env_long("HAPTICD_LOOP_CYCLES", 5000));
  const Nanos period{env_long("HAPTICD_LOOP_PERIOD_US", 1000) * 1000};
  hapticd::daemon::system::RtOptions options;
  options.priority = static_cast<int>(env_long("HAPTICD_LOOP_PRIORITY", 80));
  if (const long cpu = env_long("HAPTICD_LOOP_CPU", -1); cpu >= 0) options.cpus = {static_cast<int>(cpu)};

  for (auto _ : state) {
    std::vector<std::int64_t> latencies(cycles);  // allocated before the loop runs
    auto stats = std::make_unique<CycleStats>();
    hapticd::daemon::system::RtSetupReport report;
    std::uint64_t overruns = 0, missed = 0;
    Nanos elapsed{0};
    std::thread rt([&] {
      report = hapticd::daemon::system::configure_realtime(options);
      RealClock clock;
      PeriodicSchedule schedule(clock, period);
      schedule.start();
      for (std::size_t i = 0; i < cycles; ++i) {
        const WakeUp w = schedule.wait_next();
        const Nanos done = clock.now();
        latencies[i] = w.latency.count();
        stats->record(w, done - w.woke);
      }
      overruns = schedule.overruns();
      missed = schedule.missed_periods();
      elapsed = clock.now() - schedule.t0();
    });
    rt.join();
    state.SetIterationTime(std::chrono::duration<double>(elapsed).count());
    if (!report.problems.empty()) state.SetLabel(report.message());

    std::sort(latencies.begin(), latencies.end());
    auto pct = [&](double p) {
      auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(cycles)));
      return static_cast<double>(latencies[std::max<std::size_t>(rank, 1) - 1]) / 1000.0;
    };
    const auto snap = stats->snapshot();
    state.counters["cycles"] = static_cast<double>(cycles);
    state.counters["min_us"] = static_cast<double>(latencies.front()) / 1000.0;
    state.counters["p50_us"] = pct(0.50);
    state.counters["p99_us"] = pct(0.99);
    state.counters["p999_us"] = pct(0.999);
    state.counters["max_us"] = static_cast<double>(latencies.back()) / 1000.0;
    state.counters["hist_p99_us"] = static_cast<double>(snap.latency.percentile(0.99).count()) / 1000.0;
    state.counters["compute_p99_us"] = static_cast<double>(snap.compute.percentile(0.99).count()) / 1000.0;
    state.counters["overruns"] = static_cast<double>(overruns);
    state.counters["missed"] = static_cast<double>(missed);
    state.counters["max_streak"] = static_cast<double>(snap.max_overrun_streak);
    state.counters["sched_fifo"] = report.scheduler_set ? 1.0 : 0.0;
    state.counters["dma_latency"] = report.dma_latency_held ? 1.0 : 0.0;
    state.counters["mlocked"] = report.memory_locked ? 1.0 : 0.0;
  }
}
BENCHMARK(BM_PeriodicLoop)->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
