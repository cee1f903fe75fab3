#pragma once
/// \file
/// The gpio-pwm driver's parameters, typed and validated. Every path (GPIO
/// chip, PWM chip, counter) comes from here, so a board's quirks are
/// configuration, not code. Units: SI (N or N m, s), except the PWM period,
/// which the kernel takes in nanoseconds.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "drivers/device_hooks.hpp"
#include "drivers/driver_description.hpp"
#include "drivers/parameter.hpp"

namespace hapticd::drivers::gpio_pwm {

/// A GPIO line by offset on the chip ("17") or by name ("MOTOR_EN"), and
/// whether its active level is low. Unconfigured: neither.
struct LineSpec {
  std::optional<unsigned> offset;
  std::string name;
  bool active_low = false;

  bool configured() const noexcept { return offset.has_value() || !name.empty(); }
  std::string describe() const;  ///< "17", "\"MOTOR_EN\"", or "none"
  friend bool operator==(const LineSpec&, const LineSpec&) = default;
};

/// "" -> unconfigured; all digits -> offset; otherwise a line name (at most
/// 31 characters: the uAPI's 32-byte name field). Throws ParameterError(key).
LineSpec parse_line_spec(std::string_view key, std::string_view text, bool active_low = false);

enum class PositionSource { counter, quadrature };

struct GpioPwmConfig {
  // GPIO character device and lines (all on this one chip: the output lines
  // are one bulk request, so one ioctl per period sets them all).
  std::string chip = "gpiochip0";  ///< path, name, number or label (gpiod_chip_open_lookup)
  std::string consumer = "hapticd";
  LineSpec enable_line;       ///< required: amplifier enable (inactive on disable and fault)
  LineSpec direction_line;    ///< required: active = positive force
  LineSpec fault_line;        ///< optional input: an edge into the active level latches a fault
  LineSpec brake_line;        ///< optional output: active while the amplifier is not enabled
  LineSpec reset_line;        ///< optional output: pulsed active by clear_fault()
  LineSpec charge_pump_line;  ///< optional output: toggled every period (external watchdog)
  LineSpec encoder_a_line;    ///< quadrature inputs when no counter is named
  LineSpec encoder_b_line;

  // PWM channel (/sys/class/pwm).
  std::string pwm_chip = "/sys/class/pwm/pwmchip0";
  unsigned pwm_channel = 0;
  std::uint64_t pwm_period_ns = 50'000;  ///< 20 kHz: above hearing
  bool pwm_inversed = false;             ///< polarity "inversed"

  // Force to duty.
  double force_at_full_duty = 0.0;  ///< N or N m at 100 % duty; required (> 0)
  double max_duty = 0.95;           ///< (0, 1]
  double deadband = 0.0;            ///< N or N m

  // Position.
  std::string counter;         ///< sysfs directory of a counter device, "" = quadrature lines
  unsigned counter_count = 0;  ///< countY under it
  Motion motion = Motion::rotary;
  double counts_per_unit = 16384.0;  ///< counts per revolution (rotary) or per metre (linear), x4
  bool reverse = false;              ///< the encoder counts down for a positive force

  // The device model for the stability gate (the driver cannot measure it).
  double mass = 0.0;     ///< kg (linear) or kg m^2 (rotary): the moving mass or inertia; required
  double damping = 0.0;  ///< N s/m or N m s/rad to ground

  // Timing of non-RT steps.
  double reset_pulse_s = 0.01;    ///< width of the reset pulse
  double export_timeout_s = 1.0;  ///< wait for pwmN/ after export (udev may fix permissions)

  PositionSource position_source() const noexcept {
    return counter.empty() ? PositionSource::quadrature : PositionSource::counter;
  }
  /// Position of one count: rad (rotary) or m (linear).
  double metres_or_radians_per_count() const noexcept;
};

/// Checks ranges and combinations; throws ParameterError naming the key and
/// what is accepted.
void validate(const GpioPwmConfig& config);

/// The typed parameters of [device.gpio-pwm] (README.md, docs/driver-parameters.md).
const std::vector<ParameterSpec>& gpio_pwm_parameters();
/// The configuration from checked parameters; throws ParameterError naming
/// the key for what the table alone cannot check (combinations, line names).
GpioPwmConfig gpio_pwm_config_from(const DriverParameters& parameters);

}  // namespace hapticd::drivers::gpio_pwm
