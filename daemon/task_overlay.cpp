#include "daemon/task_overlay.hpp"

#include <algorithm>

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
void add_gravity(const config::DaemonConfig& cfg, const DeviceModel& device, TaskOverlay& out) {
  const config::GravityConfig& g = cfg.gravity;
  const auto& names = device.axis_names;
  const auto it = std::find(names.begin(), names.end(), g.axis);
  if (it == names.end())
    throw ConfigError(
        g.axis_where, "gravity.axis",
        "gravity.axis = \"" + g.axis + "\" names no axis of the device; accepted: " + axis_list(names));
  const double weight = g.mass * g.acceleration;  // N
  if (weight > cfg.device.torque_limit)
    throw ConfigError(g.mass_where, "gravity.mass",
                      "gravity.mass = " + overlay_number(g.mass) + " kg weighs " + overlay_number(weight) +
                          " N, more than device.torque_limit = " + overlay_number(cfg.device.torque_limit) +
                          " N: the feedforward could not hold the axis; accepted: a mass up to " +
                          overlay_number(cfg.device.torque_limit / g.acceleration) +
                          " kg, or a larger torque_limit");
  const auto axis = static_cast<Eigen::Index>(it - names.begin());
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

std::vector<world::ChannelDescription> TaskOverlay::channels(
    const std::vector<std::string>& axis_names) const {
  std::vector<world::ChannelDescription> out;
  if (gravity) {
    for (const auto& n : axis_names) out.push_back({"gravity_" + n, "N"});
  }
  if (workspace) out.push_back({"workspace_penetration", "m"});
  return out;
}

TaskOverlay make_task_overlay(const config::DaemonConfig& cfg, const DeviceModel& device) {
  TaskOverlay out;
  out.status = nlohmann::json::object();
  const bool wanted = cfg.gravity.configured || !cfg.workspace.shape.empty();
  if (!wanted) return out;
  if (device.axis_names.empty()) {
    const bool gravity = cfg.gravity.configured;
    throw ConfigError(gravity ? cfg.gravity.table_where : cfg.workspace.shape_where,
                      gravity ? "[gravity]" : "[workspace]",
                      std::string(gravity ? "[gravity]" : "[workspace]") +
                          " is for a device with several axes (issue 22); this one (" + cfg.device.driver +
                          ") has one; accepted: no [gravity] or [workspace] table");
  }
  if (cfg.gravity.configured) add_gravity(cfg, device, out);
  if (!cfg.workspace.shape.empty()) add_workspace(cfg, device, out);
  return out;
}

}  // namespace hapticd::daemon
