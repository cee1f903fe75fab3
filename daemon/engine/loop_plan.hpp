#pragma once
/// \file
/// What the control thread hands the RT thread at a period boundary: an
/// immutable, fully planned scene and the limits that go with it. The RT
/// thread copies `scene` into its own storage (every scene alternative is a
/// few doubles and fixed arrays: the copy does not allocate) and resets it at
/// the measured position, so a switch never makes a torque step.

#include <cstdint>

#include "world/any_scene.hpp"
#include "world/kinematics.hpp"

namespace hapticd::daemon::engine {

struct LoopPlan {
  world::AnyScene scene;
  /// What a device with several axes runs (task position in, task force out).
  world::AnyTaskScene task_scene;
  double torque_limit = 0.0;  ///< N or N m, applied after the scene, always (each axis' on several)
  /// Several axes: each joint's own limit ([device] axis_torque_limit, the
  /// smaller of it and torque_limit); empty: torque_limit on every joint.
  world::AxisVector axis_torque_limits;
  bool unstable_forced = false;  ///< loaded with force=true although analysis says unstable
};

}  // namespace hapticd::daemon::engine
