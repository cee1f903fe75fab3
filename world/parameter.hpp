#pragma once
/// \file
/// One vocabulary for typed parameters (JACK2's jack_driver_param_desc_t):
/// a scene's parameters (world/scene_description.hpp), a driver's keys
/// (drivers/parameter.hpp), the config's values (daemon/config) and the
/// protocol's params are all ParameterValue, described by a ParameterSpec.
/// Pure data: each owner checks its values against the specs, with its own
/// messages (world::plan_scene for scenes, drivers::DriverParameters for a
/// [device.<driver>] table).

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace hapticd::world {

/// The device's kind of motion; units follow it: rotary rad, N m, kg m^2,
/// linear m, N, kg.
enum class Motion { rotary, linear };
std::string_view to_string(Motion motion) noexcept;  ///< "rotary", "linear"

/// A value as a config, a request or a default gives it. TOML integers and
/// JSON numbers arrive as double.
using ParameterValue = std::variant<double, bool, std::string>;
/// Values by name.
using ParameterSet = std::map<std::string, ParameterValue, std::less<>>;

enum class ParameterType {
  number,    ///< a finite double
  integer,   ///< a whole number
  boolean,   ///< true or false
  text,      ///< any string (a path, an interface name)
  choice,    ///< one of `accepted`
  duration,  ///< seconds: a number, or text with s, ms or us ("250us")
  table,     ///< key = value pairs: a [device.<driver>.<name>] table, or the same as one text line
};
/// "number", "integer", "bool", "text", "choice", "duration", "table".
std::string_view to_string(ParameterType type) noexcept;

/// One parameter. Built fluently, e.g.
///   ParameterSpec::number("stiffness", "N/m", "wall stiffness K").on_rotary("N m/rad")
///       .defaults_to(9000.0).at_least(0).at_most(1e9)
struct ParameterSpec {
  /// choice: the canonical spelling of an accepted alias ("tustin" ->
  /// "trapezoid"), or nothing; `accepted` lists the canonical names only.
  using Canonical = std::optional<std::string> (*)(std::string_view text);

  static ParameterSpec number(std::string name, std::string unit, std::string help);
  static ParameterSpec integer(std::string name, std::string unit, std::string help);
  static ParameterSpec boolean(std::string name, std::string help);
  static ParameterSpec text(std::string name, std::string help);
  static ParameterSpec choice(std::string name, std::vector<std::string> accepted, std::string help);
  static ParameterSpec duration(std::string name, std::string help);
  static ParameterSpec table(std::string name, std::string help);
  ParameterSpec& defaults_to(ParameterValue value, std::string note = {});
  ParameterSpec& at_least(double value);  ///< minimum, inclusive
  ParameterSpec& above(double value);     ///< minimum, exclusive
  ParameterSpec& at_most(double value);   ///< maximum, inclusive
  /// The unit on a rotary device, when it differs from `unit` (a scene whose
  /// units follow the device's motion: N/m, N m/rad).
  ParameterSpec& on_rotary(std::string unit);
  /// number: a word accepted besides numbers ("auto"), kept as text.
  ParameterSpec& or_word(std::string word);
  /// choice: aliases accepted and stored in their canonical spelling.
  ParameterSpec& canonical_by(Canonical canonical);

  /// `rotary_unit` on a rotary device if there is one, else `unit`.
  const std::string& unit_on(Motion motion) const noexcept;

  std::string name;
  ParameterType type = ParameterType::number;
  /// nullopt: required. For a table: empty text.
  std::optional<ParameterValue> default_value;
  std::string default_note;  ///< when the default depends on another key ("0.1 kg when motion = linear")
  std::optional<double> minimum;
  bool minimum_exclusive = false;
  std::optional<double> maximum;
  /// choice: the values; number: the words accepted besides numbers.
  std::vector<std::string> accepted;
  Canonical canonical = nullptr;
  /// SI unit ("N/m", "kg"), "" if none. A driver key whose unit follows the
  /// driver's own motion key writes both, rotary first: "kg m^2 | kg".
  std::string unit;
  std::string rotary_unit;  ///< empty: `unit` on either motion
  std::string help;
};

/// Accepted ranges of physical parameters: generous but finite, so that a
/// typo (a 1e-300 kg mass, a 1e308 N s/m damper) is refused instead of
/// overflowing the analysis or the scene. Shared by the scenes, the keys
/// every device takes (drivers/parameter.hpp) and `hapticctl analyze`; docs/scenes.md and docs/config.md
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

}  // namespace hapticd::world
