#pragma once
/// \file
/// Self-description of the scenes (JACK2 style) and the off-RT planner that
/// turns a scene name + parameters into a ready-to-run AnyScene. Used by the
/// CLI, the config loader and the control protocol.
///
/// Parameter names are the CLI flag names without dashes; values are SI.

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "world/any_scene.hpp"
#include "world/state_space.hpp"
#include "world/units.hpp"

namespace hapticd::world {

/// Same enumerators, same order as drivers::Motion (world/ does not depend on drivers/).
enum class Motion { rotary, linear };

using ParameterValue = std::variant<double, bool, std::string>;
using ParameterSet = std::map<std::string, ParameterValue, std::less<>>;

enum class ParameterType { number, integer, enumeration, boolean };
/// "number", "integer", "enum", "bool".
std::string_view to_string(ParameterType type) noexcept;

struct ParameterDescription {
  std::string name;
  ParameterType type = ParameterType::number;
  std::string unit;         ///< SI unit for a linear device (or the scene's only motion)
  std::string rotary_unit;  ///< SI unit when the device is rotary
  ParameterValue default_value;
  std::string help;
  /// enum: the accepted values; number: accepted words besides numbers ("auto").
  std::vector<std::string> accepted;
  std::optional<double> minimum;
  bool minimum_exclusive = false;
  std::optional<double> maximum;
};

struct SceneDescription {
  std::string name;
  std::string reference;  ///< paper and equations
  std::string summary;
  std::vector<ParameterDescription> parameters;
};

struct ChannelDescription {
  std::string name;
  std::string unit;
};

struct SceneError {
  std::string message;  ///< one line, names the bad parameter and what is accepted
  /// The given parameter at fault; empty when no single one is (unknown scene, build failure).
  std::string parameter{};
};

struct ScenePlan {
  std::string scene;
  ParameterSet parameters;  ///< complete: defaults filled, enums canonical, damping "auto" resolved to T k
  AnyScene scene_object;
  std::vector<ChannelDescription> channels;
  std::optional<DiscreteLinearScene> linear;  ///< spring scenes; wall: the in-contact law
  std::vector<std::string> notes;             ///< e.g. how damping=auto was resolved
};

using PlanResult = std::variant<ScenePlan, SceneError>;

/// Validates and builds. Numbers may be given as doubles or as numeric text
/// ("12.5"), integers as integral doubles or text, enums as text, bools as
/// bool or "true"/"false". Unknown parameters are refused. Off the RT path.
/// `motion` chooses the units of wall and relay (spring-wheel is always
/// rotary, spring-mass always linear).
PlanResult plan_scene(std::string_view name, const ParameterSet& given, double period_s,
                      Motion motion = Motion::linear);

const std::vector<SceneDescription>& scene_catalog();
/// nullptr if unknown.
const SceneDescription* find_scene(std::string_view name) noexcept;
/// "spring-wheel, spring-mass, wall, relay, chirp, free"
std::string scene_names();

/// Accepted ranges of physical parameters: generous but finite, so that a
/// typo (a 1e-300 kg mass, a 1e308 N s/m damper) is refused instead of
/// overflowing the analysis or the scene. Shared by the scene catalog, the
/// loopback driver and `hapticctl analyze`; docs/scenes.md and docs/config.md
/// list them. Linear units; the same numbers on a rotary device (N m/rad, ...).
namespace parameter_range {
inline constexpr double max_stiffness = 1e9;     ///< N/m: a steel bar 1 cm^2 x 2 cm is 1e9 N/m
inline constexpr double min_mass = 1e-9;         ///< kg (kg m^2): a microgram
inline constexpr double max_mass = 1e6;          ///< kg (kg m^2): a thousand tonnes
inline constexpr double max_damping = 1e6;       ///< N s/m
inline constexpr double max_force = 1e6;         ///< N (N m)
inline constexpr double max_position = 1e6;      ///< |x| in m (rad: ~160000 turns)
inline constexpr double max_duration_s = 1e6;    ///< s: eleven days of an experiment
inline constexpr double max_frequency_hz = 1e6;  ///< Hz (a scene also checks it against 1/(2T))
}  // namespace parameter_range

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
