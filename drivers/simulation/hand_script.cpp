#include "drivers/simulation/hand_script.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include "drivers/parameter.hpp"
#include "drivers/simulation/key_value.hpp"
#include "world/text.hpp"
#include "world/units.hpp"

namespace hapticd::drivers::simulation {

namespace {

constexpr std::array<std::string_view, 4> mode_names{"free", "hold", "force", "impedance"};
constexpr std::array<std::string_view, 4> trajectory_names{"constant", "step", "ramp", "sine"};
constexpr std::array<std::string_view, 16> key_names{
    "mode", "trajectory", "position", "offset", "amplitude", "at",      "rate",  "from",
    "to",   "frequency",  "phase",    "ideal",  "stiffness", "damping", "force", "release_at"};
constexpr std::string_view all_keys =
    "mode, trajectory, position (alias offset), amplitude, at, rate, from, to, frequency, phase, ideal, "
    "stiffness, damping, force, release_at";

/// key: the hand-script key the error is about (ParameterError::key()).
[[noreturn]] void refuse_script(std::string_view key, const std::string& message) {
  throw ParameterError(std::string(key), "hand script: " + message);
}

using world::text::join;
// Shortest text that reads back as the same double (0.1, not 0.10000000000000001).
using world::text::format_number;

/// The largest magnitude a key's number may have: far beyond any device, and
/// small enough that the trajectory stays finite every period (a sine's
/// velocity amplitude 2 pi f is at most 1e3 * 6.3e4; w t + phase over 1e9 s
/// at 1e4 Hz is 6e13). 1e308 Hz made sin(w t) NaN (found by fuzzing).
double magnitude_limit(std::string_view key) {
  if (key == "frequency") return 1e4;                  // Hz
  if (key == "at" || key == "release_at") return 1e9;  // s
  if (key == "stiffness") return 1e9;                  // N/m or N m/rad
  if (key == "rate" || key == "damping" || key == "force" || key == "phase") return 1e6;
  return 1e3;  // position (offset), amplitude, from, to: m or rad
}

}  // namespace

std::string_view to_string(HandMode mode) noexcept { return mode_names[static_cast<std::size_t>(mode)]; }
std::string_view to_string(TrajectoryKind kind) noexcept {
  return trajectory_names[static_cast<std::size_t>(kind)];
}

Trajectory::Sample Trajectory::at_time(double t) const noexcept {
  switch (kind) {
    case TrajectoryKind::constant:
      return {position, 0.0};
    case TrajectoryKind::step:
      return {t >= at ? position + amplitude : position, 0.0};
    case TrajectoryKind::ramp: {
      if (t <= at || from == to) return {t <= at ? from : to, 0.0};
      const double direction = to > from ? 1.0 : -1.0;
      const double travelled = rate * (t - at);
      if (travelled >= std::abs(to - from)) return {to, 0.0};
      return {from + direction * travelled, direction * rate};
    }
    case TrajectoryKind::sine: {
      const double w = 2.0 * world::units::pi * frequency;
      const double angle = w * t + phase;
      return {position + amplitude * std::sin(angle), amplitude * w * std::cos(angle)};
    }
  }
  return {position, 0.0};
}

std::string HandScript::to_text() const {
  std::string out = "mode=" + std::string(to_string(mode));
  auto add = [&out](std::string_view key, double value) {
    out += ' ';
    out += key;
    out += '=';
    out += format_number(value);
  };
  if (mode == HandMode::hold || mode == HandMode::impedance) {
    out += " trajectory=" + std::string(to_string(trajectory.kind));
    switch (trajectory.kind) {
      case TrajectoryKind::constant:
        add("position", trajectory.position);
        break;
      case TrajectoryKind::step:
        add("position", trajectory.position);
        add("amplitude", trajectory.amplitude);
        add("at", trajectory.at);
        break;
      case TrajectoryKind::ramp:
        add("rate", trajectory.rate);
        add("from", trajectory.from);
        add("to", trajectory.to);
        add("at", trajectory.at);
        break;
      case TrajectoryKind::sine:
        add("position", trajectory.position);
        add("amplitude", trajectory.amplitude);
        add("frequency", trajectory.frequency);
        add("phase", trajectory.phase);
        break;
    }
    if (mode == HandMode::hold) out += ideal ? " ideal=true" : " ideal=false";
    if (stiffness) add("stiffness", *stiffness);
    if (damping) add("damping", *damping);
  }
  if (mode == HandMode::force) {
    add("force", force);
    add("at", force_at);
  }
  if (release_at) add("release_at", *release_at);
  return out;
}

std::vector<std::string_view> hand_script_keys() { return {key_names.begin(), key_names.end()}; }

namespace {

using KeyValues = std::vector<std::pair<std::string, std::string>>;

/// Unknown keys and keys given twice (position and its alias offset count as
/// one), refused before anything else so that the message names the key.
void refuse_unknown_or_repeated_keys(const KeyValues& pairs) {
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const std::string& key = pairs[i].first;
    const bool known = key == "mode" || key == "trajectory" || key == "position" || key == "offset" ||
                       key == "amplitude" || key == "at" || key == "rate" || key == "from" || key == "to" ||
                       key == "frequency" || key == "phase" || key == "ideal" || key == "stiffness" ||
                       key == "damping" || key == "force" || key == "release_at";
    if (!known) refuse_script(key, "unknown key '" + key + "'; accepted: " + std::string(all_keys));
    for (std::size_t j = 0; j < i; ++j) {
      const bool alias = (key == "offset" && pairs[j].first == "position") ||
                         (key == "position" && pairs[j].first == "offset");
      if (pairs[j].first == key || alias) refuse_script(key, "key '" + key + "' given twice");
    }
  }
}

/// The text the script gives `key`, or nullptr when it does not give it.
const std::string* script_value(const KeyValues& pairs, std::string_view key) {
  for (const auto& [k, v] : pairs) {
    if (k == key) return &v;
  }
  return nullptr;
}

/// A key's number: finite and within magnitude_limit(key).
double script_number(std::string_view key, const std::string& value) {
  const auto parsed = world::units::parse_finite(value);
  if (!parsed) refuse_script(key, std::string(key) + "=" + value + " is not a finite number");
  const double limit = magnitude_limit(key);
  if (std::abs(*parsed) > limit) {
    refuse_script(key, std::string(key) + "=" + value + " is out of range; accepted: -" +
                           format_number(limit) + " to " + format_number(limit));
  }
  return *parsed;
}

/// mode=: required, one of free, hold, force, impedance.
HandMode parse_hand_mode(const KeyValues& pairs) {
  const std::string* mode = script_value(pairs, "mode");
  if (!mode)
    refuse_script("mode", "missing mode; accepted: mode=" + join({"free", "hold", "force", "impedance"}));
  const auto it = std::find(mode_names.begin(), mode_names.end(), *mode);
  if (it == mode_names.end())
    refuse_script("mode", "mode=" + *mode + " is not one of free, hold, force, impedance");
  return static_cast<HandMode>(it - mode_names.begin());
}

TrajectoryKind parse_trajectory_kind(const std::string& text) {
  const auto it = std::find(trajectory_names.begin(), trajectory_names.end(), text);
  if (it == trajectory_names.end())
    refuse_script("trajectory", "trajectory=" + text + " is not one of constant, step, ramp, sine");
  return static_cast<TrajectoryKind>(it - trajectory_names.begin());
}

/// hold and impedance move the hand along a trajectory (the reference).
bool follows_trajectory(HandMode mode) { return mode == HandMode::hold || mode == HandMode::impedance; }

/// The keys that apply to the script's mode and, with a reference, its trajectory.
std::vector<std::string_view> accepted_keys(const HandScript& script) {
  std::vector<std::string_view> accepted{"mode", "release_at"};
  if (follows_trajectory(script.mode)) {
    accepted.push_back("trajectory");
    switch (script.trajectory.kind) {
      case TrajectoryKind::constant:
        accepted.insert(accepted.end(), {"position", "offset"});
        break;
      case TrajectoryKind::step:
        accepted.insert(accepted.end(), {"position", "offset", "amplitude", "at"});
        break;
      case TrajectoryKind::ramp:
        accepted.insert(accepted.end(), {"rate", "from", "to", "at"});
        break;
      case TrajectoryKind::sine:
        accepted.insert(accepted.end(), {"position", "offset", "amplitude", "frequency", "phase"});
        break;
    }
    accepted.insert(accepted.end(), {"stiffness", "damping"});
    if (script.mode == HandMode::hold) accepted.push_back("ideal");
  }
  if (script.mode == HandMode::force) accepted.insert(accepted.end(), {"force", "at"});
  return accepted;
}

/// Refuses the first key that the mode (and trajectory) does not use, with the keys that apply.
void refuse_keys_that_do_not_apply(const KeyValues& pairs, const HandScript& script) {
  const std::vector<std::string_view> accepted = accepted_keys(script);
  for (const auto& [key, value] : pairs) {
    if (std::find(accepted.begin(), accepted.end(), key) != accepted.end()) continue;
    std::string list;
    for (const auto name : accepted) {
      if (!list.empty()) list += ", ";
      list += name;
    }
    std::string context = "mode=" + std::string(to_string(script.mode));
    if (follows_trajectory(script.mode)) {
      context += " trajectory=" + std::string(to_string(script.trajectory.kind));
    }
    refuse_script(key, "key '" + key + "' does not apply to " + context + "; accepted: " + list);
  }
}

/// ideal=: true, 1 or yes; false, 0 or no.
bool parse_ideal(const std::string& text) {
  if (text == "true" || text == "1" || text == "yes") return true;
  if (text == "false" || text == "0" || text == "no") return false;
  refuse_script("ideal", "ideal=" + text + " is not one of true, false");
}

/// Every numeric key into its field, in the order the script gives them.
void assign_script_numbers(const KeyValues& pairs, HandScript& script) {
  Trajectory& r = script.trajectory;
  for (const auto& [key, value] : pairs) {
    if (key == "mode" || key == "trajectory" || key == "ideal") continue;
    const double x = script_number(key, value);
    if (key == "position" || key == "offset")
      r.position = x;
    else if (key == "amplitude")
      r.amplitude = x;
    else if (key == "at" && script.mode == HandMode::force)
      script.force_at = x;
    else if (key == "at")
      r.at = x;
    else if (key == "rate")
      r.rate = x;
    else if (key == "from")
      r.from = x;
    else if (key == "to")
      r.to = x;
    else if (key == "frequency")
      r.frequency = x;
    else if (key == "phase")
      r.phase = x;
    else if (key == "stiffness")
      script.stiffness = x;
    else if (key == "damping")
      script.damping = x;
    else if (key == "force")
      script.force = x;
    else if (key == "release_at")
      script.release_at = x;
  }
}

/// A missing key is blamed on the key that asks for it (the mode, or the trajectory).
void require_script_key(const KeyValues& pairs, const HandScript& script, std::string_view key,
                        std::string_view asked_by = "mode") {
  if (!script_value(pairs, key))
    refuse_script(asked_by, "mode=" + std::string(to_string(script.mode)) + " needs " + std::string(key));
}

/// The keys the reference's trajectory needs, and its rate and frequency > 0.
void check_trajectory_keys(const KeyValues& pairs, const HandScript& script) {
  if (!follows_trajectory(script.mode)) return;
  const Trajectory& r = script.trajectory;
  switch (r.kind) {
    case TrajectoryKind::constant:
      break;
    case TrajectoryKind::step:
      require_script_key(pairs, script, "amplitude", "trajectory");
      break;
    case TrajectoryKind::ramp:
      require_script_key(pairs, script, "rate", "trajectory");
      require_script_key(pairs, script, "to", "trajectory");
      if (!(r.rate > 0.0)) refuse_script("rate", "rate must be > 0 (got " + format_number(r.rate) + ")");
      break;
    case TrajectoryKind::sine:
      require_script_key(pairs, script, "amplitude", "trajectory");
      require_script_key(pairs, script, "frequency", "trajectory");
      if (!(r.frequency > 0.0))
        refuse_script("frequency", "frequency must be > 0 Hz (got " + format_number(r.frequency) + ")");
      break;
  }
}

/// The keys the mode needs, and the hand's own spring-damper: only on a
/// non-ideal hold, stiffness > 0, damping >= 0.
void check_hand_keys(const KeyValues& pairs, const HandScript& script) {
  if (script.mode == HandMode::force) require_script_key(pairs, script, "force");
  if (script.mode == HandMode::impedance) require_script_key(pairs, script, "stiffness");
  if (script.mode == HandMode::hold && script.ideal && (script.stiffness || script.damping)) {
    refuse_script(
        script.stiffness ? "stiffness" : "damping",
        "stiffness/damping apply to mode=hold only with ideal=false (ideal=true constrains the position "
        "exactly)");
  }
  if (script.stiffness && !(*script.stiffness > 0.0)) {
    refuse_script("stiffness", "stiffness must be > 0 (got " + format_number(*script.stiffness) + ")");
  }
  if (script.damping && !(*script.damping >= 0.0)) {
    refuse_script("damping", "damping must be >= 0 (got " + format_number(*script.damping) + ")");
  }
}

}  // namespace

HandScript parse_hand_script(std::string_view text) {
  const auto pairs = detail::split_key_values(text, "hand script");
  refuse_unknown_or_repeated_keys(pairs);
  HandScript script;
  script.mode = parse_hand_mode(pairs);
  if (follows_trajectory(script.mode)) {
    if (const std::string* kind = script_value(pairs, "trajectory")) {
      script.trajectory.kind = parse_trajectory_kind(*kind);
    }
  }
  refuse_keys_that_do_not_apply(pairs, script);
  if (const std::string* ideal = script_value(pairs, "ideal")) script.ideal = parse_ideal(*ideal);
  assign_script_numbers(pairs, script);
  check_trajectory_keys(pairs, script);
  check_hand_keys(pairs, script);
  return script;
}

std::optional<HandScript> try_parse_hand_script(std::string_view text, std::string& error) {
  try {
    return parse_hand_script(text);
  } catch (const std::invalid_argument& e) {
    error = e.what();
    return std::nullopt;
  }
}

}  // namespace hapticd::drivers::simulation
