#pragma once
/// \file
/// Typed driver parameters (JACK2's jack_driver_desc_t): each driver
/// describes the keys of its [device.<driver>] table once, and the config
/// parser, its errors, `hapticd --list-drivers`, `hapticctl device` and
/// docs/driver-parameters.md all come from that description.

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

namespace hapticd::drivers {

/// A driver parameter (or a key of a table parameter, such as the loopback's
/// hand script) is refused. It names the key structurally, so whoever holds
/// the key's source position (the daemon's config, the CLI) points at it
/// without reading the message.
class ParameterError : public std::invalid_argument {
 public:
  /// key: the key as written ("damping", "hand.amplitude"); empty when no
  /// key can be named (malformed text).
  ParameterError(std::string key, const std::string& message)
      : std::invalid_argument(message), key_(std::move(key)) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

/// Same alternatives as world::ParameterValue and the config's values (a
/// TOML integer arrives as a double).
using ParameterValue = std::variant<double, bool, std::string>;

enum class ParameterType {
  number,    ///< a finite double
  integer,   ///< a whole number
  boolean,   ///< true or false
  text,      ///< any string (a path, an interface name)
  choice,    ///< one of `accepted`
  duration,  ///< seconds: a number, or text with s, ms or us ("250us")
  table,     ///< key = value pairs: a [device.<driver>.<name>] table, or the same as one text line
};
std::string_view to_string(ParameterType type) noexcept;  ///< "number", "integer", ...

/// One key of a driver's table. Built fluently, e.g.
///   ParameterSpec::number("mass", "kg", "moving mass").defaults_to(0.1).above(0).at_most(1e6)
struct ParameterSpec {
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

  std::string name;  ///< key in [device.<driver>]
  ParameterType type = ParameterType::number;
  /// nullopt: required. For a table: empty text.
  std::optional<ParameterValue> default_value;
  std::string default_note;  ///< when the default depends on another key ("0.1 kg when motion = linear")
  std::optional<double> minimum;
  bool minimum_exclusive = false;
  std::optional<double> maximum;
  std::vector<std::string> accepted;  ///< choice: the values
  std::string unit;                   ///< SI unit ("N m", "kg m^2 | kg"), "" if none
  std::string help;
};

/// "a number in (0, 1e6] kg", "one of rigid, two-mass", "a duration in 100us..10ms".
std::string accepted_text(const ParameterSpec& spec);
/// The value as TOML would write it: 1.5, true, "text".
std::string to_text(const ParameterValue& value);

/// The typed, complete values of one [device.<driver>] table: defaults
/// filled, every value checked against its spec. Keys of a table parameter
/// arrive flattened ("hand.mode") and are kept as text for the driver.
class DriverParameters {
 public:
  /// Throws ParameterError naming the key (unknown key, wrong type, out of
  /// range, missing required key) and what is accepted. `driver` is used in
  /// messages ("device.loopback.mass").
  DriverParameters(std::string driver, const std::vector<ParameterSpec>& specs,
                   const std::map<std::string, ParameterValue, std::less<>>& given);

  double number(std::string_view name) const;
  std::int64_t integer(std::string_view name) const;
  bool boolean(std::string_view name) const;
  const std::string& text(std::string_view name) const;  ///< text and choice
  double duration_s(std::string_view name) const;
  /// A table parameter's entries, "key=value" per entry, in key order, with
  /// its one-line text form first if given.
  std::vector<std::pair<std::string, std::string>> table(std::string_view name) const;
  /// The key was written in the config (not defaulted).
  bool given(std::string_view name) const;
  /// Every value in force, for `hapticctl device` (tables as text).
  nlohmann::json to_json() const;
  const std::string& driver() const noexcept { return driver_; }

 private:
  const ParameterValue& value(std::string_view name, ParameterType type) const;

  std::string driver_;
  std::map<std::string, ParameterValue, std::less<>> values_;
  std::map<std::string, std::vector<std::pair<std::string, std::string>>, std::less<>> tables_;
  std::vector<std::string> given_;
};

nlohmann::json to_json(const ParameterSpec& spec);

}  // namespace hapticd::drivers
