#pragma once
/// \file
/// What a scene says about itself, as drivers do (drivers/registry.hpp): its
/// parameters, what it needs from the device, how the stability gate judges
/// it, and the factory that builds its RT type from validated parameters.
/// Each scene writes its own in world/<name>_scene.cpp; the registry
/// (world/scene_registry.hpp) lists them; plan_scene, the gate, scene.list,
/// `hapticd --list-scenes` and docs/scenes.md read nothing else.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "world/parameter.hpp"

namespace hapticd::world {

struct ScenePlan;  // world/scene_catalog.hpp

/// How the stability gate (analysis/stability_gate.hpp) judges a scene.
enum class StabilityRule {
  /// Not a feedback law with a linear model (relay, chirp, free): no region
  /// applies, the torque limit holds.
  none,
  /// The factory sets the plan's linear model; the gate checks it held and
  /// closed with the released device (Hulin 2), and on a refusal bisects the
  /// `stiffness` parameter if the scene has one.
  linear,
  /// linear, and the scene is Hulin's wall (parameters stiffness K, damping B,
  /// delay d): on a rigid, undamped device a refusal also says what Hulin's
  /// region (eq. 1) allows.
  hulin_wall,
  /// A wall in task space (world/task_scenes.hpp): the factory sets the
  /// plan's TaskWallJudgement, and the gate judges Hulin's one-axis wall
  /// along each of its directions with the mass the device has there.
  task_wall,
  /// A scene on each axis of a Cartesian stage (axis-springs): the factory
  /// sets the plan's PerAxisJudgement, and the gate judges that one-axis
  /// scene on each axis with the axis' own mass and damping (exact: the
  /// axes decouple), refusing with the axis and its limit.
  per_axis,
};
std::string_view to_string(
    StabilityRule rule) noexcept;  ///< "none", "linear", "hulin_wall", "task_wall", "per_axis"

/// Where a scene lives: on one axis (position and force scalars), in task
/// space (a device with several axes), or either (free).
enum class SceneSpace { one_axis, task, any };
std::string_view to_string(SceneSpace space) noexcept;  ///< "one-axis", "task", "any"

/// What the factory is given besides the validated parameters.
struct SceneContext {
  double period_s = 1e-3;
  Motion motion = Motion::linear;  ///< the scene's fixed motion, else the device's
  int axes = 1;                    ///< the device's axes (task dimensions), 1 to max_axes
};

/// Builds the scene from plan.parameters (complete, canonical): sets
/// plan.scene_object to the variant alternative that uses no more than the
/// parameters need (set_scene in world/scene_catalog.hpp), and may resolve a
/// parameter (damping auto) with a note. Throws std::invalid_argument when
/// the values do not make a scene at this period. Off the RT path.
using SceneFactory = void (*)(ScenePlan& plan, const SceneContext& context);

struct SceneDescription {
  std::string name;
  std::string reference;  ///< paper and equations
  std::string summary;
  std::vector<ParameterSpec> parameters;  ///< every one with a default
  /// What it needs from the device: nothing fixed (its units follow the
  /// device's motion), or a motion it is written for (a wheel is rotary).
  std::optional<Motion> fixed_motion;
  StabilityRule stability = StabilityRule::none;
  /// The gate's advice when even a vanishing stiffness is unstable; "" none.
  std::string unstable_hint;
  SceneFactory build = nullptr;
  SceneSpace space = SceneSpace::one_axis;
};

}  // namespace hapticd::world
