#pragma once
/// \file
/// Off-RT planning of a scene for the device at hand, before anything reaches
/// the RT thread: the stability gate of analysis/stability_gate.hpp (validate
/// the parameters, check numerical and closed-loop stability with the
/// device's mass or inertia, period and delay; refuse unstable sets with the
/// limit that would have held, unless forced), on the driver's DeviceModel,
/// with the answers in the protocol's JSON.

#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/stability_gate.hpp"
#include "drivers/device.hpp"
#include "world/plant.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::daemon {

/// What the stability checks know about the device, at the loop's period.
struct DeviceModel {
  drivers::DeviceModel info;  ///< what the driver says (mass, damping, delay, optional plant)
  world::LinearPlant plant;   ///< info.plant, or the rigid mass with its viscous damping
  world::Sensor sensor = world::Sensor::motor;
  double period_s = 1e-3;
  /// A device with several axes: their names ([device] axis_names), one per
  /// entry of info.axes; empty for one axis.
  std::vector<std::string> axis_names;
  world::Motion motion() const noexcept { return info.motion; }
  /// The same device as the stability gate (analysis/stability_gate.hpp) sees it.
  analysis::GateDevice gate() const;
  /// "J = 0.01 kg m^2, b = 0 N m s/rad, T = 1 ms, d = 0" (or m = ... kg for a linear device).
  std::string describe() const;
};

/// The model of a configured device for the gate.
DeviceModel make_device_model(const drivers::Device& device, double period_s);
/// The same from a model given as it is (an identified one, daemon/device_model.hpp).
DeviceModel make_device_model(drivers::DeviceModel info, double period_s);

/// The verdict that goes with a plan, reported to clients and recordings.
using StabilityVerdict = analysis::SceneStability;
nlohmann::json to_json(const StabilityVerdict& verdict);

struct PlannedScene {
  world::ScenePlan plan;
  StabilityVerdict stability;
  bool forced = false;  ///< unstable, loaded on purpose with force=true
};

struct PlanRefusal {
  bool invalid = false;  ///< bad parameters (vs. valid but unstable)
  std::string message;   ///< one line: what was wrong and what would be accepted or hold
  nlohmann::json data;   ///< e.g. {"limit": {"stiffness": ...}}
  bool assessed = true;  ///< false: no stability verdict could be computed; force does not apply
  /// The given parameter at fault (world::SceneError::parameter); empty when
  /// the set as a whole is refused (unstable, or it cannot be built).
  std::string parameter{};
};

using PlanOutcome = std::variant<PlannedScene, PlanRefusal>;

/// How to load an unstable set on purpose, in the words of each front end.
inline constexpr std::string_view force_over_rpc = "Send force=true (hapticctl --force)";
inline constexpr std::string_view force_in_config = "Set force = true in [scene]";

/// The refusal's message, plus for an unstable (not invalid, assessed) set
/// how to load it anyway (`how`: force_over_rpc or force_in_config).
std::string refusal_text(const PlanRefusal& refusal, std::string_view how);

/// Plans `scene` with `parameters` (missing ones take their defaults) for the
/// device: analysis::gate_scene, with the refusal's limits as JSON.
PlanOutcome plan_on_device(std::string_view scene, const world::ParameterSet& parameters,
                           const DeviceModel& device, bool force);

/// Stability of an already validated plan on the device.
StabilityVerdict check_stability(const world::ScenePlan& plan, const DeviceModel& device);

/// The parameters as a JSON object; those the scene's catalog entry types as
/// integers (the wall's delay) are integers, not 1.0.
nlohmann::json to_json(const world::ParameterSet& parameters, std::string_view scene = {});
/// {name: unit} for every parameter of `scene` ({} if unknown).
nlohmann::json parameter_units(std::string_view scene, world::Motion motion);
/// The scene catalog as scene.list's "scenes": every scene with its
/// parameters, their units on a device of this motion, defaults and ranges,
/// and what it needs from the device and how the gate judges it.
/// The scenes a device with `axes` axes takes: one axis, today's (the
/// list is exactly what it was); several, the task-space scenes and free,
/// each with its "space".
nlohmann::json scene_catalog_json(world::Motion motion, int axes = 1);
/// docs/scenes.md's parameter tables (`hapticd --list-scenes --format
/// markdown`), between the markers a test (scenes_doc) compares.
std::string scene_catalog_markdown();
/// JSON object -> parameters (numbers, booleans, strings); throws std::invalid_argument otherwise.
world::ParameterSet parameters_from_json(const nlohmann::json& object);
std::string to_text(const world::ParameterValue& value);

}  // namespace hapticd::daemon
