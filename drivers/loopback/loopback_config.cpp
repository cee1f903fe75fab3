#include "drivers/loopback/loopback_config.hpp"

#include <cmath>
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

std::vector<double> per_axis_numbers(std::string_view key, std::string_view text, int count, double low,
                                     double high, std::string_view unit) {
  const auto fail = [&] {
    throw ParameterError(std::string(key),
                         "loopback: " + std::string(key) + " = \"" + std::string(text) +
                             "\" is not accepted; accepted: " + std::to_string(count) +
                             " comma-separated numbers from " + to_text(ParameterValue(low)) + " to " +
                             to_text(ParameterValue(high)) + " (" + std::string(unit) + "), one per axis");
  };
  std::vector<double> out;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t end = std::min(text.find(',', begin), text.size());
    std::string item(text.substr(begin, end - begin));
    std::size_t used = 0;
    double value = 0.0;
    try {
      value = std::stod(item, &used);
    } catch (const std::exception&) {
      fail();
    }
    while (used < item.size() && item[used] == ' ') ++used;
    if (used != item.size() || !std::isfinite(value) || value < low || value > high) fail();
    out.push_back(value);
    begin = end + 1;
  }
  if (static_cast<int>(out.size()) != count) fail();
  return out;
}

namespace {

/// The hands of a stage: `hands` (one script per axis, ';' between them),
/// else the `hand` table for every axis.
std::vector<simulation::HandScript> stage_hands(const DriverParameters& p, int count) {
  if (!p.given("hands"))
    return std::vector<simulation::HandScript>(static_cast<std::size_t>(count), hand_script_from(p));
  const std::string& text = p.text("hands");
  std::vector<simulation::HandScript> out;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t end = std::min(text.find(';', begin), text.size());
    try {
      out.push_back(simulation::parse_hand_script(text.substr(begin, end - begin)));
    } catch (const std::invalid_argument& e) {
      throw ParameterError("hands",
                           "device.loopback.hands, axis " + std::to_string(out.size() + 1) + ": " + e.what());
    }
    begin = end + 1;
  }
  if (static_cast<int>(out.size()) != count)
    throw ParameterError("hands", "loopback: hands has " + std::to_string(out.size()) +
                                      " scripts; accepted: one per axis (" + std::to_string(count) +
                                      "), separated by ';', e.g. \"mode=hold trajectory=ramp to=0.01 "
                                      "rate=0.01; mode=free\"");
  return out;
}

/// Keys only a one-axis loopback takes.
void refuse_for_stage(const DriverParameters& p, int count) {
  const auto refuse = [&](const char* key, const std::string& why) {
    throw ParameterError(key, "loopback: " + std::string(key) + ": " + why + " (axes = " +
                                  std::to_string(count) + ": a Cartesian stage of rigid, linear axes)");
  };
  if (p.given("motion") && p.text("motion") != "linear") refuse("motion", "accepted: \"linear\"");
  if (p.text("plant") != "rigid") refuse("plant", "accepted: \"rigid\"");
  if (p.given("hand") && p.given("hands"))
    refuse("hand", "give either hand (every axis) or hands (one each)");
}

}  // namespace

LoopbackStage loopback_stage_from(const DriverParameters& p) {
  const int count = static_cast<int>(p.integer("axes"));
  LoopbackStage stage;
  if (count == 1) {
    for (const char* key : {"axis_mass", "axis_damping", "axis_weight", "hands"}) {
      if (p.given(key))
        throw ParameterError(key, "loopback: " + std::string(key) +
                                      " is for a stage of several axes; accepted with axes = 2 to " +
                                      std::to_string(max_axes) + " (one axis: mass, damping, hand)");
    }
    stage.axes.push_back(loopback_config_from(p));
    stage.hands.push_back(hand_script_from(p));
    return stage;
  }
  refuse_for_stage(p, count);
  LoopbackConfig axis = LoopbackConfig::defaults(Motion::linear);
  const auto set = [&p](const char* key, double& field) {
    if (p.given(key)) field = p.number(key);
  };
  set("mass", axis.mass);
  set("damping", axis.damping);
  set("coulomb", axis.coulomb);
  set("counts", axis.counts);
  set("max_force", axis.max_force);
  axis.delay = static_cast<int>(p.integer("delay"));
  namespace r = world::parameter_range;
  const auto masses = p.given("axis_mass") ? per_axis_numbers("axis_mass", p.text("axis_mass"), count,
                                                              r::min_mass, r::max_mass, "kg")
                                           : std::vector<double>(static_cast<std::size_t>(count), axis.mass);
  const auto dampings =
      p.given("axis_damping")
          ? per_axis_numbers("axis_damping", p.text("axis_damping"), count, 0.0, r::max_damping, "N s/m")
          : std::vector<double>(static_cast<std::size_t>(count), axis.damping);
  const auto weights = p.given("axis_weight") ? per_axis_numbers("axis_weight", p.text("axis_weight"), count,
                                                                 -r::max_force, r::max_force, "N")
                                              : std::vector<double>(static_cast<std::size_t>(count), 0.0);
  for (int i = 0; i < count; ++i) {
    axis.mass = masses[static_cast<std::size_t>(i)];
    axis.damping = dampings[static_cast<std::size_t>(i)];
    axis.weight = weights[static_cast<std::size_t>(i)];
    axis.validate();
    stage.axes.push_back(axis);
  }
  stage.hands = stage_hands(p, count);
  return stage;
}

LoopbackConfig parse_loopback_config(std::string_view text) {
  std::map<std::string, ParameterValue, std::less<>> given;
  for (auto& [key, value] : simulation::detail::split_key_values(text, "loopback")) given[key] = value;
  return loopback_config_from(DriverParameters("loopback", loopback_parameters(), given));
}

}  // namespace hapticd::drivers::loopback
