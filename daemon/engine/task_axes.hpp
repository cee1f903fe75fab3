#pragma once
/// \file
/// The RT thread's state for a device with several axes (issue 22): the
/// kinematics, the task scene, one position guard per axis and the vectors
/// of one period, all of fixed capacity (world::max_axes): the several-axis
/// cycle (task_cycle.cpp) allocates nothing. A one-axis device has none of
/// this; its cycle is engine.cpp's run_cycle as it always was.

#include <array>

#include <optional>
#include "daemon/engine/safety.hpp"
#include "drivers/device_hooks.hpp"

#include "world/any_scene.hpp"
#include "world/gravity.hpp"
#include "world/kinematics.hpp"

namespace hapticd::daemon::engine {

static_assert(drivers::max_axes == world::max_axes, "the drivers' and the kinematics' axis capacity agree");

/// The telemetry channels a device with several axes adds before the
/// scene's: each axis' position, then its task force (the scene's and the
/// workspace wall's, before the limit), then its joint output (sent to the
/// device); a linkage whose joints are not its task axes (the pantograph)
/// adds the handle's task position after them; then, with [gravity], each
/// axis' feedforward (before the limit) and, with [workspace], the workspace
/// wall's penetration.
inline constexpr std::size_t channels_per_axis = 3;

struct TaskAxes {
  TaskAxes(int axes, world::Kinematics kinematics, PositionStepRule rule);

  int axes;
  world::Kinematics kinematics;
  world::AnyTaskScene scene{};
  std::array<PositionStepGuard, world::max_axes> guards;
  std::array<drivers::Reading, world::max_axes> readings{};
  world::AxisVector joints;  ///< the last reading of every axis (a refused one too)
  world::TaskState task;     ///< where the handle is, and J there
  world::AxisVector force;   ///< the task scene's force, N
  world::AxisVector output;  ///< J^T F after the common saturation factor, sent
  world::AxisVector limits;  ///< each joint's limit |tau_i|
  /// [gravity]: the model, and this period's joint feedforward tau_g.
  std::optional<world::GravityModel> gravity;
  world::AxisVector feedforward;
  /// [workspace]: the wall held on top of every scene, and its force this period.
  std::optional<world::AnyTaskScene> workspace;
  world::AxisVector workspace_force;
  /// The pantograph: its task position is not its joints' (telemetry shows both).
  bool linkage = false;
  /// Channels before the scene's: 3 per axis (+ the task position of a linkage).
  std::size_t axis_channels() const noexcept {
    return channels_per_axis * static_cast<std::size_t>(axes) +
           (linkage ? static_cast<std::size_t>(force.size()) : 0);
  }
};

}  // namespace hapticd::daemon::engine
