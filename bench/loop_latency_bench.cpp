// Cost of the RT building blocks (ring, mailbox, histogram, statistics).
// The wake-up latency of the loop itself is measured on the real hapticd,
// next to cyclictest: bench/latency.sh.

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

#include "rt/cycle_stats.hpp"
#include "rt/latency_stats.hpp"
#include "rt/loop_timing.hpp"
#include "rt/mailbox.hpp"
#include "rt/spsc_ring.hpp"

using namespace hapticd::rt;

namespace {

struct TelemetryLike {  // the size of one telemetry sample (~150 bytes)
  std::uint64_t cycle;
  double values[18];
};

struct PlanLike {
  std::array<double, 32> coefficients{};
};

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

}  // namespace

BENCHMARK_MAIN();
