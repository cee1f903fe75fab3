#pragma once
/// \file
/// The order in which a PWM channel's sysfs attributes must be written so
/// that the kernel accepts every single write. Pure: no system calls.
///
/// Each write to `period` or `duty_cycle` under /sys/class/pwm/pwmchipN/pwmM
/// is applied on its own (drivers/pwm/sysfs.c: read the state, change one
/// field, pwm_apply_state()), and pwm_apply_state() refuses with EINVAL a
/// state whose period is 0 or whose duty_cycle exceeds its period
/// (drivers/pwm/core.c). So every intermediate state must satisfy
/// 0 < period and duty <= period:
///   - period grows (or stays): write period first, then duty;
///   - period shrinks: write duty first, then period.
/// Unchanged values are not written (one sysfs write is a system call and,
/// on some hardware, a restart of the running PWM period).

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace hapticd::drivers::gpio_pwm {

/// What the kernel holds for one channel, in nanoseconds.
struct PwmTiming {
  std::uint64_t period_ns = 0;
  std::uint64_t duty_ns = 0;
  friend bool operator==(const PwmTiming&, const PwmTiming&) = default;
};

enum class PwmAttribute : std::uint8_t { period, duty_cycle };
std::string_view to_string(PwmAttribute attribute) noexcept;  ///< "period", "duty_cycle"

struct PwmWrite {
  PwmAttribute attribute = PwmAttribute::duty_cycle;
  std::uint64_t value_ns = 0;
  friend bool operator==(const PwmWrite&, const PwmWrite&) = default;
};

/// At most two writes, in the order to issue them.
struct PwmWritePlan {
  std::array<PwmWrite, 2> writes{};
  std::size_t count = 0;
  const PwmWrite* begin() const noexcept { return writes.data(); }
  const PwmWrite* end() const noexcept { return writes.data() + count; }
};

/// A state the kernel accepts: period > 0 and duty <= period.
constexpr bool kernel_accepts(const PwmTiming& t) noexcept {
  return t.period_ns > 0 && t.duty_ns <= t.period_ns;
}

/// The writes that take the channel from `current` to `target`, each
/// intermediate state accepted by the kernel. `current` is what the kernel
/// holds: accepted, or period 0 with duty 0 (a freshly exported channel on
/// most chips). `target` must be accepted (kernel_accepts(target));
/// otherwise the plan is empty and `ok` false.
struct PlanResult {
  PwmWritePlan plan;
  bool ok = false;
};
PlanResult plan_pwm_writes(const PwmTiming& current, const PwmTiming& target) noexcept;

}  // namespace hapticd::drivers::gpio_pwm
