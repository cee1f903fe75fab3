#pragma once
/// \file
/// Typed driver parameters (JACK2's jack_driver_desc_t): each driver
/// describes the keys of its [device.<driver>] table once, with world's
/// ParameterSpec, and the config
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

#include <nlohmann/json_fwd.hpp>

#include "world/parameter.hpp"

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

// The vocabulary is world's (world/parameter.hpp), shared with the scenes
// and the config: one ParameterValue, ParameterType and ParameterSpec.
using world::ParameterSpec;
using world::ParameterType;
using world::ParameterValue;
using world::to_string;

/// The keys every device takes, declared once (DRIVERS.md): the device
/// cannot know its own moving mass, so the config says it for the stability
/// gate, with `motion` choosing the units of everything else. Every driver
/// lists them first; ranges are world::parameter_range's, as for the scenes.
/// A driver may replace the help or set a default (.defaults_to()).
ParameterSpec motion_parameter(
    std::string help = "rotary (rad, N m, kg m^2) or linear (m, N, kg): the units of everything below");
/// Required unless the driver gives a default.
ParameterSpec mass_parameter(
    std::string help = "moving inertia (rotary) or mass (linear) the stability gate uses");
/// 0 by default.
ParameterSpec damping_parameter(std::string help = "viscous damping to ground the stability gate uses");

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
