#pragma once
/// \file
/// The daemon's configuration: a TOML file (docs/config.md) parsed into
/// DaemonConfig. Every error is a ConfigError whose what() names the file,
/// line, column, key and what is accepted, e.g.
///   /etc/hapticd/hapticd.toml:4:10: loop.period = "5s" is out of range; accepted: 100us to 10ms
///
/// Scene parameters and driver parameters are not interpreted here: they are
/// kept in file order with their source positions, so the daemon can check
/// them against the scene catalog / the driver's parameter list and report
/// the file and line of a bad value.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "world/parameter.hpp"

namespace hapticd::daemon::config {

/// world's one ParameterValue (world/parameter.hpp): TOML integers are stored as double.
using world::ParameterValue;

/// Where something was written. line/column are 1-based; 0 when the value
/// comes from the built-in default.
struct SourcePosition {
  std::string file;
  std::uint32_t line = 0;
  std::uint32_t column = 0;
  /// "file:line:column", "file:line", or "file" (what is known).
  std::string to_string() const;
  bool operator==(const SourcePosition&) const = default;
};

/// One key of a free-form table ([scene], [device.<driver>]). Keys of nested
/// tables are flattened with dots: [device.loopback.hand] kind = "sine" gives
/// key "hand.kind".
struct Parameter {
  std::string key;
  ParameterValue value;
  SourcePosition where;  ///< position of the value
  bool operator==(const Parameter&) const = default;
};
using ParameterList = std::vector<Parameter>;  ///< in file order, keys unique

/// "file:line:column: message" (or without the unknown parts); what the
/// daemon uses to report a parameter the catalog or a driver rejects.
std::string format_error(const SourcePosition& where, std::string_view message);
/// A parameter value as TOML would write it: 1.5, true, "exact".
std::string to_toml(const ParameterValue& value);

enum class ClockKind { real, virtual_clock };
std::string_view to_string(ClockKind clock) noexcept;

struct LoopConfig {
  double period_s = 1e-3;   ///< 100e-6 .. 10e-3
  int priority = 80;        ///< SCHED_FIFO priority, 1..99
  int cpu = -1;             ///< -1: no pinning, else CPU index (0..1023)
  bool require_rt = false;  ///< refuse to run without SCHED_FIFO
  ClockKind clock = ClockKind::real;
  std::uint32_t overrun_limit = 10;  ///< consecutive overruns that latch a fault; 0 = never
  std::optional<double> duration_s;  ///< stop after this much loop time; nullopt = until signalled
  bool operator==(const LoopConfig&) const = default;
};

/// [device] encoder: what the position is relative to (docs/config.md, "Calibration").
enum class EncoderKind {
  incremental,  ///< counts from where the device powered up
  absolute,     ///< the same position reads the same across power cycles
};
std::string_view to_string(EncoderKind encoder) noexcept;

/// [device] origin: how long a calibration (device.zero, homing) lasts.
enum class OriginKeeping {
  session,  ///< until hapticd stops
  persist,  ///< also written to the state directory and restored at start-up
};
std::string_view to_string(OriginKeeping keeping) noexcept;

struct DeviceConfig {
  std::string driver = "loopback";
  double torque_limit = 1.0;  ///< N (linear) or N m (rotary), > 0
  /// Several axes: each axis' own limit, in the driver's order (a stage's
  /// motors differ); empty: torque_limit on every axis. Checked against the
  /// device's axes at start-up.
  std::vector<double> axis_torque_limit;
  SourcePosition axis_torque_limit_where;  ///< position of device.axis_torque_limit's value
  /// Axis i's limit: the smaller of torque_limit and its own, if given.
  double axis_limit(std::size_t i) const noexcept {
    return i < axis_torque_limit.size() ? std::min(torque_limit, axis_torque_limit[i]) : torque_limit;
  }
  /// Fastest plausible motion, m/s or rad/s, > 0: a reading that steps more
  /// than max_velocity x interval + one count latches "encoder jump /
  /// velocity limit". nullopt: derived from the device (docs/config.md).
  std::optional<double> max_velocity;
  ParameterList parameters;  ///< the [device.<driver>] table, unvalidated
  /// A device with several axes: each axis' name, in the driver's order
  /// (checked against the device's axes at start-up). Empty: x, y, z, a,
  /// b, c, as many as the device has.
  std::vector<std::string> axis_names;
  SourcePosition axis_names_where;  ///< position of device.axis_names' value
  /// Joints to task space on several axes: "cartesian" (one task axis per
  /// joint) or "pantograph" (the five-bar linkage, world/kinematics.hpp;
  /// only with the loopback's linkage = "pantograph", which provides it).
  std::string kinematics = "cartesian";
  /// A model file (`hapticctl identify --apply`) replacing the driver's model
  /// for the stability gate; resolved against the config file's directory. Empty: none.
  std::string model;
  EncoderKind encoder = EncoderKind::incremental;
  /// How long a calibration lasts; nullopt: "persist" for an absolute
  /// encoder, "session" for an incremental one (origin_keeping()).
  std::optional<OriginKeeping> origin;
  /// Where a persisted origin lives; "": origin.toml in the state directory
  /// (resolve_origin_file). Resolved against the config file's directory.
  std::string origin_file;
  /// No scene renders (output zero) until the device is calibrated.
  bool require_calibration = false;
  OriginKeeping origin_keeping() const noexcept {
    return origin.value_or(encoder == EncoderKind::absolute ? OriginKeeping::persist
                                                            : OriginKeeping::session);
  }
  SourcePosition origin_where;        ///< position of device.origin's value (else of [device])
  SourcePosition origin_file_where;   ///< position of device.origin_file's value (else of [device])
  SourcePosition model_where;         ///< position of device.model's value
  SourcePosition max_velocity_where;  ///< position of device.max_velocity's value
  SourcePosition driver_where;        ///< position of device.driver's value, else of the [device] key
  SourcePosition table_where;         ///< position of the [device.<driver>] key, else driver_where
  bool operator==(const DeviceConfig&) const = default;
};

/// [gravity] (issue 22 item 7): the weight a vertical axis of a stage
/// carries, or the pantograph's links in a vertical plane, held by a
/// feedforward the engine adds after the scene.
struct GravityConfig {
  bool configured = false;        ///< a [gravity] table was given
  std::string axis;               ///< the vertical axis' name (device.axis_names, else x, y, z, ...)
  double mass = 0.0;              ///< kg the axis lifts, > 0 and <= 100
  double acceleration = 9.80665;  ///< m/s^2, > 0 and <= 30
  bool down_positive = false;     ///< down = "positive": gravity pulls toward +axis
  SourcePosition table_where;     ///< position of the [gravity] key
  SourcePosition axis_where;      ///< position of gravity.axis' value
  SourcePosition mass_where;      ///< position of gravity.mass' value
  /// The pantograph in a vertical plane (y up): its links' masses, kg, each
  /// at the link's middle (proximal left, distal left, distal right,
  /// proximal right: world::PantographMasses); empty for a stage.
  std::vector<double> link_masses;
  double handle_mass = 0.0;          ///< kg at the handle, with link_masses
  SourcePosition link_masses_where;  ///< position of gravity.link_masses' value
  bool operator==(const GravityConfig&) const = default;
};

/// [workspace] (issue 22 item 7): a box or a sphere of task space the device
/// is held inside, a wall rendered on top of any scene. `shape` and the
/// box's or sphere's parameters, kept as the scene's are (file order,
/// positions) for the scene planner.
struct WorkspaceConfig {
  std::string shape;           ///< "" (none), "box" or "sphere"
  ParameterList parameters;    ///< every [workspace] key except shape, unvalidated
  SourcePosition shape_where;  ///< position of workspace.shape's value, else of [workspace]
  bool operator==(const WorkspaceConfig&) const = default;
};

struct SceneConfig {
  std::string name = "spring-wheel";
  ParameterList parameters;    ///< every [scene] key except name, unvalidated
  SourcePosition name_where;   ///< position of scene.name's value, else of the [scene] key
  SourcePosition table_where;  ///< position of the [scene] key (file only when absent)
  bool operator==(const SceneConfig&) const = default;
};

struct ControlConfig {
  std::string socket;                       ///< empty: default path resolution (daemon's business)
  std::string group;                        ///< group allowed to change things; empty: owner only
  std::uint32_t max_clients = 16;           ///< 1..1024
  std::uint32_t max_message_bytes = 65536;  ///< 1 KiB .. 16 MiB
  double idle_timeout_s = 300.0;            ///< 0 = never
  int cpu = -1;                             ///< the control thread's CPU; -1: any
  SourcePosition socket_where;              ///< position of socket's value (or "--socket")
  SourcePosition group_where;               ///< position of group's value
  bool operator==(const ControlConfig&) const = default;
};

struct RecorderConfig {
  /// Empty: $STATE_DIRECTORY/recordings under systemd, else "." (see
  /// resolve_recording_directory).
  std::string directory;
  double ring_seconds = 2.0;       ///< telemetry ring capacity, seconds of samples; 0.1..60
  double flush_interval_s = 0.1;   ///< 1ms..10s
  int cpu = -1;                    ///< the recorder thread's CPU; -1: any
  SourcePosition directory_where;  ///< position of directory's value (file only when absent)
  /// Ring capacity in samples for a loop period: ceil(ring_seconds / period), at least 2.
  std::size_t ring_capacity(double period_s) const noexcept;
  bool operator==(const RecorderConfig&) const = default;
};

/// [telemetry]: UDP datagrams in PlotJuggler's JSON format (docs/config.md).
/// Unauthenticated and unencrypted: only to loopback or the address named here.
struct TelemetryConfig {
  std::string udp;                    ///< "" (off) or "ADDRESS:PORT" (daemon/telemetry/udp_endpoint.hpp)
  double rate_hz = 100.0;             ///< samples per second, 0.1 .. the loop rate
  std::vector<std::string> channels;  ///< empty: the recording's columns
  std::vector<SourcePosition> channel_where;  ///< position of each entry of channels
  std::uint32_t batch = 1;                    ///< samples per datagram, 1 .. 64
  std::string prefix = "hapticd";             ///< the object holding the channels (/hapticd/position)
  SourcePosition udp_where;                   ///< position of udp's value (file only when absent)
  SourcePosition channels_where;              ///< position of channels' value
  bool operator==(const TelemetryConfig&) const = default;
};

struct DaemonConfig {
  std::string source;  ///< the file name, or "<built-in default>"
  LoopConfig loop;
  DeviceConfig device;
  SceneConfig scene;
  GravityConfig gravity;
  WorkspaceConfig workspace;
  ControlConfig control;
  RecorderConfig recorder;
  TelemetryConfig telemetry;
};

class ConfigError : public std::runtime_error {
 public:
  ConfigError(SourcePosition where, std::string key, std::string_view message);
  const SourcePosition& where() const noexcept { return where_; }
  /// Dotted key ("loop.period"), section ("[foo]") or empty for syntax errors.
  const std::string& key() const noexcept { return key_; }

