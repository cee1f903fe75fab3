#pragma once
/// \file
/// The stability gate for a wall in task space (issue 22): Hulin's one-axis
/// wall rule, judged along directions of the task space with the mass and
/// damping the device has there (analysis/task_space.hpp, m_n = 1 / (n^T J
/// M^-1 J^T n)). Which directions, the scene's plan says
/// (world::TaskWallJudgement):
///   plane-wall  its normal: m_n and the damping along n (cartesian_along:
///               exact with damping proportional to the mass, else a bound);
///   sphere      the worst direction, the smallest m_n over all directions:
///               the lightest axis (with the least damping per unit mass of
///               any axis, a bound unless the damping is proportional);
///   box         each face along its axis (the axes decouple: exact).
/// Along each, the one-axis wall with the scene's K, B and d on a rigid
/// device of that mass and damping goes through the one-axis gate, so the
/// limit along n is the one-axis Hulin limit with m_n, and a refusal names
/// the direction or axis with the limit that would hold.

#include <string>
#include <vector>

#include "analysis/stability_gate.hpp"
#include "analysis/task_space.hpp"

namespace hapticd::analysis {

/// One direction a task-space wall is judged along.
struct TaskDirection {
  std::string label;             ///< "the normal (0.7071, 0.7071)", "axis y", "the lightest axis, x"
  DirectionalModel along;        ///< m_n, the damping along it, exact or a bound, and how
  GateDevice device;             ///< the rigid one-axis device along it (m_n, b_n, T, d)
  world::ParameterSet one_axis;  ///< the one-axis wall judged there (K, B, d; surface at 0)
};

/// The directions of `plan` (a task-space wall) on `device` (its axes).
/// Throws std::invalid_argument when the device's axes cannot be judged
/// (none given, a mass not positive and finite, a damping below 0).
std::vector<TaskDirection> task_wall_directions(const world::ScenePlan& plan, const GateDevice& device);

/// The verdict of the worst direction (the first unstable one, else the
/// largest closed-loop pole radius), its summary naming the direction.
SceneStability check_task_wall_stability(const world::ScenePlan& plan, const GateDevice& device);

/// The gate's answer for a planned task-space wall.
GateOutcome gate_task_wall(world::ScenePlan plan, const GateDevice& device, bool force);

/// A scene on each axis of a Cartesian stage (StabilityRule::per_axis,
/// axis-springs): the plan's one-axis scene judged on each axis with that
/// axis' mass and damping (the axes decouple: exact). The verdict of the
/// worst axis, its summary naming the axis. Throws std::invalid_argument
/// for a device whose axes are not a Cartesian stage's (a pantograph).
SceneStability check_per_axis_stability(const world::ScenePlan& plan, const GateDevice& device);

/// The gate's answer for such a scene: a refusal names the axis and the
/// limit that would hold there (the one-axis gate's, on that axis).
GateOutcome gate_per_axis(world::ScenePlan plan, const GateDevice& device, bool force);

}  // namespace hapticd::analysis
