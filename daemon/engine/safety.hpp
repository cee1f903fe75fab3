#pragma once
/// \file
/// The safety rules applied around the scene, every period, on the RT thread:
/// finite-value guard, position plausibility (the velocity limit), torque
/// limit, and a latched fault that holds the output at zero until a client
/// clears it. Pure and allocation-free (describe() formats text: non-RT).

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <string>
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
  encoder_jump,         ///< the position stepped beyond max_velocity x interval + one count
  kinematics,           ///< several axes: the joints are out of the linkage's workspace
  kinematics_singular,  ///< several axes: the joints are at a singular configuration of the linkage
};

std::string_view to_string(FaultReason reason) noexcept;

/// Clamps a command to [-limit, limit]; NaN maps to 0 (never forwarded).
constexpr double limit_output(double command, double limit) noexcept {
  if (!(command == command)) return 0.0;  // NaN
  if (command > limit) return limit;
  if (command < -limit) return -limit;
  return command;
}

/// Position plausibility (Force Dimension brakes above a velocity threshold;
/// OpenHaptics reports HD_EXCEEDED_MAX_VELOCITY): a device moves at most
/// max_velocity, so two readings `interval` apart differ by at most
/// max_velocity x interval plus one count (each reading is quantized to a
/// count; their errors add up to less than one). Anything more is an encoder
/// or link fault (a lost count, a corrupted frame, a torn 32-bit read), not
/// motion, and must never be rendered as motion.
struct PositionStepRule {
  double max_velocity = 0.0;  ///< m/s or rad/s; 0: no check
  double resolution = 0.0;    ///< m or rad per encoder count; 0: continuous
  double period_s = 1e-3;     ///< the loop period: the shortest interval counted
  bool rotary = true;         ///< units in the fault's text: rad or m

  bool enabled() const noexcept { return max_velocity > 0.0; }
  /// The largest plausible step between readings `interval_s` apart.
  double step_limit(double interval_s) const noexcept {
    return max_velocity * std::max(interval_s, period_s) + resolution;
  }
};

/// The default max_velocity (docs/config.md, [device] max_velocity): the
/// fastest a hand moves a grip (5 m/s; 50 rad/s) plus what the device's own
/// motor, at torque_limit, gives the free device over 0.1 m or one turn:
/// sqrt(2 torque_limit travel / mass). A mass that is not positive and
/// finite adds nothing (the hand's bound alone).
double default_max_velocity(bool rotary, double mass, double torque_limit) noexcept;

/// The figures of a step the rule refused: what the fault's text says.
struct PositionJump {
  double step = 0.0;        ///< m or rad, new reading minus the previous one
  double limit = 0.0;       ///< m or rad, the rule's limit for this interval
  double interval_s = 0.0;  ///< between the two readings (at least one period)
  int axis = -1;            ///< the axis (0-based) on a device with several; -1 on one
};

/// "encoder jump / velocity limit: the position stepped ... in ... ms ..."
/// with the step in SI and counts (when the resolution is known). Non-RT.
std::string describe(const PositionJump& jump, const PositionStepRule& rule);

/// The rule in one line for --check-config and the start-up banner:
/// "max_velocity 85.4 rad/s (derived from the device), a step over 0.0858 rad
/// (224 counts) in one period of 1 ms latches ...". Non-RT.
std::string describe_rule(const PositionStepRule& rule, bool configured);

/// Applies the rule to consecutive finite readings. A reading without a
/// previous one (the first after start, and after forget(): the engine
/// forgets at a fault clear, where the scene restarts at equilibrium at that
/// very reading) is not checked. Every reading becomes the reference for the
/// next, a refused one too: a position that jumped and stays is refused
/// once, not every period.
class PositionStepGuard {
 public:
  explicit PositionStepGuard(PositionStepRule rule = {}) noexcept : rule_(rule) {}
  /// Checks a finite reading taken at `time_s` (any epoch). True when it is
  /// implausible; then `jump` holds the figures.
  bool implausible(double position, double time_s, PositionJump& jump) noexcept {
    const bool had_previous = has_previous_;
    const double step = position - previous_;
    const double interval = time_s - previous_time_s_;
    previous_ = position;
    previous_time_s_ = time_s;
    has_previous_ = true;
    if (!had_previous || !rule_.enabled()) return false;
    const double limit = rule_.step_limit(interval);
    if (std::abs(step) <= limit) return false;  // a step too big to subtract (inf) is implausible too
    jump = PositionJump{step, limit, std::max(interval, rule_.period_s)};
    return true;
  }
  /// The next reading has no reference (not checked).
  void forget() noexcept { has_previous_ = false; }
  const PositionStepRule& rule() const noexcept { return rule_; }

 private:
  PositionStepRule rule_;
  bool has_previous_ = false;
  double previous_ = 0.0;
  double previous_time_s_ = 0.0;
};

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
