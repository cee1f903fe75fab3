#pragma once
/// \file
/// Periodic schedule with absolute deadlines t0 + n T (ros2_control's
/// controller_manager sleeping policy, with the skip-ahead rule made explicit).
///
/// Why skip ahead: after a late wake-up (here the host stalls the vCPU for
/// 1-43 ms about twice a second) the loop runs ONE cycle at once, counts the
/// overrun and the periods it missed, and then waits for the next deadline
/// that is still in the future. It never runs a burst of back-to-back cycles
/// to "catch up": a haptic device wants one fresh command now, not forty
/// stale ones.

#include <cstdint>
#include <stdexcept>

#include "rt/clock.hpp"

namespace hapticd::rt {

/// What wait_next() observed for one cycle.
struct WakeUp {
  std::uint64_t cycle = 0;         ///< 1, 2, ... cycles actually run
  std::uint64_t period_index = 0;  ///< n of the deadline t0 + n T this cycle served
  Nanos deadline{0};
  Nanos woke{0};             ///< clock time after the sleep returned
  Nanos latency{0};          ///< woke - deadline (>= 0 with a sane clock)
  std::uint64_t missed = 0;  ///< deadlines skipped after this cycle (0 normally)
  bool overrun = false;      ///< latency >= one period: at least one deadline missed
};

class PeriodicSchedule {
 public:
  static constexpr Nanos min_period{100'000};     // 100 us
  static constexpr Nanos max_period{10'000'000};  // 10 ms

  /// Throws std::invalid_argument if period is outside [100 us, 10 ms].
  PeriodicSchedule(Clock& clock, Nanos period) : clock_(clock), period_(period) {
    if (period < min_period || period > max_period)
      throw std::invalid_argument("PeriodicSchedule: period must be within 100 us .. 10 ms");
  }

  /// Set t0 = now; the first deadline is t0 + T.
  void start() noexcept { start_at(clock_.now()); }
  void start_at(Nanos t0) noexcept {
    t0_ = t0;
    next_index_ = 1;
    cycles_ = overruns_ = missed_ = 0;
  }

  /// Sleep to the next deadline and account for how late the wake-up was.
  /// Allocation-free; one clock sleep and one clock read.
  WakeUp wait_next() noexcept {
    WakeUp w;
    w.period_index = next_index_;
    w.deadline = deadline_of(next_index_);
    clock_.sleep_until(w.deadline);
    w.woke = clock_.now();
    w.latency = w.woke - w.deadline;
    w.cycle = ++cycles_;
    // Next deadline: the first t0 + n T strictly after the wake-up time.
    const std::int64_t late_periods = w.latency.count() >= 0 ? w.latency.count() / period_.count() : 0;
    w.missed = static_cast<std::uint64_t>(late_periods);
    w.overrun = w.missed > 0;
    if (w.overrun) {
      ++overruns_;
      missed_ += w.missed;
    }
    next_index_ += 1 + w.missed;
    return w;
  }

  Nanos period() const noexcept { return period_; }
  Nanos t0() const noexcept { return t0_; }
  Nanos deadline_of(std::uint64_t n) const noexcept { return t0_ + period_ * static_cast<std::int64_t>(n); }
  /// Index of the deadline the next wait_next() will sleep to.
  std::uint64_t next_index() const noexcept { return next_index_; }
  std::uint64_t cycles() const noexcept { return cycles_; }
  std::uint64_t overruns() const noexcept { return overruns_; }
  std::uint64_t missed_periods() const noexcept { return missed_; }

 private:
  Clock& clock_;
  Nanos period_;
  Nanos t0_{0};
  std::uint64_t next_index_ = 1;
  std::uint64_t cycles_ = 0;
  std::uint64_t overruns_ = 0;
  std::uint64_t missed_ = 0;
};

}  // namespace hapticd::rt
