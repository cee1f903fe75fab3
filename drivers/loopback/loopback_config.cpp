#include "drivers/loopback/loopback_config.hpp"

#include <stdexcept>

#include "drivers/simulation/key_value.hpp"
#include "world/parameter.hpp"

namespace hapticd::drivers::loopback {

LoopbackConfig loopback_config_from(const DriverParameters& p) {
  const Motion motion = p.text("motion") == "linear" ? Motion::linear : Motion::rotary;
  LoopbackConfig config = LoopbackConfig::defaults(motion);
  auto set = [&p](const char* key, double& field) {
    if (p.given(key)) field = p.number(key);
  };
  config.plant = p.text("plant") == "rigid" ? PlantKind::rigid : PlantKind::two_mass;
  set("mass", config.mass);
  set("damping", config.damping);
  set("coulomb", config.coulomb);
  set("motor_mass", config.two_mass.motor_mass);
  set("body_mass", config.two_mass.body_mass);
  set("motor_damping", config.two_mass.motor_damping);
  set("body_damping", config.two_mass.body_damping);
  set("cable_stiffness", config.two_mass.cable_stiffness);
  set("cable_damping", config.two_mass.cable_damping);
  config.sensor = world::parse_sensor(p.text("sensor")).value_or(world::Sensor::motor);
  set("counts", config.counts);
  set("max_force", config.max_force);
  config.delay = static_cast<int>(p.integer("delay"));
  config.validate();  // ParameterError naming the key
  return config;
}

simulation::HandScript hand_script_from(const DriverParameters& p) {
  const auto entries = p.table("hand");
  std::string text;
  for (const auto& [key, value] : entries) text += (key.empty() ? value : key + "=" + value) + " ";
  if (text.empty()) return {};
  try {
    return simulation::parse_hand_script(text);
  } catch (const ParameterError& e) {
    // Blame the [device.loopback.hand] key at fault if it was written as
    // one, else the hand as a whole (a one-line `hand = "..."`).
    std::string blamed = "hand";
    for (const auto& entry : entries) {
      if (!e.key().empty() && entry.first == e.key()) blamed = "hand." + entry.first;
    }
    throw ParameterError(blamed, std::string("device.loopback.") + e.what());
  }
}

LoopbackConfig parse_loopback_config(std::string_view text) {
  std::map<std::string, ParameterValue, std::less<>> given;
  for (auto& [key, value] : simulation::detail::split_key_values(text, "loopback")) given[key] = value;
  return loopback_config_from(DriverParameters("loopback", loopback_parameters(), given));
}

}  // namespace hapticd::drivers::loopback