 private:
  SourcePosition where_;
  std::string key_;
};

/// Reads and parses a file. Throws ConfigError (also when it cannot be read).
DaemonConfig load_config(const std::filesystem::path& path);
/// Parses TOML text; source_name is used in messages.
DaemonConfig parse_config(std::string_view text, std::string_view source_name);
/// A device model file's [model] table (docs/config.md, "Device model
/// files"), flattened in file order with positions; unvalidated. Throws
/// ConfigError when it cannot be read (at `named_at`, the device.model key
/// that names it, with the reason), is not TOML, or holds anything but [model].
ParameterList load_model_file(const std::filesystem::path& path, const SourcePosition& named_at = {});

/// The built-in default: loopback rotary wheel, scene spring-wheel with the
/// exact integrator, 1 ms period. Identical to config/hapticd.toml.
DaemonConfig default_config();
/// The TOML text of the built-in default (what config/hapticd.toml holds).
std::string_view default_config_text() noexcept;

/// The directory recordings go to: RecorderConfig::directory if set, else the
/// first entry of state_directory_env ($STATE_DIRECTORY, set by systemd's
/// StateDirectory=; colon-separated) + "/recordings", else ".".
std::filesystem::path resolve_recording_directory(const RecorderConfig& recorder,
                                                  const char* state_directory_env);
/// The file a persisted origin lives in: DeviceConfig::origin_file if set,
/// else the first entry of $STATE_DIRECTORY + "/origin.toml", else
/// "./origin.toml" (the daemon's working directory, as recordings).
std::filesystem::path resolve_origin_file(const DeviceConfig& device, const char* state_directory_env);

}  // namespace hapticd::daemon::config
