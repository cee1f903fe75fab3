#pragma once
/// \file
/// The scripted hand of the loopback device. A HandScript is a small value
/// parsed from key=value text, e.g.
///   mode=hold trajectory=step amplitude=0.785398 at=0.5
///   mode=hold trajectory=sine amplitude=0.0872665 frequency=1 phase=0
///   mode=free
///   mode=force force=0.2 at=1
///   mode=impedance stiffness=50 damping=1 position=0
///   ... release_at=2.0      (combinable with any mode)
/// Times (at, release_at, the sine's t) are seconds of simulated time since
/// the script took effect (the first write() that saw it).
/// Sign convention: the hand force is the force the hand applies to the
/// device (on the body for the two-mass plant); positive increases position.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hapticd::drivers::simulation {

enum class HandMode { free, hold, force, impedance };
enum class TrajectoryKind { constant, step, ramp, sine };

std::string_view to_string(HandMode mode) noexcept;
std::string_view to_string(TrajectoryKind kind) noexcept;

/// A reference position r(t) and its derivative.
struct Trajectory {
  TrajectoryKind kind = TrajectoryKind::constant;
  double position = 0.0;   ///< constant value; step/sine offset ("offset" is an alias)
  double amplitude = 0.0;  ///< step height or sine amplitude
  double at = 0.0;         ///< step time; ramp start time, s
  double rate = 0.0;       ///< ramp speed magnitude, m/s or rad/s (> 0)
  double from = 0.0;       ///< ramp start position
  double to = 0.0;         ///< ramp end position
  double frequency = 0.0;  ///< sine frequency, Hz
  double phase = 0.0;      ///< sine phase, rad

  struct Sample {
    double position = 0.0;
    double velocity = 0.0;
  };
  /// r(t), r'(t). Step: r = position + amplitude for t >= at (velocity 0).
  /// Ramp: from until at, then towards `to` at `rate`, then holds `to`.
  /// Sine: position + amplitude sin(2 pi frequency t + phase).
  Sample at_time(double t) const noexcept;
  bool operator==(const Trajectory&) const = default;
};

struct HandScript {
  HandMode mode = HandMode::free;
  Trajectory trajectory{};  ///< hold and impedance: the reference
  /// hold: true constrains the body exactly to the trajectory at every sample
  /// (position and velocity overwritten; the hand force is whatever it takes);
  /// false holds it through a stiff spring-damper (stiffness/damping, or by
  /// default a critically damped 30 Hz impedance on the total mass).
  bool ideal = true;
  std::optional<double> stiffness;   ///< impedance (required), hold ideal=false (optional): N/m or N m/rad
  std::optional<double> damping;     ///< impedance/hold ideal=false: N s/m or N m s/rad (impedance default 0)
  double force = 0.0;                ///< force mode: N or N m
  double force_at = 0.0;             ///< force mode: the force is 0 before this time ("at")
  std::optional<double> release_at;  ///< from this time on the hand lets go (mode free)

  /// Hand force for mode = force at script time t (ignores release_at).
  double force_at_time(double t) const noexcept { return t >= force_at ? force : 0.0; }
  bool released(double t) const noexcept { return release_at && t >= *release_at; }

  /// Back to key=value text (parse_hand_script(to_text()) == *this).
  std::string to_text() const;
  bool operator==(const HandScript&) const = default;
};

/// Every key a script may hold (which of them apply depends on the mode and
/// the trajectory), "offset" (the alias of position) included.
std::vector<std::string_view> hand_script_keys();

/// Parses key=value text. Throws std::invalid_argument with one line naming
/// the bad key or value and what is accepted.
HandScript parse_hand_script(std::string_view text);

/// Non-throwing form: nothing on error, the one-line message in `error`.
std::optional<HandScript> try_parse_hand_script(std::string_view text, std::string& error);

}  // namespace hapticd::drivers::simulation
