#pragma once
/// \file
/// What the config adds on top of every scene of a device with several axes
/// (issue 22 item 7), as the vendor SDKs have it: gravity compensation
/// ([gravity]: the constant force that holds a vertical axis of a stage, or
/// the torques that hold the pantograph's links in a vertical plane, added
/// after the scene as a joint feedforward) and a workspace ([workspace]:
/// a box or a sphere the device is held inside, a task-space wall stepped
/// beside the scene, before J^T). Built once at start-up, off the RT thread;
/// the workspace wall passes the stability gate as the scene's walls do.

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/config/config.hpp"
#include "daemon/planner.hpp"
#include "world/any_scene.hpp"
#include "world/gravity.hpp"

namespace hapticd::daemon {

struct TaskOverlay {
  std::optional<world::GravityModel> gravity;
  std::optional<world::AnyTaskScene> workspace;
  std::optional<PlannedScene> workspace_plan;  ///< the wall as planned and judged
  nlohmann::json status;                       ///< status' "gravity" and "workspace" (only those configured)
  std::vector<std::string> notes;              ///< one line each for a recording's header
  /// The channels the engine writes after each axis' three: gravity_<axis>
  /// (N, or N m on rotary joints: the feedforward before the limit) and
  /// workspace_penetration (m).
  std::vector<world::ChannelDescription> channels(const std::vector<std::string>& axis_names,
                                                  bool rotary) const;
};

/// [gravity] and [workspace] for `device`. Throws config::ConfigError naming
/// the key and what is accepted: either on one axis, an axis name that is not
/// the device's, a weight the torque limit cannot hold, a workspace
/// parameter the box or sphere refuses, or a workspace wall the gate finds
/// unstable (with the largest stiffness that would hold).
TaskOverlay make_task_overlay(const config::DaemonConfig& config, const DeviceModel& device);

}  // namespace hapticd::daemon
