#pragma once
/// \file
/// The time source of the RT loop. One seam, two implementations:
/// RealClock sleeps on CLOCK_MONOTONIC to absolute deadlines (measured here:
/// matches cyclictest at p50, timerfd woke 8-18 us later); VirtualClock jumps
/// to the deadline at once, so tests run minutes of simulated time in
/// milliseconds, deterministically, and can inject stalls.

#include <chrono>
#include <cstdint>

namespace hapticd::rt {

/// Time since an arbitrary epoch (CLOCK_MONOTONIC's for RealClock).
using Nanos = std::chrono::nanoseconds;

class Clock {
 public:
  virtual ~Clock() = default;
  virtual Nanos now() noexcept = 0;
  /// Block until now() >= deadline (returns at once if it already is).
  virtual void sleep_until(Nanos deadline) noexcept = 0;
};

/// CLOCK_MONOTONIC + clock_nanosleep(TIMER_ABSTIME), retried on EINTR.
/// Absolute deadlines: a late wake-up never shifts the following ones.
class RealClock final : public Clock {
 public:
  Nanos now() noexcept override;
  void sleep_until(Nanos deadline) noexcept override;
};

/// Simulated time. sleep_until() sets now = max(now, deadline) instantly.
/// advance() models compute time; stall_next_sleep() models a late wake-up
/// (the host stalling the vCPU, a higher-priority task).
class VirtualClock final : public Clock {
 public:
  explicit VirtualClock(Nanos start = Nanos{0}) noexcept : now_(start) {}
  Nanos now() noexcept override { return now_; }
  void sleep_until(Nanos deadline) noexcept override {
    if (deadline > now_) now_ = deadline;
    now_ += pending_stall_;
    pending_stall_ = Nanos{0};
    ++sleeps_;
  }
  void advance(Nanos d) noexcept { now_ += d; }
  /// The next sleep_until() wakes `d` after its deadline (or after now).
  void stall_next_sleep(Nanos d) noexcept { pending_stall_ = d; }
  std::uint64_t sleeps() const noexcept { return sleeps_; }

 private:
  Nanos now_;
  Nanos pending_stall_{0};
  std::uint64_t sleeps_ = 0;
};

}  // namespace hapticd::rt
