#pragma once
/// \file
/// Per-loop statistics the RT loop updates once per cycle, allocation-free:
/// cycle count, overruns, missed periods, the current and longest streak of
/// consecutive overruns (the safety layer zeroes the output on a streak), and
/// histograms of wake-up latency and compute time. Counters are single-writer
/// single-writer atomics behind a seqlock, so snapshot() from a non-RT thread is
/// consistent and never blocks the loop. Each histogram has its own seqlock:
/// a snapshot's histogram totals may differ from `cycles` by the one cycle
/// being recorded while it was taken.

#include <atomic>
#include <cstdint>

#include "rt/latency_stats.hpp"
#include "rt/loop_timing.hpp"
#include "rt/seqlock.hpp"

namespace hapticd::rt {

class CycleStats {
 public:
  struct Snapshot {
    std::uint64_t cycles = 0;
    std::uint64_t overruns = 0;
    std::uint64_t missed_periods = 0;
    std::uint64_t overrun_streak = 0;  ///< consecutive overruns ending at the last cycle
    std::uint64_t max_overrun_streak = 0;
    HistogramSnapshot latency;
    HistogramSnapshot compute;
  };

  /// RT thread, once per cycle: the schedule's wake-up and the time the cycle
  /// spent computing (read + step + write).
  void record(const WakeUp& w, Nanos compute) noexcept {
    version_.write_begin();
    single_writer_add(cycles_, std::uint64_t{1});
    if (w.overrun) {
      single_writer_add(overruns_, std::uint64_t{1});
      single_writer_add(missed_, w.missed);
      const std::uint64_t s = streak_.load(std::memory_order_relaxed) + 1;
      seq_store(streak_, s);
      if (s > max_streak_.load(std::memory_order_relaxed)) seq_store(max_streak_, s);
    } else {
      seq_store(streak_, 0);
    }
    version_.write_end();
    latency_.record(w.latency);
    compute_.record(compute);
  }

  /// RT thread (the single writer): start the statistics afresh (stats.reset,
  /// one measurement slice of bench/latency.sh). The current overrun streak
  /// is kept: it is the safety rule's state, not a statistic.
  void reset() noexcept {
    version_.write_begin();
    seq_store(cycles_, 0);
    seq_store(overruns_, 0);
    seq_store(missed_, 0);
    seq_store(max_streak_, streak_.load(std::memory_order_relaxed));
    version_.write_end();
    latency_.reset();
    compute_.reset();
  }

  /// RT thread reads its own streak to decide the configured consequence.
  std::uint64_t overrun_streak() const noexcept { return streak_.load(std::memory_order_relaxed); }

  /// Any thread. Allocates.
  Snapshot snapshot() const {
    Snapshot s;
    version_.read([&] {
      s.cycles = seq_load(cycles_);
      s.overruns = seq_load(overruns_);
      s.missed_periods = seq_load(missed_);
      s.overrun_streak = seq_load(streak_);
      s.max_overrun_streak = seq_load(max_streak_);
    });
    s.latency = latency_.snapshot();
    s.compute = compute_.snapshot();
    return s;
  }

  const LatencyHistogram& latency() const noexcept { return latency_; }
  const LatencyHistogram& compute() const noexcept { return compute_; }

 private:
  SeqlockVersion version_;
  std::atomic<std::uint64_t> cycles_{0};
  std::atomic<std::uint64_t> overruns_{0};
  std::atomic<std::uint64_t> missed_{0};
  std::atomic<std::uint64_t> streak_{0};
  std::atomic<std::uint64_t> max_streak_{0};
  LatencyHistogram latency_;
  LatencyHistogram compute_;
};

}  // namespace hapticd::rt
