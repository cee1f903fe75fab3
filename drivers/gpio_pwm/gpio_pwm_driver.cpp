// The gpio-pwm driver's description (drivers/driver_description.hpp): its
// typed parameters and the factory of its hooks.
#include "drivers/gpio_pwm/gpio_pwm_config.hpp"
#include "drivers/gpio_pwm/gpio_pwm_device.hpp"
#include "world/parameter.hpp"

namespace hapticd::drivers::gpio_pwm {
namespace {

using P = ParameterSpec;
namespace range = world::parameter_range;

P line(const char* name, const char* help) { return P::text(name, help).defaults_to(""); }
P active_low(const char* name, const char* what) {
  return P::boolean(name, std::string("the ") + what + " line is active low").defaults_to(false);
}

std::vector<ParameterSpec> make_parameters() {
  return {
      motion_parameter(),
      mass_parameter(),
      damping_parameter(),
      P::text("chip", "GPIO chip of every line: path, name, number or label (gpiod_chip_open_lookup)")
          .defaults_to("gpiochip0"),
      P::text("consumer", "label the lines are requested under (shown by gpioinfo)").defaults_to("hapticd"),
      P::text("enable_line",
              "amplifier enable output: line offset or name; inactive while disabled or faulted"),
      active_low("enable_active_low", "enable"),
      P::text("direction_line", "H-bridge direction output: line offset or name; active = positive force"),
      active_low("direction_active_low", "direction"),
      line("fault_line", "amplifier fault input (edges latch a fault): line offset or name, \"\" for none"),
      active_low("fault_active_low", "fault"),
      line("brake_line", "brake output, applied while not enabled or faulted: offset or name, \"\" for none"),
      active_low("brake_active_low", "brake"),
      line("reset_line", "amplifier reset output, pulsed by fault clear: offset or name, \"\" for none"),
      active_low("reset_active_low", "reset"),
      line(
          "charge_pump_line",
          "output toggled every period for an external watchdog (README: the dead-man): offset or name, \"\" "
          "for none"),
      line("encoder_a_line", "quadrature input A when no counter is named: offset or name"),
      active_low("encoder_a_active_low", "encoder A"),
      line("encoder_b_line", "quadrature input B when no counter is named: offset or name"),
      active_low("encoder_b_active_low", "encoder B"),
      P::text("pwm_chip", "sysfs directory of the PWM chip").defaults_to("/sys/class/pwm/pwmchip0"),
      P::integer("pwm_channel", "", "PWM channel on the chip").defaults_to(0.0).at_least(0).at_most(1023),
      P::duration("pwm_period", "PWM period (20 kHz: above hearing)")
          .defaults_to(50e-6)
          .at_least(1e-6)
          .at_most(1.0),
      P::boolean("pwm_inversed", "PWM polarity \"inversed\" (the bridge's PWM input is active low)")
          .defaults_to(false),
      P::number("force_at_full_duty", "N m | N", "force or torque the amplifier delivers at 100 % duty")
          .above(0.0)
          .at_most(range::max_force),
      P::number("max_duty", "", "largest duty cycle, a fraction of the period")
          .defaults_to(0.95)
          .above(0.0)
          .at_most(1.0),
      P::number("deadband", "N m | N", "commands up to this size give duty 0 (direction held)")
          .defaults_to(0.0)
          .at_least(0.0)
          .at_most(range::max_force),
      P::text("counter",
              "sysfs directory of a kernel counter (/sys/bus/counter/devices/counterN), \"\" to decode "
              "encoder_a_line/encoder_b_line")
          .defaults_to(""),
      P::integer("counter_count", "", "countY of the counter").defaults_to(0.0).at_least(0).at_most(1023),
      P::number("counts_per_unit", "1/rev | 1/m", "encoder counts per revolution or per metre (x4)")
          .defaults_to(16384.0)
          .above(0.0)
          .at_most(1e12),
      P::boolean("reverse", "the encoder counts down for a positive force").defaults_to(false),
      P::duration("reset_pulse", "width of the reset pulse").defaults_to(0.01).at_least(1e-6).at_most(1.0),
      P::duration("export_timeout", "wait for pwmN/ after exporting the channel (udev may set permissions)")
          .defaults_to(1.0)
          .above(0.0)
          .at_most(10.0),
  };
}

}  // namespace

const std::vector<ParameterSpec>& gpio_pwm_parameters() {
  static const std::vector<ParameterSpec> parameters = make_parameters();
  return parameters;
}

DriverDescription gpio_pwm_driver() {
  return {"gpio-pwm",
          "GPIO lines (libgpiod 1.6) and a kernel PWM channel driving an H-bridge, position from a kernel "
          "counter "
          "or two encoder lines (Hapkit-class rigs)",
          true, gpio_pwm_parameters(), [](const DriverParameters& p) -> std::unique_ptr<DeviceHooks> {
            return std::make_unique<GpioPwmDevice>(gpio_pwm_config_from(p));
          }};
}

}  // namespace hapticd::drivers::gpio_pwm
