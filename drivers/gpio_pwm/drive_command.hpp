#pragma once
/// \file
/// Sign/magnitude split of a force command for a PWM + direction H-bridge
/// (the "pwm/dir" output of LinuxCNC's pwmgen): the sign selects the
/// direction line, the magnitude the duty cycle. Pure: no system calls.
///
///   |F| <= deadband            -> duty 0, direction unchanged (no chatter
///                                 of the direction line around zero)
///   otherwise                   -> duty = min(|F| / force_at_full_duty, max_duty) * period
///                                 direction = sign(F)
///
/// The deadband is in force units (N or N m), like the command; the duty is
/// rounded to the nearest nanosecond and never exceeds the period.

#include <cstdint>

namespace hapticd::drivers::gpio_pwm {

struct DriveScaling {
  double force_at_full_duty = 1.0;  ///< N or N m the amplifier delivers at 100 % duty (> 0)
  double max_duty = 1.0;            ///< fraction of the period, (0, 1]
  double deadband = 0.0;            ///< N or N m, >= 0
  std::uint64_t period_ns = 50'000;
};

struct DriveCommand {
  bool positive = true;  ///< direction: true = the direction line says "positive force"
  std::uint64_t duty_ns = 0;
  bool saturated = false;  ///< the magnitude was limited by max_duty
  friend bool operator==(const DriveCommand&, const DriveCommand&) = default;
};

/// `previous_positive` is the direction currently on the line (kept inside
/// the deadband). A non-finite force gives duty 0 and `valid` false.
struct DriveResult {
  DriveCommand command;
  bool valid = true;
};
DriveResult split_force(double force, const DriveScaling& scaling, bool previous_positive) noexcept;

/// The force a command delivers (the inverse of split_force outside the
/// deadband, up to the nanosecond rounding): what the simulated amplifier
/// applies and what telemetry can report.
double force_of(const DriveCommand& command, const DriveScaling& scaling) noexcept;

}  // namespace hapticd::drivers::gpio_pwm
