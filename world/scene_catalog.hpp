#pragma once
/// \file
/// The scene catalog (the registry's descriptions, world/scene_registry.hpp)
/// and the off-RT planner that turns a scene name + parameters into a
/// ready-to-run AnyScene: it validates against the scene's description and
/// calls the scene's factory. Used by the CLI, the config loader and the
/// control protocol.
///
/// Parameter names are the CLI flag names without dashes; values are SI.

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "world/any_scene.hpp"
#include "world/parameter.hpp"
#include "world/passivity_scene.hpp"
#include "world/scene_description.hpp"
#include "world/state_space.hpp"
#include "world/units.hpp"

namespace hapticd::world {

/// The name scene.list and `hapticd --list-scenes` give a parameter's type:
/// as to_string(type), but a choice is "enum" (protocol 1 said so first).
std::string_view scene_type_name(ParameterType type) noexcept;

struct ChannelDescription {
  std::string name;
  std::string unit;
};

struct SceneError {
  std::string message;  ///< one line, names the bad parameter and what is accepted
  /// The given parameter at fault; empty when no single one is (unknown scene, build failure).
  std::string parameter{};
};

/// A scene judged one axis at a time (StabilityRule::per_axis): the
/// one-axis scene `scene` with `parameters` on each axis of the device.
struct PerAxisJudgement {
  std::string scene;
  ParameterSet parameters;
  /// Each axis' own set when they differ (axis-springs' axis_stiffness,
  /// axis_mass, axis_damping);
  /// empty: `parameters` on every axis.
  std::vector<ParameterSet> axes{};
  const ParameterSet& on_axis(std::size_t i) const { return axes.empty() ? parameters : axes.at(i); }
};

struct ScenePlan {
  std::string scene;
  const SceneDescription* description = nullptr;  ///< the catalog's entry (lives as long as the program)
  ParameterSet parameters;  ///< complete: defaults filled, enums canonical, damping "auto" resolved to T k
  AnyScene scene_object;
  /// What a device with several axes runs (task-space scenes, and free):
  /// world/task_scenes.hpp. Unused on one axis.
  AnyTaskScene task_object;
  /// A task-space wall: what the stability gate judges (StabilityRule::task_wall).
  std::optional<TaskWallJudgement> task_wall;
  /// A scene on each axis of a stage: what the gate judges on each (StabilityRule::per_axis).
  std::optional<PerAxisJudgement> per_axis;
  std::vector<ChannelDescription> channels;
  std::optional<DiscreteLinearScene> linear;  ///< spring scenes; wall: the in-contact law
  std::vector<std::string> notes;             ///< e.g. how damping=auto was resolved
};

using PlanResult = std::variant<ScenePlan, SceneError>;

/// Validates and builds. Numbers may be given as doubles or as numeric text
/// ("12.5"), integers as integral doubles or text, enums as text, bools as
/// bool or "true"/"false". Unknown parameters are refused. Off the RT path.
/// `motion` (the device's) chooses the units of a scene without a fixed
/// motion (wall, relay); spring-wheel is always rotary, spring-mass linear.
/// `axes` (the device's, 1 to max_axes) decides where the scene may run: a
/// task-space scene needs several axes, a one-axis scene one (SceneSpace);
/// either is refused otherwise, saying which scenes the device takes.
PlanResult plan_scene(std::string_view name, const ParameterSet& given, double period_s,
                      Motion motion = Motion::linear, int axes = 1);

/// The scenes a device with this many axes takes: "spring-wheel, ..." or
/// "plane-wall, sphere, box, free".
std::string scene_names_for(int axes);

/// Every registered scene's description (world/scene_registry.hpp), in registry order.
const std::vector<SceneDescription>& scene_catalog();
/// nullptr if unknown.
const SceneDescription* find_scene(std::string_view name) noexcept;
/// "spring-wheel, spring-mass, wall, relay, chirp, free"
std::string scene_names();

/// What a scene parameter accepts, in its units on a device of this motion:
/// "a finite number >= 0 and <= 1e+09 (N/m) or auto", "one of upper, lower".
std::string accepted_text(const ParameterSpec& parameter, Motion motion);

/// Telemetry channels of a scene type's names: positions in m or rad,
/// velocities in m/s or rad/s, "armed" in 1, passivity_energy in J and
/// passivity_damping in N s/m or N m s/rad.
std::vector<ChannelDescription> describe_channels(std::span<const std::string_view> names, Motion motion);

/// For a scene's factory: a validated value of one of the scene's own
/// parameters (a number, or the text of a choice).
double number_of(const ParameterSet& parameters, std::string_view name);
const std::string& text_of(const ParameterSet& parameters, std::string_view name);

/// For a scene's factory: the plan runs `scene`, with its linear model (if
/// the type has one) and its telemetry channels.
template <class S>
void set_scene(ScenePlan& plan, S scene, Motion motion) {
  if constexpr (requires { scene.linear_model(); }) plan.linear = scene.linear_model();
  plan.channels = describe_channels(S::channel_names, motion);
  plan.scene_object = std::move(scene);
}

/// For a task-space scene's factory: the plan runs `scene` on a device with
/// several axes, with its telemetry channels (positions in m).
template <class S>
void set_task_scene(ScenePlan& plan, S scene) {
  plan.channels = describe_channels(S::channel_names, Motion::linear);
  plan.task_object = std::move(scene);
}

/// For a scene's factory with the passivity option (world/passivity_scene.hpp):
/// the scene as it is when the option is off, wrapped with the observer when on.
template <StoresEnergy S>
void set_scene(ScenePlan& plan, S scene, Motion motion, const PassivityOptions& passivity) {
  if (passivity.mode == PassivityMode::off) {
    set_scene(plan, std::move(scene), motion);
  } else {
    set_scene(plan, PassivityControlledScene<S>(std::move(scene), passivity.observer), motion);
  }
}

/// Named defaults, derived from the papers (computed, not typed in).
namespace scene_defaults {
// Freudenberg 2.1: 1 Hz wheel, at most 800 N mm of reaction torque for a 45 degree move.
inline constexpr double wheel_natural_frequency_hz = 1.0;
inline constexpr double wheel_max_torque_n_mm = 800.0;
inline constexpr double wheel_max_angle_deg = 45.0;
inline constexpr double wheel_stiffness =
    units::n_mm_to_n_m(wheel_max_torque_n_mm) / units::deg_to_rad(wheel_max_angle_deg);  // N m/rad
inline constexpr double wheel_inertia =
    wheel_stiffness / (units::hz_to_rad_per_s(wheel_natural_frequency_hz) *
                       units::hz_to_rad_per_s(wheel_natural_frequency_hz));  // kg m^2
// spring-mass: a 0.5 kg virtual mass at 2 Hz.
inline constexpr double mass_natural_frequency_hz = 2.0;
inline constexpr double mass_mass = 0.5;
inline constexpr double mass_stiffness = mass_mass * units::hz_to_rad_per_s(mass_natural_frequency_hz) *
                                         units::hz_to_rad_per_s(mass_natural_frequency_hz);  // N/m
// Hulin section 7: PHANToM-like m = 0.1 kg, T = 1 ms, d = 1, optimum of the
// normalized square error (alpha = 0.09, beta = 0.46). Note B = beta m / T =
// 46 N s/m; the paper prints 4.6 N s/m, which (beta = 0.046) is unstable.
inline constexpr double hulin_mass = 0.1;
inline constexpr double hulin_period_s = 1e-3;
inline constexpr double hulin_alpha = 0.09;
inline constexpr double hulin_beta = 0.46;
inline constexpr int hulin_delay_samples = 1;
inline constexpr double wall_stiffness = hulin_alpha * hulin_mass / (hulin_period_s * hulin_period_s);
inline constexpr double wall_damping = hulin_beta * hulin_mass / hulin_period_s;
inline constexpr double relay_amplitude = 1.0;  // N
}  // namespace scene_defaults

}  // namespace hapticd::world
