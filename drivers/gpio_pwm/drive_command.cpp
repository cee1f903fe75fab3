#include "drivers/gpio_pwm/drive_command.hpp"

#include <algorithm>
#include <cmath>

namespace hapticd::drivers::gpio_pwm {

DriveResult split_force(double force, const DriveScaling& scaling, bool previous_positive) noexcept {
  DriveResult result;
  result.command.positive = previous_positive;
  if (!std::isfinite(force)) {
    result.valid = false;
    return result;
  }
  const double magnitude = std::fabs(force);
  if (magnitude <= scaling.deadband) return result;
  result.command.positive = force > 0.0;
  double fraction = magnitude / scaling.force_at_full_duty;
  if (fraction > scaling.max_duty) {
    fraction = scaling.max_duty;
    result.command.saturated = true;
  }
  const double period = static_cast<double>(scaling.period_ns);
  const double duty = std::min(std::round(fraction * period), period);
  result.command.duty_ns = static_cast<std::uint64_t>(duty);
  return result;
}

double force_of(const DriveCommand& command, const DriveScaling& scaling) noexcept {
  if (scaling.period_ns == 0) return 0.0;
  const double fraction = static_cast<double>(command.duty_ns) / static_cast<double>(scaling.period_ns);
  const double magnitude = fraction * scaling.force_at_full_duty;
  return command.positive ? magnitude : -magnitude;
}

}  // namespace hapticd::drivers::gpio_pwm
