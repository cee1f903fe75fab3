#include "drivers/canopen/canopen_config.hpp"

#include <cmath>
#include <numbers>

#include "drivers/canopen/301/cob_id.hpp"

namespace hapticd::drivers::canopen {

namespace {

void require(bool ok, const std::string& message, const std::string& key) {
  if (!ok) throw ConfigError(message, key);
}

bool positive(double v) { return std::isfinite(v) && v > 0.0; }

/// A per-axis list has one value per node, or none (the common key's value on every node).
void require_one_per_node(std::size_t given, std::size_t nodes, const std::string& what, const char* key) {
  require(given == 0 || given == nodes,
          std::string(key) + " has " + std::to_string(given) + " " + what +
              "; accepted: one per node in node_ids (" + std::to_string(nodes) + ")",
          key);
}

/// The per-axis keys of a config without node_ids, each refused naming the one-drive key.
void refuse_axis_keys_for_one_drive(const CanopenConfig& c) {
  const auto one_drive = [](bool empty, const char* key, const char* instead) {
    require(empty, std::string(key) + " is for several drives (node_ids = \"1,2\"); one drive: " + instead,
            key);
  };
  one_drive(c.axis_mass.empty(), "axis_mass", "mass");
  one_drive(c.axis_damping.empty(), "axis_damping", "damping");
  one_drive(c.axis_homing_method.empty(), "axis_homing_method", "homing_method");
  one_drive(c.axis_home_offset.empty(), "axis_home_offset", "home_offset");
}

/// The keys of several drives on one bus: 2 to max_axes distinct node-IDs,
/// none hapticd's, one mass, damping, homing method and home offset per
/// axis or none (canopen_bus_device.cpp).
void validate_nodes(const CanopenConfig& c) {
  if (c.node_ids.empty()) {
    refuse_axis_keys_for_one_drive(c);
    return;
  }
  const std::size_t n = c.node_ids.size();
  require(n >= 2 && n <= static_cast<std::size_t>(max_axes),
          "node_ids names " + std::to_string(n) + " drive(s); accepted: 2 to " + std::to_string(max_axes) +
              " node-IDs, one per axis (one drive: node_id)",
          "node_ids");
  for (std::size_t i = 0; i < n; ++i) {
    require(cia301::valid_node_id(c.node_ids[i]), "node_ids: each node-ID must be 1..127", "node_ids");
    require(c.node_ids[i] != c.master_node_id,
            "node_ids: node " + std::to_string(c.node_ids[i]) +
                " is master_node_id: hapticd's heartbeat needs its own",
            "node_ids");
    for (std::size_t j = 0; j < i; ++j)
      require(
          c.node_ids[j] != c.node_ids[i],
          "node_ids: node " + std::to_string(c.node_ids[i]) + " is named twice; each axis has its own drive",
          "node_ids");
  }
  require_one_per_node(c.axis_mass.size(), n, "masses", "axis_mass");
  require_one_per_node(c.axis_damping.size(), n, "dampings", "axis_damping");
  require_one_per_node(c.axis_homing_method.size(), n, "homing methods", "axis_homing_method");
  require_one_per_node(c.axis_home_offset.size(), n, "home offsets", "axis_home_offset");
  for (double m : c.axis_mass) require(positive(m), "axis_mass: each mass must be > 0", "axis_mass");
  for (double b : c.axis_damping)
    require(std::isfinite(b) && b >= 0.0, "axis_damping: each damping must be >= 0", "axis_damping");
  for (int m : c.axis_homing_method)
    require(m >= -128 && m <= 127, "axis_homing_method: each method must be -128..127 (0x6098 is INTEGER8)",
            "axis_homing_method");
  for (double o : c.axis_home_offset)
    require(std::isfinite(o), "axis_home_offset: each offset must be a finite number", "axis_home_offset");
}

}  // namespace

std::vector<std::uint8_t> drive_nodes(const CanopenConfig& c) {
  return c.node_ids.empty() ? std::vector<std::uint8_t>{c.node_id} : c.node_ids;
}

CanopenConfig axis_config(const CanopenConfig& c, std::size_t axis) {
  CanopenConfig a = c;
  a.node_ids.clear();
  a.axis_mass.clear();
  a.axis_damping.clear();
  a.axis_homing_method.clear();
  a.axis_home_offset.clear();
  a.node_id = c.node_ids.at(axis);
  if (!c.axis_mass.empty()) a.mass = c.axis_mass.at(axis);
  if (!c.axis_damping.empty()) a.damping = c.axis_damping.at(axis);
  if (!c.axis_homing_method.empty()) a.homing_method = c.axis_homing_method.at(axis);
  if (!c.axis_home_offset.empty()) a.home_offset = c.axis_home_offset.at(axis);
  return a;
}

namespace {

/// Axis `axis`'s own homing values fit their objects; a refusal names the
/// per-axis key the value came from.
void check_axis_homing(const CanopenConfig& c, std::size_t axis) {
  try {
    (void)homing_settings(axis_config(c, axis));
  } catch (const ConfigError& e) {
    const bool own = (e.key() == "home_offset" && !c.axis_home_offset.empty()) ||
                     (e.key() == "homing_method" && !c.axis_homing_method.empty());
    if (!own) throw;
    throw ConfigError("axis " + std::to_string(axis + 1) + ": " + e.what(), "axis_" + e.key());
  }
}

}  // namespace

void validate(const CanopenConfig& c) {
  require(!c.interface.empty(),
          "interface is required: a CAN interface (\"can0\") or \"unix:/path\" of the simulated drive",
          "interface");
  require(c.interface != "unix:",
          "interface \"unix:\" needs the path of the simulated bus, e.g. \"unix:/run/hapticd/canbus\"",
          "interface");
  require(cia301::valid_node_id(c.node_id), "node_id must be 1..127", "node_id");
  require(cia301::valid_node_id(c.master_node_id), "master_node_id must be 1..127", "master_node_id");
  validate_nodes(c);
  require(!c.node_ids.empty() || c.master_node_id != c.node_id,
          "master_node_id " + std::to_string(c.master_node_id) +
              " is the drive's node_id: hapticd's heartbeat needs its own",
          "master_node_id");
  require(c.bitrate >= 10000 && c.bitrate <= 1000000, "bitrate must be 10000..1000000 bit/s (classic CAN)",
          "bitrate");
  require(positive(c.counts_per_unit),
          "counts_per_unit must be > 0 (0x6064 increments per output revolution or metre)",
          "counts_per_unit");
  require(std::isfinite(c.velocity_counts_per_unit) && c.velocity_counts_per_unit >= 0.0,
          "velocity_counts_per_unit must be >= 0 (0: the same as counts_per_unit, increments per second)",
          "velocity_counts_per_unit");
  require(positive(c.gear_ratio), "gear_ratio must be > 0", "gear_ratio");
  require(std::isfinite(c.rated_torque) && c.rated_torque >= 0.0,
          "rated_torque must be >= 0 (0: read 0x6076 from the drive)", "rated_torque");
  require(c.rated_torque * 1e3 <= 4294967295.0, "rated_torque is beyond 0x6076's range (UNSIGNED32 mN m)",
          "rated_torque");
  require(
      positive(c.heartbeat_period) && c.heartbeat_period * 1e3 >= 1.0 && c.heartbeat_period * 1e3 <= 65535.0,
      "heartbeat_period must be 1 ms..65.535 s (0x1017 is in whole ms)", "heartbeat_period");
  require(positive(c.heartbeat_timeout) && c.heartbeat_timeout * 1e3 <= 65535.0,
          "heartbeat_timeout must be > 0 and at most 65.535 s (0x1016 is in whole ms)", "heartbeat_timeout");
  require(c.heartbeat_timeout > c.heartbeat_period,
          "heartbeat_timeout (" + std::to_string(c.heartbeat_timeout * 1e3) +
              " ms) must exceed heartbeat_period (" + std::to_string(c.heartbeat_period * 1e3) +
              " ms), or every heartbeat would arrive late",
          "heartbeat_timeout");
  require(c.tpdo_timeout_periods >= 1 && c.tpdo_timeout_periods <= 100000,
          "tpdo_timeout_periods must be 1..100000", "tpdo_timeout_periods");
  require(positive(c.sdo_timeout) && c.sdo_timeout <= 10.0, "sdo_timeout must be > 0 and at most 10 s",
          "sdo_timeout");
  require(positive(c.mass), "mass must be > 0", "mass");
  require(std::isfinite(c.damping) && c.damping >= 0.0, "damping must be >= 0", "damping");
  require(c.homing_method >= -128 && c.homing_method <= 127,
          "homing_method must be -128..127 (0x6098 is INTEGER8)", "homing_method");
  require(positive(c.homing_timeout), "homing_timeout must be > 0", "homing_timeout");
  if (c.homing) {
    (void)homing_settings(c);  // every value fits its object
    for (std::size_t i = 0; i < c.node_ids.size(); ++i) check_axis_homing(c, i);
  }
}

namespace {

/// A speed or acceleration in the drive's units: 0 stays "the drive's own";
/// otherwise it must be at least one unit and fit UNSIGNED32.
std::optional<std::uint32_t> drive_units(double si, double units_per_si, const std::string& key,
                                         const std::string& unit) {
  require(std::isfinite(si) && si >= 0.0, key + " must be >= 0 (0: the drive's own)", key);
  if (si == 0.0) return std::nullopt;
  const double units = std::round(si * units_per_si);
  require(units >= 1.0 && units <= 4294967295.0,
          key + " = " + std::to_string(si) + " " + unit + " is " + std::to_string(units) +
              " drive units: CiA 402 takes 1..4294967295 (UNSIGNED32)",
          key);
  return static_cast<std::uint32_t>(units);
}

}  // namespace

HomingSettings homing_settings(const CanopenConfig& c) {
  const bool rotary = c.motion == Motion::rotary;
  const double unit = rotary ? 2.0 * std::numbers::pi : 1.0;
  const double counts_per_si = c.counts_per_unit / unit;
  const double velocity_per_si =
      (c.velocity_counts_per_unit > 0.0 ? c.velocity_counts_per_unit : c.counts_per_unit) / unit;
  HomingSettings h;
  h.method = static_cast<std::int8_t>(c.homing_method);
  // 0x607C in the drive's frame: `reversed` flips hapticd's.
  const double offset = std::round(c.home_offset * counts_per_si * (c.reversed ? -1.0 : 1.0));
  require(std::isfinite(offset) && offset >= -2147483648.0 && offset <= 2147483647.0,
          "home_offset = " + std::to_string(c.home_offset) + " is beyond 0x607C (INTEGER32 increments)",
          "home_offset");
  h.home_offset_counts = static_cast<std::int32_t>(offset);
  h.speed_switch =
      drive_units(c.homing_speed_switch, velocity_per_si, "homing_speed_switch", rotary ? "rad/s" : "m/s");
  h.speed_zero =
      drive_units(c.homing_speed_zero, velocity_per_si, "homing_speed_zero", rotary ? "rad/s" : "m/s");
  h.acceleration = drive_units(c.homing_acceleration, velocity_per_si, "homing_acceleration",
                               rotary ? "rad/s^2" : "m/s^2");
  h.timeout_s = c.homing_timeout;
  return h;
}

Scaling scaling(const CanopenConfig& c, std::uint32_t rated_torque_mnm) {
  const double sign = c.reversed ? -1.0 : 1.0;
  const double unit = c.motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0;  // rad per rev, m per m
  Scaling s;
  s.si_per_count = sign * unit / c.counts_per_unit;
  s.si_per_velocity_unit =
      sign * unit / (c.velocity_counts_per_unit > 0.0 ? c.velocity_counts_per_unit : c.counts_per_unit);
  const double rated = c.rated_torque > 0.0 ? c.rated_torque : rated_torque_mnm * 1e-3;
  s.force_per_permille = sign * rated * 1e-3 * c.gear_ratio;
  return s;
}

}  // namespace hapticd::drivers::canopen
