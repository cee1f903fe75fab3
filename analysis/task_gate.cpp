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
  if (device.pantograph) {
    // The mass along a direction changes with the configuration: the worst
    // case over the workspace (a bound, not exact), with where it is.
    const auto& k = *device.pantograph;
    const auto at = [](const DirectionalModel& m) {
      return ", its worst case at (" + task_number(m.position(0)) + ", " + task_number(m.position(1)) +
             ") m, q = (" + task_number(m.joints(0)) + ", " + task_number(m.joints(1)) + ") rad";
    };
    if (judged.directions.empty()) {
      world::AxisVector n;
      DirectionalModel along = pantograph_lightest(k, device.axes, device.workspace, n);
      std::string label =
          "the lightest direction (" + task_number(n(0)) + ", " + task_number(n(1)) + ")" + at(along);
      add(std::move(label), std::move(along));
      return out;
    }
    static const char* const task_axes[] = {"x", "y"};
    for (std::size_t i = 0; i < judged.directions.size(); ++i) {
      DirectionalModel along = pantograph_along(k, device.axes, judged.directions[i], device.workspace);
      std::string label =
          (judged.along_axes && i < 2 ? "axis " + std::string(task_axes[i]) : judged.labels.at(i)) +
          at(along);
      add(std::move(label), std::move(along));
    }
    return out;
  }
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
         task_number(d.along.damping) + " N s/m, " + (d.along.exact ? "exact" : "a bound, not exact") + ")";
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

// ---- a one-axis scene on each axis (axis-springs) ----------------------------

namespace {

struct AxisVerdicts {
  std::vector<GateDevice> devices;  ///< each axis as a rigid one-axis device
  std::vector<SceneStability> verdicts;
  std::size_t worst = 0;
};

void require_stage(const world::ScenePlan& plan, const GateDevice& device) {
  if (!plan.per_axis) throw std::invalid_argument(plan.scene + " is not judged per axis");
  if (device.pantograph)
    throw std::invalid_argument(plan.scene +
                                " needs a Cartesian stage: a pantograph's task axes are coupled through its "
                                "linkage (its mass along x depends on y), so no axis is a one-axis device");
  if (device.axes.empty())
    throw std::invalid_argument("the device's axes (mass and damping of each) are not known");
}

std::string axis_label(const GateDevice& device, std::size_t i) {
  const JointModel& axis = device.axes[i];
  return "axis " + axis_name(device, static_cast<Eigen::Index>(i)) + " (m = " + task_number(axis.mass) +
         " kg, b = " + task_number(axis.damping) + " N s/m, exact: the axes decouple)";
}

AxisVerdicts judge_axes(const world::ScenePlan& plan, const GateDevice& device) {
  const world::PerAxisJudgement& per = *plan.per_axis;
  AxisVerdicts out;
  for (std::size_t i = 0; i < device.axes.size(); ++i) {
    out.devices.push_back(rigid_device(device.axes[i].mass, device.axes[i].damping, device.period_s,
                                       device.delay_samples, world::Motion::linear));
    auto planned = world::plan_scene(per.scene, per.on_axis(i), device.period_s, world::Motion::linear);
    if (const auto* error = std::get_if<world::SceneError>(&planned))
      throw std::invalid_argument(error->message);
    out.verdicts.push_back(check_scene_stability(std::get<world::ScenePlan>(planned), out.devices.back()));
    const SceneStability& v = out.verdicts.back();
    const SceneStability& w = out.verdicts[out.worst];
    const bool worse = (v.verdict != w.verdict) ? static_cast<int>(v.verdict) > static_cast<int>(w.verdict)
                                                : v.closed_loop_radius > w.closed_loop_radius;
    if (worse) out.worst = i;
  }
  return out;
}

SceneStability worst_axis(const GateDevice& device, const AxisVerdicts& judged) {
  SceneStability v = judged.verdicts[judged.worst];
  v.summary = "on " + axis_label(device, judged.worst) + ": " + v.summary;
  if (judged.verdicts.size() > 1)
    v.summary += " (the worst of " + std::to_string(judged.verdicts.size()) + " axes)";
  return v;
}

}  // namespace

SceneStability check_per_axis_stability(const world::ScenePlan& plan, const GateDevice& device) {
  require_stage(plan, device);
  return worst_axis(device, judge_axes(plan, device));
}

GateOutcome gate_per_axis(world::ScenePlan plan, const GateDevice& device, bool force) {
  AxisVerdicts judged;
  try {
    require_stage(plan, device);
    judged = judge_axes(plan, device);
  } catch (const std::invalid_argument& e) {
    GateRefusal refusal;
    refusal.assessed = false;
    refusal.message = plan.scene + ": stability cannot be assessed on this device: " + e.what();
    return refusal;
  }
  GateAccepted accepted{std::move(plan), worst_axis(device, judged), false};
  if (accepted.stability.stable) return accepted;
  const bool assessed = accepted.stability.verdict != VerdictState::cannot_assess;
  if (force && assessed) {
    accepted.forced = true;
    return accepted;
  }
  // The one-axis gate on the failing axis: its limit, with the axis named.
  const world::PerAxisJudgement& per = *accepted.plan.per_axis;
  GateOutcome one = gate_scene(per.scene, per.on_axis(judged.worst), judged.devices[judged.worst], false);
  GateRefusal refusal = std::holds_alternative<GateRefusal>(one) ? std::get<GateRefusal>(one) : GateRefusal{};
  const std::string prefix = per.scene + ": ";
  const std::string reason =
      refusal.message.starts_with(prefix) ? refusal.message.substr(prefix.size()) : refusal.message;
  refusal.message = accepted.plan.scene + " on " + axis_label(device, judged.worst) + ": " + reason;
  refusal.stability = accepted.stability;
  refusal.assessed = assessed;
  return refusal;
}

}  // namespace hapticd::analysis
