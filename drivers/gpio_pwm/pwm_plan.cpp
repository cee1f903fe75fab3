#include "drivers/gpio_pwm/pwm_plan.hpp"

namespace hapticd::drivers::gpio_pwm {

std::string_view to_string(PwmAttribute attribute) noexcept {
  return attribute == PwmAttribute::period ? "period" : "duty_cycle";
}

PlanResult plan_pwm_writes(const PwmTiming& current, const PwmTiming& target) noexcept {
  PlanResult result;
  if (!kernel_accepts(target)) return result;
  result.ok = true;
  PwmWritePlan& plan = result.plan;
  const auto add = [&plan](PwmAttribute attribute, std::uint64_t value) {
    plan.writes[plan.count++] = PwmWrite{attribute, value};
  };
  const bool period_changes = current.period_ns != target.period_ns;
  const bool duty_changes = current.duty_ns != target.duty_ns;
  // Growing (or a fresh channel with period 0): (target.period, current.duty)
  // is accepted because current.duty <= current.period <= target.period.
  const bool period_first = target.period_ns >= current.period_ns;
  if (period_first) {
    if (period_changes) add(PwmAttribute::period, target.period_ns);
    if (duty_changes) add(PwmAttribute::duty_cycle, target.duty_ns);
  } else {
    // Shrinking: (current.period, target.duty) is accepted because
    // target.duty <= target.period < current.period.
    if (duty_changes) add(PwmAttribute::duty_cycle, target.duty_ns);
    if (period_changes) add(PwmAttribute::period, target.period_ns);
  }
  return result;
}

}  // namespace hapticd::drivers::gpio_pwm
