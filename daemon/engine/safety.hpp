#pragma once
/// \file
/// The safety rules applied after the scene, every period, on the RT thread:
/// finite-value guard, torque limit, and a latched fault that holds the
/// output at zero until a client clears it. Pure and allocation-free.

#include <atomic>
#include <cmath>
#include <cstdint>
#include <string_view>

namespace hapticd::daemon::engine {

/// Why the output is held at zero. The first reason latched wins.
enum class FaultReason : std::uint8_t {
  none = 0,
  estop,                ///< a client asked for an emergency stop
  non_finite_position,  ///< the device returned NaN or Inf
  non_finite_command,   ///< the scene produced NaN or Inf
  device_fault,         ///< the driver reported a device-side fault
  read_error_streak,    ///< too many consecutive read errors
  write_error,          ///< the driver could not apply the output
  overrun_streak,       ///< too many consecutive late cycles
};

std::string_view to_string(FaultReason reason) noexcept;

/// Clamps a command to [-limit, limit]; NaN maps to 0 (never forwarded).
constexpr double limit_output(double command, double limit) noexcept {
  if (!(command == command)) return 0.0;  // NaN
  if (command > limit) return limit;
  if (command < -limit) return -limit;
  return command;
}

/// A fault latched by the RT thread (or by estop from the control thread)
/// and cleared only from the control thread. Lock-free.
class FaultLatch {
 public:
  /// Latches `reason` unless a fault is already latched. Returns true if this call latched it.
  bool latch(FaultReason reason) noexcept {
    auto expected = static_cast<std::uint8_t>(FaultReason::none);
    return state_.compare_exchange_strong(expected, static_cast<std::uint8_t>(reason),
                                          std::memory_order_acq_rel);
  }
  void clear() noexcept {
    state_.store(static_cast<std::uint8_t>(FaultReason::none), std::memory_order_release);
  }
  FaultReason reason() const noexcept {
    return static_cast<FaultReason>(state_.load(std::memory_order_acquire));
  }
  bool latched() const noexcept { return reason() != FaultReason::none; }

 private:
  std::atomic<std::uint8_t> state_{static_cast<std::uint8_t>(FaultReason::none)};
};

/// Counts consecutive events and says when a configured streak is reached
/// (limit 0 = never).
class StreakCounter {
 public:
  explicit StreakCounter(std::uint32_t limit = 0) noexcept : limit_(limit) {}
  /// Records one period; returns true when the streak reaches the limit.
  bool record(bool event) noexcept {
    streak_ = event ? streak_ + 1 : 0;
    return limit_ != 0 && streak_ >= limit_;
  }
  std::uint32_t streak() const noexcept { return streak_; }

 private:
  std::uint32_t limit_;
  std::uint32_t streak_ = 0;
};

}  // namespace hapticd::daemon::engine
