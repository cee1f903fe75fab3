#include "drivers/planned.hpp"

namespace hapticd::drivers::planned {

namespace {

using P = ParameterSpec;

/// What every real device needs for the stability gate (DRIVERS.md): the
/// device cannot know its own moving mass, so the config says it.
std::vector<ParameterSpec> common() {
  return {P::choice("motion", {"rotary", "linear"},
                    "rotary (rad, N m, kg m^2) or linear (m, N, kg): the units of everything below")
              .defaults_to("rotary"),
          P::number("mass", "kg m^2 | kg", "moving inertia (rotary) or mass (linear) the stability gate uses")
              .above(0.0)
              .at_most(1e6),
          P::number("damping", "N m s/rad | N s/m", "viscous damping to ground the stability gate uses")
              .defaults_to(0.0)
              .at_least(0.0)
              .at_most(1e6)};
}

DriverDescription planned(std::string name, std::string summary, std::vector<ParameterSpec> specific) {
  std::vector<ParameterSpec> all = common();
  for (auto& p : specific) all.push_back(std::move(p));
  return {std::move(name), std::move(summary), false, std::move(all), {}};
}

P counts_per_unit() {
  return P::number("counts_per_unit", "1/rev | 1/m", "encoder counts per revolution or per metre").above(0.0);
}

}  // namespace

DriverDescription gpio_pwm_driver() {
  return planned("gpio-pwm", "GPIO lines and kernel PWM through libgpiod and sysfs (Hapkit-class rigs)",
                 {P::text("chip", "GPIO chip of the lines").defaults_to("/dev/gpiochip0"),
                  P::integer("direction_line", "", "direction output line offset").at_least(0).at_most(1023),
                  P::integer("enable_line", "", "enable output line offset").at_least(0).at_most(1023),
                  P::text("pwm_chip", "PWM chip directory").defaults_to("/sys/class/pwm/pwmchip0"),
                  P::integer("pwm_channel", "", "PWM channel").defaults_to(0.0).at_least(0).at_most(1023),
                  counts_per_unit(),
                  P::number("force_at_full_duty", "N m | N", "force or torque at 100 % duty").above(0.0)});
}

}  // namespace hapticd::drivers::planned
