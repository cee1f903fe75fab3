#pragma once
/// \file
/// The canopen driver's settings, typed and in SI, and what follows from
/// them: the scaling between the drive's units (0x6064 increments, 0x606C
/// velocity units, 0x6071 per mille of 0x6076) and the output in rad or m,
/// N m or N. The parameter table for the driver registry is built from the
/// same names (canopen_driver.cpp).

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "drivers/canopen/homing.hpp"
#include "drivers/device_hooks.hpp"
#include "drivers/parameter.hpp"

namespace hapticd::drivers::canopen {

struct CanopenConfig {
  std::string interface;     ///< "can0", or "unix:/path" for the simulated drive
  std::uint8_t node_id = 1;  ///< the drive's CANopen node-ID
  /// Several drives on one bus, one per axis in this order (README.md,
  /// "Several drives on one bus"); empty: the one drive node_id.
  std::vector<std::uint8_t> node_ids;
  std::vector<double> axis_mass;     ///< per axis, kg (kg m^2); empty: mass on every axis
  std::vector<double> axis_damping;  ///< per axis, N s/m (N m s/rad); empty: damping on every axis
  std::uint32_t bitrate = 1000000;   ///< bit/s, as set with `ip link set can0 type can bitrate ...`
  Motion motion = Motion::rotary;
  double counts_per_unit = 16384.0;  ///< 0x6064 increments per output revolution (rotary) or metre (linear)
  double velocity_counts_per_unit =
      0.0;                    ///< 0x606C units per output rev/s or m/s; 0: counts_per_unit (increments/s)
  double gear_ratio = 1.0;    ///< output N m (N) per motor N m: gearbox N:1 -> N; screw of lead L -> 2 pi / L
  bool reversed = false;      ///< flips position and force
  double rated_torque = 0.0;  ///< motor N m (N for a linear motor); 0: read 0x6076 from the drive
  double heartbeat_period = 0.02;  ///< s: hapticd's heartbeat and the drive's (0x1017)
  double heartbeat_timeout =
      0.1;  ///< s: the drive stops when hapticd's heartbeat is older (0x1016), and vice versa
  std::uint32_t tpdo_timeout_periods = 3;  ///< a TPDO missing this many periods in a row is a fault
  double sdo_timeout = 0.1;                ///< s, per SDO transfer (configuration, commissioning)
  std::uint8_t master_node_id = 127;       ///< the node-ID hapticd's heartbeat carries
  bool velocity_pdo = false;               ///< map 0x606C in TPDO2 (only for a scene that uses the velocity)
  double mass = 0.01;    ///< kg m^2 (kg): moving inertia for the stability gate (the drive cannot know it)
  double damping = 0.0;  ///< N m s/rad (N s/m)
  // CiA 402 homing before the loop (README.md, "Homing"); SI, converted by homing_settings().
  bool homing = false;             ///< homing = "cia402"
  int homing_method = 37;          ///< 0x6098 (37: on the current position)
  double home_offset = 0.0;        ///< 0x607C, rad (m): the zero lies this far past the home position
  double homing_speed_switch = 0;  ///< 0x6099:1, rad/s (m/s); 0: the drive's own
  double homing_speed_zero = 0;    ///< 0x6099:2, rad/s (m/s); 0: the drive's own
  double homing_acceleration = 0;  ///< 0x609A, rad/s^2 (m/s^2); 0: the drive's own
  double homing_timeout = 20.0;    ///< s, from the start command to homing attained
  /// With node_ids: each node's own 0x6098 method and 0x607C offset (each
  /// axis has its own switches); empty: homing_method, home_offset on every node.
  std::vector<int> axis_homing_method;
  std::vector<double> axis_home_offset;
};

/// A setting that cannot work, naming the key.
class ConfigError : public std::invalid_argument {
 public:
  ConfigError(const std::string& message, std::string key)
      : std::invalid_argument(message), key_(std::move(key)) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

/// The drives hapticd runs: node_ids, or node_id alone.
std::vector<std::uint8_t> drive_nodes(const CanopenConfig& config);
/// The settings of axis `axis` (0-based) of a config with node_ids: its
/// node_id, mass, damping, homing method and home offset; everything else shared.
CanopenConfig axis_config(const CanopenConfig& config, std::size_t axis);

/// Checks ranges and the relations between keys (the heartbeat timeout must
/// exceed its period, the node-IDs differ ...). Throws ConfigError.
void validate(const CanopenConfig& config);

/// The scaling from the drive's units to the output's SI units.
struct Scaling {
  double si_per_count = 0.0;          ///< rad (m) per 0x6064 increment, with the sign of `reversed`
  double si_per_velocity_unit = 0.0;  ///< rad/s (m/s) per 0x606C unit
  double force_per_permille = 0.0;    ///< output N m (N) per 0x6071 unit
};
/// rated_torque_mnm: 0x6076 as read (mN m), used when config.rated_torque is 0.
Scaling scaling(const CanopenConfig& config, std::uint32_t rated_torque_mnm);

/// The homing keys in the drive's units (0x607C increments, 0x6099 velocity
/// units, 0x609A velocity units per second). Throws ConfigError naming the
/// key when a value does not fit its object (or rounds to 0).
HomingSettings homing_settings(const CanopenConfig& config);

/// The typed config from a checked [device.canopen] table; throws
/// ParameterError naming the key.
CanopenConfig canopen_config_from(const DriverParameters& parameters);

}  // namespace hapticd::drivers::canopen
