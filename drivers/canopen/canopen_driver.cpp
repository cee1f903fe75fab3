// The canopen driver's self-description for the registry (parameters with
// types, units, ranges, help) and its factory.

#include <algorithm>
#include <cmath>

#include "drivers/canopen/canopen_bus_device.hpp"
#include "drivers/canopen/canopen_device.hpp"
#include "drivers/driver_description.hpp"

namespace hapticd::drivers::canopen {

namespace {

using P = ParameterSpec;

/// CiA 402 homing before the loop (0x6098, 0x607C, 0x6099, 0x609A).
std::vector<ParameterSpec> homing_parameters() {
  const CanopenConfig d;
  return {
      P::choice("homing", {"none", "cia402"},
                "cia402: the drive homes (mode 6) before the loop, then cyclic synchronous torque; the "
                "device counts as calibrated")
          .defaults_to("none"),
      P::integer("homing_method", "",
                 "0x6098 homing method (37: on the current position; 17, 18: on a limit switch)")
          .defaults_to(37.0)
          .at_least(-128)
          .at_most(127),
      P::number(
          "home_offset", "rad | m",
          "0x607C: the zero lies this far past the home position (the home position reads -home_offset)")
          .defaults_to(0.0)
          .at_least(-1e6)
          .at_most(1e6),
      P::number("homing_speed_switch", "rad/s | m/s", "0x6099:1 speed while searching for the switch")
          .defaults_to(0.0, "0: the drive's own")
          .at_least(0.0)
          .at_most(1e6),
      P::number("homing_speed_zero", "rad/s | m/s", "0x6099:2 speed while searching for zero")
          .defaults_to(0.0, "0: the drive's own")
          .at_least(0.0)
          .at_most(1e6),
      P::number("homing_acceleration", "rad/s^2 | m/s^2", "0x609A homing acceleration")
          .defaults_to(0.0, "0: the drive's own")
          .at_least(0.0)
          .at_most(1e9),
      P::text("axis_homing_method",
              "with node_ids: each node's 0x6098 homing method, comma-separated (\"17,18\"); unset: "
              "homing_method on every node")
          .defaults_to(""),
      P::text("axis_home_offset",
              "with node_ids: each node's 0x607C home offset (rad | m), comma-separated; unset: home_offset "
              "on every node")
          .defaults_to(""),
      P::duration("homing_timeout", "from the start command to homing completed")
          .defaults_to(d.homing_timeout)
          .above(0.0)
          .at_most(600.0),
  };
}

std::vector<ParameterSpec> make_parameters() {
  const CanopenConfig d;
  return {
      motion_parameter(),
      mass_parameter(
          "moving inertia (rotary) or mass (linear) the stability gate uses: the drive cannot know it"),
      damping_parameter(),
      P::text("interface", "SocketCAN interface (can0), or unix:/path of the simulated drive's bus")
          .defaults_to("can0"),
      P::integer("node_id", "", "the drive's CANopen node-ID").defaults_to(1.0).at_least(1).at_most(127),
      P::text("node_ids",
              "several drives on one bus, one per axis in this order: their node-IDs, comma-separated "
              "(\"1,2\"): one SYNC for all, each node's PDOs, heartbeat and EMCY")
          .defaults_to("", "one drive: node_id"),
      P::text("axis_mass",
              "with node_ids: each axis' moving mass (kg, kg m^2 rotary), comma-separated; unset: mass on "
              "every axis")
          .defaults_to(""),
      P::text("axis_damping",
              "with node_ids: each axis' damping (N s/m, N m s/rad rotary), comma-separated; unset: damping "
              "on every axis")
          .defaults_to(""),
      P::integer("bitrate", "bit/s", "the bus bit rate (as set with ip link), for the bus budget")
          .defaults_to(static_cast<double>(d.bitrate))
          .at_least(10e3)
          .at_most(1e6),
      P::number("counts_per_unit", "1/rev | 1/m",
                "0x6064 position increments per output revolution (rotary) or metre (linear)")
          .above(0.0)
          .at_most(1e12),
      P::number("velocity_counts_per_unit", "1/rev | 1/m",
                "0x606C units per output rev/s or m/s (with velocity_pdo)")
          .defaults_to(0.0, "0: counts_per_unit, i.e. increments per second")
          .at_least(0.0)
          .at_most(1e12),
      P::number("gear_ratio", "",
                "output N m (N) per motor N m: gearbox N:1 -> N; screw of lead L -> 2 pi / L")
          .defaults_to(1.0)
          .above(0.0)
          .at_most(1e6),
      P::boolean("reversed", "flip the sign of position and force").defaults_to(false),
      P::number("rated_torque", "N m | N", "motor rated torque: the unit of 0x6071 (per mille of it)")
          .defaults_to(0.0, "0: read 0x6076 from the drive")
          .at_least(0.0)
          .at_most(4e6),
      P::duration("heartbeat_period", "hapticd's heartbeat and the drive's (0x1017), whole ms")
          .defaults_to(d.heartbeat_period)
          .at_least(1e-3)
          .at_most(65.535),
      P::duration(
          "heartbeat_timeout",
          "the drive faults when hapticd's heartbeat is older (0x1016), and hapticd when the drive's is")
          .defaults_to(d.heartbeat_timeout)
          .at_least(2e-3)
          .at_most(65.535),
      P::integer("tpdo_timeout_periods", "periods", "a TPDO missing this many periods in a row is a fault")
          .defaults_to(static_cast<double>(d.tpdo_timeout_periods))
          .at_least(1)
          .at_most(100000),
      P::duration("sdo_timeout", "per SDO transfer (configuration, commissioning)")
          .defaults_to(d.sdo_timeout)
          .at_least(1e-3)
          .at_most(10.0),
      P::integer("master_node_id", "", "the node-ID hapticd's heartbeat carries")
          .defaults_to(static_cast<double>(d.master_node_id))
          .at_least(1)
          .at_most(127),
      P::boolean("velocity_pdo", "map 0x606C velocity actual in TPDO2 (one more frame per period)")
          .defaults_to(false),
  };
}

/// "1,2" -> {1, 2}; "" -> {}. Throws ParameterError naming the key and what is accepted.
std::vector<double> number_list(const DriverParameters& p, const std::string& key,
                                const std::string& accepted) {
  const std::string& text = p.text(key);
  std::vector<double> out;
  if (text.empty()) return out;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t end = std::min(text.find(',', begin), text.size());
    const std::string item = text.substr(begin, end - begin);
    std::size_t used = 0;
    double value = std::nan("");
    try {
      value = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    while (used < item.size() && item[used] == ' ') ++used;
    if (used == 0 || used != item.size() || !std::isfinite(value))
      throw ParameterError(key, "device.canopen." + key + " = \"" + text + "\": '" + item +
                                    "' is not a number; accepted: " + accepted);
    out.push_back(value);
    begin = end + 1;
  }
  return out;
}

/// "17,18" -> {17, 18}: whole numbers only (the range is validate()'s).
std::vector<int> method_list(const DriverParameters& p) {
  const std::string accepted =
      "one 0x6098 method (-128..127) per node in node_ids, comma-separated (\"17,18\")";
  std::vector<int> methods;
  for (const double m : number_list(p, "axis_homing_method", accepted)) {
    if (m != std::floor(m) || std::abs(m) > 1e6)
      throw ParameterError("axis_homing_method",
                           "device.canopen.axis_homing_method = \"" + p.text("axis_homing_method") +
                               "\": " + std::to_string(m) + " is no whole number; accepted: " + accepted);
    methods.push_back(static_cast<int>(m));
  }
  return methods;
}

std::vector<std::uint8_t> node_list(const DriverParameters& p) {
  const std::string accepted = "node-IDs 1..127, comma-separated, one per axis (\"1,2\")";
  std::vector<std::uint8_t> nodes;
  for (const double id : number_list(p, "node_ids", accepted)) {
    if (id != std::floor(id) || id < 1.0 || id > 127.0)
      throw ParameterError("node_ids", "device.canopen.node_ids = \"" + p.text("node_ids") + "\": " +
                                           std::to_string(id) + " is no node-ID; accepted: " + accepted);
    nodes.push_back(static_cast<std::uint8_t>(id));
  }
  return nodes;
}

}  // namespace

CanopenConfig canopen_config_from(const DriverParameters& p) {
  CanopenConfig c;
  c.motion = p.text("motion") == "linear" ? Motion::linear : Motion::rotary;
  c.mass = p.number("mass");
  c.damping = p.number("damping");
  c.interface = p.text("interface");
  c.node_id = static_cast<std::uint8_t>(p.integer("node_id"));
  c.node_ids = node_list(p);
  c.axis_mass = number_list(p, "axis_mass", "one mass per node in node_ids, comma-separated (\"0.1,0.3\")");
  c.axis_damping =
      number_list(p, "axis_damping", "one damping per node in node_ids, comma-separated (\"0,0.5\")");
  c.bitrate = static_cast<std::uint32_t>(p.integer("bitrate"));
  c.counts_per_unit = p.number("counts_per_unit");
  c.velocity_counts_per_unit = p.number("velocity_counts_per_unit");
  c.gear_ratio = p.number("gear_ratio");
  c.reversed = p.boolean("reversed");
  c.rated_torque = p.number("rated_torque");
  c.heartbeat_period = p.duration_s("heartbeat_period");
  c.heartbeat_timeout = p.duration_s("heartbeat_timeout");
  c.tpdo_timeout_periods = static_cast<std::uint32_t>(p.integer("tpdo_timeout_periods"));
  c.sdo_timeout = p.duration_s("sdo_timeout");
  c.master_node_id = static_cast<std::uint8_t>(p.integer("master_node_id"));
  c.velocity_pdo = p.boolean("velocity_pdo");
  c.homing = p.text("homing") == "cia402";
  c.homing_method = static_cast<int>(p.integer("homing_method"));
  c.home_offset = p.number("home_offset");
  c.homing_speed_switch = p.number("homing_speed_switch");
  c.homing_speed_zero = p.number("homing_speed_zero");
  c.homing_acceleration = p.number("homing_acceleration");
  c.homing_timeout = p.duration_s("homing_timeout");
  c.axis_homing_method = method_list(p);
  c.axis_home_offset = number_list(
      p, "axis_home_offset", "one offset (rad | m) per node in node_ids, comma-separated (\"0.25,-0.1\")");
  try {
    validate(c);
  } catch (const ConfigError& e) {
    throw ParameterError(e.key(), "device.canopen." + std::string(e.what()));
  }
  // 0x1017 and 0x1016 carry whole milliseconds.
  for (const auto& [key, seconds] : {std::pair{"heartbeat_period", c.heartbeat_period},
                                     std::pair{"heartbeat_timeout", c.heartbeat_timeout}}) {
    if (std::abs(seconds * 1e3 - std::round(seconds * 1e3)) > 1e-9)
      throw ParameterError(
          key, "device.canopen." + std::string(key) + " must be whole milliseconds (0x1016/0x1017)");
  }
  return c;
}

DriverDescription canopen_driver() {
  static const std::vector<ParameterSpec> parameters = [] {
    std::vector<ParameterSpec> all = make_parameters();
    for (auto& key : homing_parameters()) all.push_back(std::move(key));
    return all;
  }();
  return {"canopen", "CiA 402 drive over SocketCAN, cyclic synchronous torque (CiA 301/402)", true,
          parameters, [](const DriverParameters& p) -> std::unique_ptr<DeviceHooks> {
            CanopenConfig config = canopen_config_from(p);
            if (!config.node_ids.empty()) return std::make_unique<CanopenBusDevice>(std::move(config));
            return std::make_unique<CanopenDevice>(std::move(config));
          }};
}

}  // namespace hapticd::drivers::canopen
