#include "drivers/modbus/modbus_config.hpp"

#include <numbers>
#include <optional>
#include <stdexcept>

namespace hapticd::drivers::modbus {

namespace {

/// A refusal the parameter table alone cannot make: "device.modbus.<key>: why".
[[noreturn]] void refuse(const std::string& key, const std::string& why) {
  throw ParameterError(key, "device.modbus." + key + ": " + why);
}

/// A register key: -1 = none.
std::optional<std::uint16_t> optional_register(const DriverParameters& p, const char* key) {
  const std::int64_t r = p.integer(key);
  if (r < 0) return std::nullopt;
  return static_cast<std::uint16_t>(r);
}

std::string baud_list() {
  int n = 0;
  const int* bauds = supported_bauds(n);
  std::string text;
  for (int i = 0; i < n; ++i) text += (i ? ", " : "") + std::to_string(bauds[i]);
  return text;
}

void check_map(const ModbusConfig& c) {
  const RegisterMap& m = c.map;
  if (c.map.read_table == ReadTable::input && c.function_23)
    refuse("function_23",
           "= true needs holding registers (fc 23 reads holding registers); with read_table = "
           "\"input\" set function_23 = false (fc 16 + fc 4)");
  if (m.status_enabled_bit >= 0 && !m.status)
    refuse("status_enabled_bit", "needs a status_register (it is -1)");
  if (m.status_fault_bit >= 0 && !m.status) refuse("status_fault_bit", "needs a status_register (it is -1)");
  if (m.status_enabled_bit >= 0 && m.status_enabled_bit == m.status_fault_bit)
    refuse("status_fault_bit", "is the same bit as status_enabled_bit");
  const LayoutResult layout = plan_blocks(m);
  if (!layout.error_key.empty()) refuse(layout.error_key, layout.error);
  if (c.map.read_table == ReadTable::input) return;  // the write goes to holding registers, another table
  // A periodic write must not land on a register that reports state.
  const auto& l = layout.layout;
  struct Item {
    const char* key;
    std::optional<std::uint16_t> address;
    int size;
  };
  const Item read_items[] = {{"position_register", m.position, 2},
                             {"velocity_register", m.velocity, 2},
                             {"status_register", m.status, 1},
                             {"fault_register", m.fault, 1}};
  for (int i = 0; i < l.write_count; ++i) {
    const int a = l.write_address + i;
    for (const Item& item : read_items) {
      if (!item.address || a < *item.address || a >= *item.address + item.size) continue;
      refuse(i == l.torque_index ? "torque_register" : "watchdog_register",
             "= " + std::to_string(a) + " is also " + item.key + " = " + std::to_string(*item.address) +
                 ": the periodic write would overwrite state the amplifier reports");
    }
  }
}

}  // namespace

double ModbusConfig::position_per_count() const noexcept {
  return (motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0) / counts;
}

namespace {

/// The link and its timing: transport, TCP and RTU settings, timeouts.
void link_from(const DriverParameters& p, ModbusConfig& c) {
  c.transport = p.text("transport") == "tcp" ? Transport::tcp : Transport::rtu;
  c.host = p.text("host");
  if (c.host.empty()) refuse("host", "is empty; accepted: an IPv4 address such as \"192.168.0.10\"");
  c.port = static_cast<int>(p.integer("port"));
  c.device = p.text("device");
  if (c.device.empty()) refuse("device", "is empty; accepted: a serial device path");
  c.serial.baud = static_cast<int>(p.integer("baud"));
  if (!is_supported_baud(c.serial.baud))
    refuse("baud", "= " + std::to_string(c.serial.baud) +
                       " is not a rate libmodbus 3.1.6 can set (it would silently use 9600); accepted: " +
                       baud_list());
  const std::string& parity = p.text("parity");
  c.serial.parity = parity == "none" ? Parity::none : parity == "even" ? Parity::even : Parity::odd;
  c.serial.data_bits = static_cast<int>(p.integer("data_bits"));
  c.serial.stop_bits = static_cast<int>(p.integer("stop_bits"));
  c.rs485 = p.boolean("rs485");
  c.silence = p.text("silence") == "spec" ? SilenceRule::spec : SilenceRule::characters;
  c.turnaround_s = p.duration_s("turnaround");
  c.slave_id = static_cast<int>(p.integer("slave_id"));
  if (c.slave_id > 247 && !(c.transport == Transport::tcp && c.slave_id == 255))
    refuse("slave_id", "= " + std::to_string(c.slave_id) +
                           " is not a unit address; accepted: 1 to 247, or 255 with transport = tcp");
  c.response_timeout_s = p.duration_s("response_timeout");
  c.byte_timeout_s = p.duration_s("byte_timeout");
  c.connect_timeout_s = p.duration_s("connect_timeout");
  c.link_budget = p.number("link_budget");
  c.failure_streak = static_cast<int>(p.integer("failure_streak"));
  c.function_23 = p.boolean("function_23");
  c.rtt_samples = static_cast<int>(p.integer("rtt_samples"));
  c.reset_on_start = p.boolean("reset_on_start");
}

/// The register map (AP 4.4 addresses) and the bits of the status and fault words.
RegisterMap map_from(const DriverParameters& p) {
  RegisterMap m;
  m.read_table = p.text("read_table") == "holding" ? ReadTable::holding : ReadTable::input;
  m.position = static_cast<std::uint16_t>(p.integer("position_register"));
  m.word_order = p.text("word_order") == "high-first" ? WordOrder::high_first : WordOrder::low_first;
  m.velocity = optional_register(p, "velocity_register");
  m.torque = static_cast<std::uint16_t>(p.integer("torque_register"));
  m.watchdog = optional_register(p, "watchdog_register");
  m.watchdog_value = static_cast<std::uint16_t>(p.integer("watchdog_value"));
  const std::string& refresh = p.text("watchdog_refresh");
  m.watchdog_refresh = refresh == "write"     ? WatchdogRefresh::write
                       : refresh == "counter" ? WatchdogRefresh::counter
                                              : WatchdogRefresh::any_frame;
  const std::string& enable = p.text("enable");
  m.enable = enable == "none"   ? EnableKind::none
             : enable == "coil" ? EnableKind::coil
                                : EnableKind::register_bit;
  m.enable_address = static_cast<std::uint16_t>(p.integer("enable_address"));
  m.enable_bit = static_cast<int>(p.integer("enable_bit"));
  m.status = optional_register(p, "status_register");
  m.status_enabled_bit = static_cast<int>(p.integer("status_enabled_bit"));
  m.status_fault_bit = static_cast<int>(p.integer("status_fault_bit"));
  m.fault = optional_register(p, "fault_register");
  try {
    m.fault_bits = parse_fault_bits(p.text("fault_bits"));
  } catch (const std::invalid_argument& e) {
    refuse("fault_bits", e.what());
  }
  m.reset = optional_register(p, "reset_register");
  m.reset_value = static_cast<std::uint16_t>(p.integer("reset_value"));
  return m;
}

}  // namespace

ModbusConfig modbus_config_from(const DriverParameters& p) {
  ModbusConfig c;
  link_from(p, c);
  c.motion = p.text("motion") == "rotary" ? Motion::rotary : Motion::linear;
  c.mass = p.number("mass");
  c.damping = p.number("damping");
  c.counts = p.number("counts");
  c.direction = p.text("direction") == "normal" ? 1 : -1;
  c.torque_per_count = p.number("torque_per_count");
  c.map = map_from(p);
  check_map(c);
  return c;
}

ModbusConfig modbus_config(const std::map<std::string, ParameterValue, std::less<>>& given) {
  return modbus_config_from(DriverParameters("modbus", modbus_parameters(), given));
}

}  // namespace hapticd::drivers::modbus
