#include "daemon/task_overlay.hpp"

#include <algorithm>
#include <cmath>

#include "world/text.hpp"

namespace hapticd::daemon {

namespace {

using config::ConfigError;

std::string overlay_number(double v) {
  return world::text::format_significant(v, world::text::precision::summary);
}

std::string axis_list(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

/// [gravity] on a Cartesian stage: +m g on the vertical axis (the force that
/// holds it, dV/dq with V = m g q for an axis pointing up), 0 elsewhere.
void add_stage_gravity(const config::DaemonConfig& cfg, const DeviceModel& device, TaskOverlay& out) {
  const config::GravityConfig& g = cfg.gravity;
  const auto& names = device.axis_names;
  if (g.axis_where.line == 0)
    throw ConfigError(g.table_where, "gravity.axis",
                      "[gravity] on a stage with several axes needs axis (the vertical axis' name); "
                      "accepted: " +
                          axis_list(names));
  const auto it = std::find(names.begin(), names.end(), g.axis);
  if (it == names.end())
    throw ConfigError(
        g.axis_where, "gravity.axis",
        "gravity.axis = \"" + g.axis + "\" names no axis of the device; accepted: " + axis_list(names));
  const double weight = g.mass * g.acceleration;  // N
  const auto axis = static_cast<Eigen::Index>(it - names.begin());
  const double limit = cfg.device.axis_limit(static_cast<std::size_t>(axis));
  if (weight > limit)
    throw ConfigError(g.mass_where, "gravity.mass",
                      "gravity.mass = " + overlay_number(g.mass) + " kg weighs " + overlay_number(weight) +
                          " N, more than the torque limit of axis " + g.axis + ", " + overlay_number(limit) +
                          " N: the feedforward could not hold the axis; accepted: a mass up to " +
                          overlay_number(limit / g.acceleration) + " kg, or a larger torque_limit");
  world::StageWeight stage{world::AxisVector::Zero(static_cast<Eigen::Index>(names.size()))};
  stage.holding(axis) = g.down_positive ? -weight : weight;
  out.gravity = stage;
  const std::string down = g.down_positive ? "positive" : "negative";
  out.status["gravity"] = {{"axis", g.axis},
                           {"mass", g.mass},
                           {"acceleration", g.acceleration},
                           {"down", down},
                           {"feedforward", stage.holding(axis)}};
  out.notes.push_back("gravity: " + overlay_number(g.mass) + " kg on axis " + g.axis + " (down " + down +
                      ", g = " + overlay_number(g.acceleration) + " m/s^2): a feedforward of " +
                      overlay_number(stage.holding(axis)) +
                      " N added after the scene, inside the torque limit (gravity_" + g.axis + ")");
}

/// [gravity] on a device with one linear axis, vertical: +m g (down
/// negative) or -m g, the force that holds the axis, after the scene.
void add_axis_gravity(const config::DaemonConfig& cfg, const DeviceModel& device, TaskOverlay& out) {
  const config::GravityConfig& g = cfg.gravity;
  if (g.axis_where.line != 0)
    throw ConfigError(g.axis_where, "gravity.axis",
                      "gravity.axis names a stage's vertical axis; this device has one axis, which "
                      "[gravity] holds; accepted: mass and down without axis");
  if (device.info.motion == drivers::Motion::rotary)
    throw ConfigError(g.table_where, "[gravity]",
                      "[gravity] on one axis is a constant weight on a vertical linear axis; this device "
                      "is rotary (a weight on a lever varies with the angle); accepted: a linear device");
  const double weight = g.mass * g.acceleration;  // N
  const double limit = cfg.device.axis_limit(0);
  if (weight > limit)
    throw ConfigError(g.mass_where, "gravity.mass",
                      "gravity.mass = " + overlay_number(g.mass) + " kg weighs " + overlay_number(weight) +
                          " N, more than the torque limit " + overlay_number(limit) +
                          " N: the feedforward could not hold the axis; accepted: a mass up to " +
                          overlay_number(limit / g.acceleration) + " kg, or a larger torque_limit");
  const double holding = g.down_positive ? -weight : weight;
  out.gravity = world::StageWeight{world::AxisVector::Constant(1, holding)};
  const std::string down = g.down_positive ? "positive" : "negative";
  out.status["gravity"] = {
      {"mass", g.mass}, {"acceleration", g.acceleration}, {"down", down}, {"feedforward", holding}};
  out.notes.push_back("gravity: " + overlay_number(g.mass) + " kg on the axis (down " + down +
                      ", g = " + overlay_number(g.acceleration) + " m/s^2): a feedforward of " +
                      overlay_number(holding) +
                      " N added after the scene, inside the torque limit (gravity)");
}

/// The holding torque nearest its joint's limit over the pantograph's
/// workspace box (41 x 41 points, as the loopback checks the box): the
/// feedforward must fit the torque limits everywhere the handle is used.
struct WorstHolding {
  double torque = 0.0;  ///< N m, |tau_g,i| of the joint nearest its limit
  double share = 0.0;   ///< that torque over its joint's limit
  Eigen::Index joint = 0;
  double x = 0.0, y = 0.0;
};

WorstHolding worst_holding(const drivers::DeviceModel::Pantograph& p, const world::PantographMasses& masses,
                           const config::DeviceConfig& limits) {
  const world::PantographKinematics kinematics(p.geometry);
  WorstHolding worst;
  constexpr int steps = 40;
  for (int i = 0; i <= steps; ++i) {
    for (int j = 0; j <= steps; ++j) {
      world::AxisVector x(2);
      x << p.x_min + (p.x_max - p.x_min) * i / steps, p.y_min + (p.y_max - p.y_min) * j / steps;
      const auto q = kinematics.inverse(x);
      if (!q) continue;  // the driver checked the box is reached
      world::TaskState state;
      kinematics.solve(*q, state);
      const world::AxisVector tau = world::pantograph_gravity_torques(kinematics, masses, *q, state);
      for (Eigen::Index k = 0; k < tau.size(); ++k) {
        const double share = std::abs(tau(k)) / limits.axis_limit(static_cast<std::size_t>(k));
        if (share > worst.share) worst = {std::abs(tau(k)), share, k, x(0), x(1)};
      }
    }
  }
  return worst;
}

/// [gravity] on the pantograph in a vertical plane (y up): the links' and
/// the handle's masses; the holding torques dV/dq follow the configuration
/// (world/gravity.hpp) and must fit the torque limits over the workspace.
void add_pantograph_gravity(const config::DaemonConfig& cfg, const DeviceModel& device, TaskOverlay& out) {
  const config::GravityConfig& g = cfg.gravity;
  const auto& m = g.link_masses;
  const world::PantographMasses masses{m[0], m[1], m[2], m[3], g.handle_mass, g.acceleration};
  const WorstHolding worst = worst_holding(*device.info.pantograph, masses, cfg.device);
  const std::string& joint = device.axis_names.at(static_cast<std::size_t>(worst.joint));
  const double limit = cfg.device.axis_limit(static_cast<std::size_t>(worst.joint));
  if (worst.share > 1.0)
    throw ConfigError(g.link_masses_where, "gravity.link_masses",
                      "gravity.link_masses: holding the links takes up to " + overlay_number(worst.torque) +
                          " N m on " + joint + " (the handle at (" + overlay_number(worst.x) + ", " +
                          overlay_number(worst.y) + ") m), more than its torque limit " +
                          overlay_number(limit) + " N m; accepted: lighter links, or a larger torque_limit");
  out.gravity = masses;
  out.status["gravity"] = {
      {"link_masses", m},
      {"handle_mass", g.handle_mass},
      {"acceleration", g.acceleration},
      {"worst_case", {{"torque", worst.torque}, {"joint", joint}, {"handle", {worst.x, worst.y}}}}};
  out.notes.push_back("gravity: the pantograph's links " + overlay_number(m[0]) + ", " +
                      overlay_number(m[1]) + ", " + overlay_number(m[2]) + ", " + overlay_number(m[3]) +
                      " kg and " + overlay_number(g.handle_mass) +
                      " kg at the handle in a vertical plane (y up, g = " + overlay_number(g.acceleration) +
                      " m/s^2): a joint feedforward up to " + overlay_number(worst.torque) + " N m on " +
                      joint + " (" + overlay_number(100.0 * worst.share) +
                      " % of its limit) over the workspace, added " + "after the scene (gravity_<joint>)");
}

/// [gravity]: the stage's or the pantograph's model, each with its own keys.
void add_gravity(const config::DaemonConfig& cfg, const DeviceModel& device, TaskOverlay& out) {
  const config::GravityConfig& g = cfg.gravity;
  const bool pantograph = device.info.pantograph.has_value();
  if (pantograph && g.link_masses.empty())
    throw ConfigError(g.axis_where.line != 0 ? g.axis_where : g.table_where, "gravity.axis",
                      "[gravity] on the pantograph: its weight is in its links; accepted: link_masses "
                      "(four masses in kg) and handle_mass, not axis, mass or down");
  if (!pantograph && !g.link_masses.empty())
    throw ConfigError(g.link_masses_where, "gravity.link_masses",
                      "gravity.link_masses is for the pantograph ([device] kinematics = \"pantograph\"); "
                      "accepted on a Cartesian stage: axis, mass and down");
  if (pantograph) return add_pantograph_gravity(cfg, device, out);
  if (device.axis_names.empty()) return add_axis_gravity(cfg, device, out);
  add_stage_gravity(cfg, device, out);
}

const config::Parameter* workspace_key(const config::WorkspaceConfig& w, std::string_view key) {
  for (const auto& p : w.parameters) {
    if (p.key == key) return &p;
  }
  return nullptr;
}

/// [workspace]: the box or sphere as the scene planner builds it (a sphere
/// always holds the device inside), judged by the gate like any wall.
void add_workspace(const config::DaemonConfig& cfg, const DeviceModel& device, TaskOverlay& out) {
  const config::WorkspaceConfig& w = cfg.workspace;
  world::ParameterSet parameters;
  for (const auto& p : w.parameters) parameters[p.key] = p.value;
  if (w.shape == "sphere") {
    if (const auto* side = workspace_key(w, "side"))
      throw ConfigError(
          side->where, "workspace.side",
          "workspace.side: a workspace holds the device inside its sphere; accepted: no side key");
    parameters["side"] = std::string("inside");
  }
  auto outcome = plan_on_device(w.shape, parameters, device, false);
  if (const auto* refusal = std::get_if<PlanRefusal>(&outcome)) {
    const auto* named = workspace_key(w, refusal->parameter);
    const auto* stiffness = workspace_key(w, "stiffness");
    const config::Parameter* at = named != nullptr ? named : refusal->invalid ? nullptr : stiffness;
    const std::string key = at != nullptr ? "workspace." + at->key : "workspace.shape";
    throw ConfigError(at != nullptr ? at->where : w.shape_where, key,
                      "workspace (" + w.shape + "): " + refusal->message +
                          (refusal->invalid ? "" : "; accepted: a workspace wall the gate holds"));
  }
  auto planned = std::get<PlannedScene>(std::move(outcome));
  out.workspace = planned.plan.task_object;
  nlohmann::json parameters_json = to_json(planned.plan.parameters, w.shape);
  out.status["workspace"] = {
      {"shape", w.shape}, {"parameters", parameters_json}, {"stability", to_json(planned.stability)}};
  std::string line = "workspace: " + w.shape;
  for (const auto& [k, v] : planned.plan.parameters) line += " " + k + "=" + to_text(v);
  out.notes.push_back(line + ", a wall on top of every scene (workspace_penetration); stability: " +
                      planned.stability.summary);
  out.workspace_plan = std::move(planned);
}

}  // namespace

std::vector<world::ChannelDescription> TaskOverlay::channels(const std::vector<std::string>& axis_names,
                                                             bool rotary) const {
  std::vector<world::ChannelDescription> out;
  if (gravity) {
    for (const auto& n : axis_names) out.push_back({"gravity_" + n, rotary ? "N m" : "N"});
    if (axis_names.empty()) out.push_back({"gravity", "N"});  // one linear axis
  }
  if (workspace) out.push_back({"workspace_penetration", "m"});
  return out;
}

TaskOverlay make_task_overlay(const config::DaemonConfig& cfg, const DeviceModel& device) {
  TaskOverlay out;
  out.status = nlohmann::json::object();
  const bool wanted = cfg.gravity.configured || !cfg.workspace.shape.empty();
  if (!wanted) return out;
  if (device.axis_names.empty() && !cfg.workspace.shape.empty()) {
    throw ConfigError(cfg.workspace.shape_where, "[workspace]",
                      "[workspace] is a box or a sphere in the task space of a device with several axes; "
                      "this one (" +
                          cfg.device.driver +
                          ") has one, where a wall scene limits the travel; accepted: no [workspace] table");
  }
  if (cfg.gravity.configured) add_gravity(cfg, device, out);
  if (!cfg.workspace.shape.empty()) add_workspace(cfg, device, out);
  return out;
}

}  // namespace hapticd::daemon
