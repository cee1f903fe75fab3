#include "world/passivity_scene.hpp"

#include <string>

#include "world/units.hpp"

namespace hapticd::world {

std::string_view to_string(PassivityMode mode) noexcept {
  switch (mode) {
    case PassivityMode::off:
      return "off";
    case PassivityMode::observer:
      return "observer";
    case PassivityMode::controller:
      return "controller";
  }
  return "off";
}

std::optional<PassivityMode> parse_passivity_mode(std::string_view name) noexcept {
  for (const PassivityMode m : {PassivityMode::off, PassivityMode::observer, PassivityMode::controller}) {
    if (name == to_string(m)) return m;
  }
  return std::nullopt;
}

std::vector<ParameterSpec> passivity_parameters(std::optional<Motion> fixed_motion) {
  using P = ParameterSpec;
  namespace d = passivity_defaults;
  const bool rotary = fixed_motion == Motion::rotary;
  std::vector<ParameterSpec> out;
  out.push_back(P::choice("passivity", {"off", "observer", "controller"},
                          "Hannaford & Ryu 2002: off; observer (passivity_energy in telemetry); "
                          "controller (adds the damping that dissipates what the scene generated)")
                    .defaults_to("off"));
  out.push_back(P::number("passivity_max_damping", rotary ? "N m s/rad" : "N s/m",
                          "the most damping the controller adds (what the device can dissipate)")
                    .defaults_to(d::max_damping)
                    .at_least(0.0)
                    .at_most(parameter_range::max_damping));
  out.push_back(P::integer("passivity_window", "periods",
                           "dissipated energy older than this is forgotten (0: never), so a long "
                           "contact builds no credit")
                    .defaults_to(static_cast<double>(d::window_periods))
                    .at_least(0.0)
                    .at_most(static_cast<double>(max_passivity_window)));
  out.push_back(P::number("passivity_velocity_floor", rotary ? "rad/s" : "m/s",
                          "v^2 in the controller's gain is at least this squared (one encoder count a "
                          "period)")
                    .defaults_to(d::velocity_floor)
                    .above(0.0)
                    .at_most(1e3));
  out.push_back(
      P::number("passivity_velocity_deadband", rotary ? "rad/s" : "m/s",
                "the controller does not act while |v| <= this: one encoder count a period is "
                "quantization, and a damper on it chatters (unset: the daemon takes 1.5 encoder counts a "
                "period of its device)")
          .defaults_to(0.0)
          .at_least(0.0)
          .at_most(1e3));
  out.push_back(P::integer("passivity_device_delay", "periods",
                           "periods the device adds before a force acts (CiA 402: the next SYNC), so the "
                           "observer pairs each force with the period it acted in (unset: the daemon takes "
                           "its device's)")
                    .defaults_to(0.0)
                    .at_least(0.0)
                    .at_most(static_cast<double>(max_output_delay)));
  if (!fixed_motion) {  // the wall: units follow the device's motion
    out[1].on_rotary("N m s/rad");
    out[3].on_rotary("rad/s");
    out[4].on_rotary("rad/s");
  }
  return out;
}

PassivityOptions passivity_options(const ParameterSet& parameters, double period_s) {
  PassivityOptions out;
  const auto value = [&](const char* name) { return parameters.find(name); };
  if (const auto it = value("passivity"); it != parameters.end()) {
    if (const auto* text = std::get_if<std::string>(&it->second)) {
      out.mode = parse_passivity_mode(*text).value_or(PassivityMode::off);
    }
  }
  const auto number = [&](const char* name, double fallback) {
    const auto it = value(name);
    const double* x = it == parameters.end() ? nullptr : std::get_if<double>(&it->second);
    return x == nullptr ? fallback : *x;
  };
  out.observer.period_s = period_s;
  out.observer.max_damping = number("passivity_max_damping", passivity_defaults::max_damping);
  out.observer.window_periods = static_cast<std::size_t>(
      number("passivity_window", static_cast<double>(passivity_defaults::window_periods)));
  out.observer.velocity_floor = number("passivity_velocity_floor", passivity_defaults::velocity_floor);
  out.observer.velocity_deadband = number("passivity_velocity_deadband", 0.0);
  out.observer.output_delay_periods = static_cast<std::size_t>(number("passivity_device_delay", 0.0));
  out.observer.control = out.mode == PassivityMode::controller;
  out.observer.correction = PassivityCorrection::measured;
  return out;
}

}  // namespace hapticd::world
