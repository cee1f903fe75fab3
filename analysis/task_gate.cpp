#include "analysis/task_gate.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

#include "world/text.hpp"

namespace hapticd::analysis {

namespace {

std::string task_number(double v) {
  return world::text::format_significant(v, world::text::precision::summary);
}

/// The one-axis wall with the task wall's law, its surface at 0.
world::ParameterSet one_axis_wall(const world::TaskWallLaw& law) {
  return {{"stiffness", law.stiffness},
          {"damping", law.damping},
          {"delay", static_cast<double>(law.delay_samples)},
          {"position", 0.0},
          {"side", std::string("upper")}};
}

std::string axis_name(const GateDevice& device, Eigen::Index i) {
  const auto k = static_cast<std::size_t>(i);
  return k < device.axis_names.size() ? device.axis_names[k] : std::to_string(i + 1);
}

/// The sphere's worst direction: the lightest axis, with the least damping
/// per unit mass of any axis (every direction mixes axes, and the radius
/// may point anywhere).
DirectionalModel lightest_direction(const GateDevice& device, Eigen::Index& lightest) {
  const auto& axes = device.axes;
  lightest = 0;
  double least_per_mass = std::numeric_limits<double>::infinity(), most_per_mass = 0.0;
  for (std::size_t i = 0; i < axes.size(); ++i) {
    if (axes[i].mass < axes[static_cast<std::size_t>(lightest)].mass) lightest = static_cast<Eigen::Index>(i);
    least_per_mass = std::min(least_per_mass, axes[i].damping / axes[i].mass);
    most_per_mass = std::max(most_per_mass, axes[i].damping / axes[i].mass);
  }
  const auto n = static_cast<Eigen::Index>(axes.size());
  DirectionalModel along = cartesian_along(axes, world::AxisVector::Unit(n, lightest));
  const bool proportional = most_per_mass - least_per_mass <= 1e-12 * std::max(most_per_mass, 1.0);
  along.damping = least_per_mass * along.mass;
  along.exact = proportional;
  along.basis =
      "the smallest m_n over all directions is the lightest axis' mass, " + task_number(along.mass) +
      " kg; " +
      (proportional ? std::string("damping proportional to the mass: exact")
                    : "damping " + task_number(along.damping) +
                          " N s/m, the least damping per unit mass of any axis (a bound: the radius "
                          "may point along any mix of axes)");
  return along;
}

}  // namespace

std::vector<TaskDirection> task_wall_directions(const world::ScenePlan& plan, const GateDevice& device) {
  if (!plan.task_wall) throw std::invalid_argument(plan.scene + " is not a wall in task space");
  if (device.axes.empty())
    throw std::invalid_argument("the device's axes (mass and damping of each) are not known");
  const world::TaskWallJudgement& judged = *plan.task_wall;
  std::vector<TaskDirection> out;
  const auto add = [&](std::string label, DirectionalModel along) {
    TaskDirection d{std::move(label), std::move(along), {}, one_axis_wall(judged.law)};
    d.device = rigid_device(d.along.mass, d.along.damping, device.period_s, device.delay_samples,
                            world::Motion::linear);
    out.push_back(std::move(d));
  };
  if (judged.directions.empty()) {
    Eigen::Index lightest = 0;
    DirectionalModel along = lightest_direction(device, lightest);
    add("the worst direction (the lightest axis, " + axis_name(device, lightest) + ")", std::move(along));
    return out;
  }
  for (std::size_t i = 0; i < judged.directions.size(); ++i) {
    DirectionalModel along = cartesian_along(device.axes, judged.directions[i]);
    std::string label =
        judged.along_axes ? "axis " + axis_name(device, static_cast<Eigen::Index>(i)) : judged.labels.at(i);
    add(std::move(label), std::move(along));
  }
  return out;
}

namespace {

std::string describe_along(const TaskDirection& d) {
  return "along " + d.label + " (m_n = " + task_number(d.along.mass) + " kg, damping " +
         task_number(d.along.damping) + " N s/m, " + (d.along.exact ? "exact" : "a bound") + ")";
}

/// Each direction's verdict; the index of the worst.
std::size_t judge_directions(const std::vector<TaskDirection>& directions,
                             std::vector<SceneStability>& verdicts) {
  std::size_t worst = 0;
  for (std::size_t i = 0; i < directions.size(); ++i) {
    const auto& d = directions[i];
    auto planned = world::plan_scene("wall", d.one_axis, d.device.period_s, world::Motion::linear);
    if (const auto* error = std::get_if<world::SceneError>(&planned))
      throw std::invalid_argument(error->message);
    verdicts.push_back(check_scene_stability(std::get<world::ScenePlan>(planned), d.device));
    const SceneStability& v = verdicts.back();
    const SceneStability& w = verdicts[worst];
    const bool worse = (v.verdict != w.verdict) ? static_cast<int>(v.verdict) > static_cast<int>(w.verdict)
                                                : v.closed_loop_radius > w.closed_loop_radius;
    if (worse) worst = i;
  }
  return worst;
}

}  // namespace

namespace {
/// The worst direction's verdict, its summary naming the direction.
SceneStability worst_verdict(const std::vector<TaskDirection>& directions,
                             const std::vector<SceneStability>& verdicts, std::size_t worst) {
  SceneStability v = verdicts[worst];
  v.summary = describe_along(directions[worst]) + ": " + v.summary;
  if (directions.size() > 1) v.summary += " (the worst of " + std::to_string(directions.size()) + " axes)";
  return v;
}
}  // namespace

SceneStability check_task_wall_stability(const world::ScenePlan& plan, const GateDevice& device) {
  const auto directions = task_wall_directions(plan, device);
  std::vector<SceneStability> verdicts;
  const std::size_t worst = judge_directions(directions, verdicts);
  return worst_verdict(directions, verdicts, worst);
}

GateOutcome gate_task_wall(world::ScenePlan plan, const GateDevice& device, bool force) {
  std::vector<TaskDirection> directions;
  try {
    directions = task_wall_directions(plan, device);
  } catch (const std::invalid_argument& e) {
    GateRefusal refusal;
    refusal.assessed = false;
    refusal.message = plan.scene + ": stability cannot be assessed on this device: " + e.what();
    return refusal;
  }
  std::vector<SceneStability> verdicts;
  const std::size_t worst = judge_directions(directions, verdicts);
  GateAccepted accepted{std::move(plan), worst_verdict(directions, verdicts, worst), false};
  if (accepted.stability.stable) return accepted;
  const bool assessed = accepted.stability.verdict != VerdictState::cannot_assess;
  if (force && assessed) {
    accepted.forced = true;
    return accepted;
  }
  // The one-axis gate along the failing direction: its limit and Hulin's
  // region, with the direction named.
  const TaskDirection& d = directions[worst];
  GateOutcome along = gate_scene("wall", d.one_axis, d.device, false);
  GateRefusal refusal =
      std::holds_alternative<GateRefusal>(along) ? std::get<GateRefusal>(along) : GateRefusal{};
  const std::string prefix = "wall: ";
  std::string reason =
      refusal.message.starts_with(prefix) ? refusal.message.substr(prefix.size()) : refusal.message;
  refusal.message = accepted.plan.scene + " " + describe_along(d) + ": " + reason;
  refusal.stability = accepted.stability;
  refusal.assessed = assessed;
  return refusal;
}

}  // namespace hapticd::analysis
