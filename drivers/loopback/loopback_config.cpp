#include "drivers/loopback/loopback_config.hpp"

#include <array>
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

namespace {
/// The `hand` table (or its one-line text) as key=value text.
std::string hand_text_from(const DriverParameters& p) {
  std::string text;
  for (const auto& [key, value] : p.table("hand")) text += (key.empty() ? value : key + "=" + value) + " ";
  return text;
}
}  // namespace

simulation::HandScript hand_script_from(const DriverParameters& p) {
  const auto entries = p.table("hand");
  const std::string text = hand_text_from(p);
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

/// The default pantograph's workspace, m: an 8 x 5 cm box in front of the
/// motors of the default links (Campion et al.'s proportions), where the
/// distal links keep at least 50 degrees between them and J's smallest
/// singular value stays above 0.04 m/rad.
constexpr std::array<double, 4> default_workspace{-0.02, 0.06, 0.07, 0.12};
/// The default joint inertia, kg m^2: 0.1 kg (Hulin's PHANToM) at the 7 cm
/// proximal link.
constexpr double default_joint_inertia = 5e-4;

/// Refuses what a pantograph cannot take.
void refuse_for_pantograph(const DriverParameters& p) {
  const auto refuse = [](const char* key, const std::string& why) {
    throw ParameterError(key, "loopback: " + std::string(key) + ": " + why +
                                  " (linkage = \"pantograph\": two rigid, rotary motor joints)");
  };
  if (p.given("axes") && p.integer("axes") != 2) refuse("axes", "accepted: 2 (the two motor joints)");
  if (p.given("motion") && p.text("motion") != "rotary") refuse("motion", "accepted: \"rotary\"");
  if (p.text("plant") != "rigid") refuse("plant", "accepted: \"rigid\"");
  for (const char* key : {"mass", "damping", "axis_mass", "axis_damping"}) {
    if (p.given(key)) refuse(key, "the joints take joint_inertia and joint_damping");
  }
}

/// The workspace box: reachable, away from the singularities, everywhere
/// (a 41 x 41 grid); throws ParameterError naming the point.
DeviceModel::Pantograph pantograph_model(const DriverParameters& p) {
  namespace r = world::parameter_range;
  DeviceModel::Pantograph model;
  world::PantographGeometry& g = model.geometry;
  if (p.given("links")) {
    const auto a = per_axis_numbers("links", p.text("links"), 5, 1e-3, 10.0, "m");
    g.a1 = a[0], g.a2 = a[1], g.a3 = a[2], g.a4 = a[3], g.a5 = a[4];
  }
  try {
    g.validate();
  } catch (const std::invalid_argument& e) {
    throw ParameterError("links", std::string("loopback: links: ") + e.what());
  }
  const auto box =
      p.given("workspace")
          ? per_axis_numbers("workspace", p.text("workspace"), 4, -r::max_position, r::max_position, "m")
          : std::vector<double>(default_workspace.begin(), default_workspace.end());
  model.x_min = box[0], model.x_max = box[1], model.y_min = box[2], model.y_max = box[3];
  if (!(box[0] < box[1] && box[2] < box[3]))
    throw ParameterError("workspace", "loopback: workspace = \"" + p.text("workspace") +
                                          "\" is not accepted; x_min,x_max,y_min,y_max with min < max (m)");
  const world::PantographKinematics k(g);
  constexpr int steps = 40;
  for (int i = 0; i <= steps; ++i) {
    for (int j = 0; j <= steps; ++j) {
      world::AxisVector x(2);
      x << box[0] + (box[1] - box[0]) * i / steps, box[2] + (box[3] - box[2]) * j / steps;
      const auto q = k.inverse(x);
      world::TaskState s;
      if (q) k.solve(*q, s);
      if (q && s.status == world::KinematicsStatus::ok) continue;
      throw ParameterError(
          "workspace", "loopback: workspace: the point (" + to_text(ParameterValue(x(0))) + ", " +
                           to_text(ParameterValue(x(1))) + ") m is " +
                           (q ? std::string(world::to_string(s.status)) : std::string("out of reach")) +
                           " of these links; accepted: a box the handle reaches everywhere, away from the "
                           "singularities");
    }
  }
  return model;
}

LoopbackStage pantograph_from(const DriverParameters& p) {
  refuse_for_pantograph(p);
  namespace r = world::parameter_range;
  LoopbackStage stage;
  LoopbackStage::Pantograph linkage;
  linkage.model = pantograph_model(p);
  const auto& m = linkage.model;
  linkage.start = {(m.x_min + m.x_max) / 2, (m.y_min + m.y_max) / 2};
  if (p.given("start")) {
    const auto s = per_axis_numbers("start", p.text("start"), 2, -r::max_position, r::max_position, "m");
    if (!(s[0] >= m.x_min && s[0] <= m.x_max && s[1] >= m.y_min && s[1] <= m.y_max))
      throw ParameterError("start", "loopback: start = \"" + p.text("start") +
                                        "\" is not accepted; a point inside the workspace (m)");
    linkage.start = {s[0], s[1]};
  }
  const auto inertia = p.given("joint_inertia") ? per_axis_numbers("joint_inertia", p.text("joint_inertia"),
                                                                   2, r::min_mass, r::max_mass, "kg m^2")
                                                : std::vector<double>(2, default_joint_inertia);
  const auto damping = p.given("joint_damping") ? per_axis_numbers("joint_damping", p.text("joint_damping"),
                                                                   2, 0.0, r::max_damping, "N m s/rad")
                                                : std::vector<double>(2, 0.0);
  LoopbackConfig joint = LoopbackConfig::defaults(Motion::rotary);
  const auto set = [&p](const char* key, double& field) {
    if (p.given(key)) field = p.number(key);
  };
  set("coulomb", joint.coulomb);
  set("counts", joint.counts);
  set("max_force", joint.max_force);
  joint.delay = static_cast<int>(p.integer("delay"));
  for (std::size_t i = 0; i < 2; ++i) {
    joint.mass = inertia[i];
    joint.damping = damping[i];
    joint.validate();
    stage.axes.push_back(joint);
  }
  stage.hands = p.given("hands") ? stage_hands(p, 2) : std::vector<simulation::HandScript>(2);
  const std::string text = hand_text_from(p);
  try {
    linkage.hand = simulation::parse_task_hand_script(text, linkage.start);
    simulation::PantographHand check(m.geometry, linkage.hand, joint.period_s);
  } catch (const std::invalid_argument& e) {
    throw ParameterError("hand",
                         std::string("device.loopback.hand (on the pantograph's handle): ") + e.what());
  }
  if (p.given("link_masses")) {
    const auto w = per_axis_numbers("link_masses", p.text("link_masses"), 5, 0.0, 10.0, "kg");
    linkage.weight = world::PantographMasses{w[0], w[1], w[2], w[3], w[4], world::standard_gravity};
  }
  stage.pantograph = linkage;
  return stage;
}

}  // namespace

LoopbackStage loopback_stage_from(const DriverParameters& p) {
  if (p.text("linkage") == "pantograph") return pantograph_from(p);
  for (const char* key : {"links", "joint_inertia", "joint_damping", "workspace", "start", "link_masses"}) {
    if (p.given(key))
      throw ParameterError(key, "loopback: " + std::string(key) +
                                    " is for a pantograph; accepted with linkage = \"pantograph\"");
  }
  const int count = static_cast<int>(p.integer("axes"));
  LoopbackStage stage;
  if (count == 1) {
    for (const char* key : {"axis_mass", "axis_damping", "hands"}) {
      if (p.given(key))
        throw ParameterError(key, "loopback: " + std::string(key) +
                                      " is for a stage of several axes; accepted with axes = 2 to " +
                                      std::to_string(max_axes) + " (one axis: mass, damping, hand)");
    }
    stage.axes.push_back(loopback_config_from(p));
    // One vertical axis: its weight (one number), as on a stage.
    if (p.given("axis_weight")) {
      namespace r = world::parameter_range;
      stage.axes[0].weight =
          per_axis_numbers("axis_weight", p.text("axis_weight"), 1, -r::max_force, r::max_force, "N")[0];
      stage.axes[0].validate();
    }
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
