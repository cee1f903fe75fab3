#include "drivers/modbus/modbus_config.hpp"

#include <cmath>
#include <numbers>
#include <sstream>

namespace hapticd::drivers::modbus {

namespace {

using P = ParameterType;

std::string join(const std::vector<std::string>& items) {
  std::string text;
  for (const auto& item : items) text += (text.empty() ? "" : ", ") + item;
  return text;
}

std::string number_text(double value) {
  std::ostringstream out;
  out.precision(10);
  out << value;
  return out.str();
}

std::vector<ModbusParameter> make_table() {
  const std::string reg = "PDU address, 0-based (a manual's 40001 is 0)";
  return {
      {"transport",
       P::choice,
       std::string("tcp"),
       "",
       {},
       {},
       {"tcp", "rtu"},
       "",
       "Modbus TCP or RTU (serial)"},
      {"host", P::text, std::string("127.0.0.1"), "", {}, {}, {}, "", "TCP: the amplifier's address"},
      {"port", P::integer, 502.0, "", 1.0, 65535.0, {}, "", "TCP: port"},
      {"device", P::text, std::string("/dev/ttyUSB0"), "", {}, {}, {}, "", "RTU: serial device"},
      {"baud",
       P::integer,
       115200.0,
       "",
       300.0,
       4000000.0,
       {},
       "baud",
       "RTU: line rate; one libmodbus 3.1.6 maps to a termios speed (not 2000000, not 14400)"},
      {"parity",
       P::choice,
       std::string("even"),
       "",
       {},
       {},
       {"none", "even", "odd"},
       "",
       "RTU: parity (the spec's default is even; none normally goes with 2 stop bits)"},
      {"data_bits", P::integer, 8.0, "", 8.0, 8.0, {}, "bit", "RTU: data bits (RTU carries 8-bit bytes)"},
      {"stop_bits", P::integer, 1.0, "", 1.0, 2.0, {}, "bit", "RTU: stop bits"},
      {"rs485",
       P::boolean,
       false,
       "",
       {},
       {},
       {},
       "",
       "RTU: switch the port to RS-485 mode (TIOCSRS485) after it is open"},
      {"silence",
       P::choice,
       std::string("spec"),
       "",
       {},
       {},
       {"spec", "characters"},
       "",
       "RTU: inter-frame silence t3.5 in the budget: spec = 3.5 characters up to 19200 baud and 1.75 ms "
       "above; characters = 3.5 characters at any rate (check the amplifier's manual)"},
      {"turnaround",
       P::duration,
       0.0,
       "",
       0.0,
       1.0,
       {},
       "s",
       "RTU: the amplifier's processing time between request and response, from its manual (budget only)"},
      {"slave_id",
       P::integer,
       1.0,
       "",
       1.0,
       255.0,
       {},
       "",
       "unit identifier: 1..247 (RTU and TCP), or 255 for a TCP device addressed directly"},
      {"response_timeout",
       P::duration,
       0.0,
       "0: link_budget x period / transactions",
       0.0,
       10.0,
       {},
       "s",
       "how long one transaction may wait for its response; must sit well inside the period"},
      {"byte_timeout",
       P::duration,
       0.0,
       "",
       0.0,
       1.0,
       {},
       "s",
       "gap allowed between response bytes; 0 = off, the response timeout bounds the whole response"},
      {"connect_timeout",
       P::duration,
       1.0,
       "",
       1e-3,
       60.0,
       {},
       "s",
       "TCP connect and reconnect bound; also how long an exchange off the loop (configure, enable, fault "
       "clear, disable) waits for its reply; SIGTERM ends either wait within 0.1 s"},
      {"link_budget",
       P::number,
       0.5,
       "",
       0.05,
       0.95,
       {},
       "",
       "fraction of the period the Modbus exchange may take"},
      {"failure_streak",
       P::integer,
       3.0,
       "",
       1.0,
       1000.0,
       {},
       "periods",
       "consecutive failed transactions (timeout, CRC error, malformed reply) that latch a fault"},
      {"function_23",
       P::boolean,
       true,
       "",
       {},
       {},
       {},
       "",
       "the amplifier supports read/write multiple registers (fc 23): one transaction per period; "
       "false: fc 16 then fc 3/4"},
      {"read_table",
       P::choice,
       std::string("holding"),
       "",
       {},
       {},
       {"holding", "input"},
       "",
       "position, velocity, status and fault are holding registers (fc 3/23) or input registers (fc 4)"},
      {"rtt_samples",
       P::integer,
       200.0,
       "",
       10.0,
       10000.0,
       {},
       "",
       "TCP: round trips measured at configure for the budget"},
      {"reset_on_start",
       P::boolean,
       false,
       "",
       {},
       {},
       {},
       "",
       "write the reset register at configure when the amplifier reports a fault (e.g. its watchdog "
       "tripped after hapticd was killed)"},
      {"motion",
       P::choice,
       std::string("rotary"),
       "",
       {},
       {},
       {"rotary", "linear"},
       "",
       "rotary (rad, N m) or linear (m, N)"},
      {"counts",
       P::number,
       16384.0,
       "",
       1.0,
       1e12,
       {},
       "counts/rev or counts/m",
       "position counts per revolution (rotary) or per metre (linear)"},
      {"direction",
       P::choice,
       std::string("normal"),
       "",
       {},
       {},
       {"normal", "reversed"},
       "",
       "reversed flips the sign of position and torque"},
      {"torque_per_count",
       P::number,
       0.001,
       "",
       1e-9,
       1e6,
       {},
       "N m or N",
       "torque (force) of one torque-command count"},
      {"mass",
       P::number,
       0.01,
       "",
       1e-9,
       1e6,
       {},
       "kg m^2 or kg",
       "moving inertia or mass, for the stability gate (the amplifier cannot report it)"},
      {"damping", P::number, 0.0, "", 0.0, 1e6, {}, "N m s/rad or N s/m", "viscous damping to ground"},
      {"position_register",
       P::integer,
       0.0,
       "",
       0.0,
       65534.0,
       {},
       "",
       "first of the two registers of the 32-bit position, " + reg},
      {"word_order",
       P::choice,
       std::string("high-first"),
       "",
       {},
       {},
       {"high-first", "low-first"},
       "",
       "which register of a 32-bit pair holds the high 16 bits"},
      {"velocity_register",
       P::integer,
       2.0,
       "",
       -1.0,
       65534.0,
       {},
       "",
       "first of the two registers of the 32-bit velocity (counts/s), -1 = none"},
      {"torque_register", P::integer, 10.0, "", 0.0, 65535.0, {}, "", "signed 16-bit torque command, " + reg},
      {"watchdog_register",
       P::integer,
       11.0,
       "",
       -1.0,
       65535.0,
       {},
       "",
       "the amplifier's watchdog, -1 = none (then see the protocol note: an external dead-man is needed)"},
      {"watchdog_value",
       P::integer,
       50.0,
       "",
       1.0,
       65535.0,
       {},
       "",
       "write: written to arm the watchdog and at every refresh, in the amplifier's unit (the simulated one: "
       "ms); counter: the alive counter's first value"},
      {"watchdog_refresh",
       P::choice,
       std::string("write"),
       "",
       {},
       {},
       {"write", "any-frame", "counter"},
       "",
       "write: the register is rewritten every period (next to torque_register); any-frame: the "
       "amplifier restarts it on every valid frame; counter: an alive counter, one more every period "
       "(wrapping 0xFFFF -> 0; next to torque_register), for an amplifier that trips on an unchanged value"},
      {"enable",
       P::choice,
       std::string("register-bit"),
       "",
       {},
       {},
       {"none", "coil", "register-bit"},
       "",
       "how the power stage is switched"},
      {"enable_address", P::integer, 12.0, "", 0.0, 65535.0, {}, "", "the enable coil or register, " + reg},
      {"enable_bit", P::integer, 0.0, "", 0.0, 15.0, {}, "", "register-bit: the enable bit"},
      {"status_register", P::integer, 4.0, "", -1.0, 65535.0, {}, "", "status word, -1 = none"},
      {"status_enabled_bit",
       P::integer,
       0.0,
       "",
       -1.0,
       15.0,
       {},
       "",
       "status bit set while the power stage is on, -1 = none"},
      {"status_fault_bit", P::integer, 1.0, "", -1.0, 15.0, {}, "", "status bit set in fault, -1 = none"},
      {"fault_register",
       P::integer,
       5.0,
       "",
       -1.0,
       65535.0,
       {},
       "",
       "fault word (nonzero = in fault), -1 = none"},
      {"fault_bits",
       P::text,
       std::string("0:over-current,1:over-voltage,2:watchdog,3:following-error,4:over-temperature"),
       "",
       {},
       {},
       {},
       "",
       "meaning of the fault word's bits, bit:name pairs, comma separated"},
      {"reset_register",
       P::integer,
       13.0,
       "",
       -1.0,
       65535.0,
       {},
       "",
       "written with reset_value by `fault clear`, -1 = none"},
      {"reset_value", P::integer, 1.0, "", 0.0, 65535.0, {}, "", "value that resets the amplifier's faults"},
  };
}

class Values {
 public:
  explicit Values(const std::map<std::string, ParameterValue>& values) : values_(values) {
    for (const auto& [key, value] : values) {
      (void)value;
      if (!find(key)) {
        std::vector<std::string> names;
        for (const auto& p : modbus_parameters()) names.push_back(p.name);
        throw ConfigError(key, "unknown key; accepted: " + join(names));
      }
    }
  }

  double number(const std::string& key) const {
    const ModbusParameter& spec = *find(key);
    const ParameterValue& v = value(spec);
    if (!std::holds_alternative<double>(v)) throw ConfigError(key, "must be a number" + range_text(spec));
    const double x = std::get<double>(v);
    if (!std::isfinite(x) || (spec.minimum && x < *spec.minimum) || (spec.maximum && x > *spec.maximum))
      throw ConfigError(key, "= " + number_text(x) + " is out of range" + range_text(spec));
    return x;
  }
  int integer(const std::string& key) const {
    const double x = number(key);
    if (x != std::floor(x)) throw ConfigError(key, "= " + number_text(x) + " is not a whole number");
    return static_cast<int>(x);
  }
  bool boolean(const std::string& key) const {
    const ParameterValue& v = value(*find(key));
    if (!std::holds_alternative<bool>(v)) throw ConfigError(key, "must be true or false");
    return std::get<bool>(v);
  }
  std::string text(const std::string& key) const {
    const ModbusParameter& spec = *find(key);
    const ParameterValue& v = value(spec);
    if (!std::holds_alternative<std::string>(v)) throw ConfigError(key, "must be a string");
    const std::string& s = std::get<std::string>(v);
    if (spec.type == P::choice) {
      bool ok = false;
      for (const auto& a : spec.accepted) ok = ok || a == s;
      if (!ok) throw ConfigError(key, "= \"" + s + "\" is not accepted; accepted: " + join(spec.accepted));
    }
    return s;
  }
  std::optional<std::uint16_t> optional_register(const std::string& key) const {
    const int r = integer(key);
    if (r < 0) return std::nullopt;
    return static_cast<std::uint16_t>(r);
  }

 private:
  static const ModbusParameter* find(const std::string& key) {
    for (const auto& p : modbus_parameters())
      if (p.name == key) return &p;
    return nullptr;
  }
  const ParameterValue& value(const ModbusParameter& spec) const {
    const auto it = values_.find(spec.name);
    return it != values_.end() ? it->second : spec.default_value;
  }
  static std::string range_text(const ModbusParameter& spec) {
    if (!spec.minimum && !spec.maximum) return "";
    std::string unit = spec.unit.empty() ? "" : " " + spec.unit;
    return "; accepted: " + number_text(spec.minimum.value_or(-INFINITY)) + " to " +
           number_text(spec.maximum.value_or(INFINITY)) + unit;
  }
  const std::map<std::string, ParameterValue>& values_;
};

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
    throw ConfigError("function_23",
                      "= true needs holding registers (fc 23 reads holding registers); with read_table = "
                      "\"input\" set function_23 = false (fc 16 + fc 4)");
  if (m.status_enabled_bit >= 0 && !m.status)
    throw ConfigError("status_enabled_bit", "needs a status_register (it is -1)");
  if (m.status_fault_bit >= 0 && !m.status)
    throw ConfigError("status_fault_bit", "needs a status_register (it is -1)");
  if (m.status_enabled_bit >= 0 && m.status_enabled_bit == m.status_fault_bit)
    throw ConfigError("status_fault_bit", "is the same bit as status_enabled_bit");
  const LayoutResult layout = plan_blocks(m);
  if (!layout.error_key.empty()) throw ConfigError(layout.error_key, layout.error);
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
      throw ConfigError(i == l.torque_index ? "torque_register" : "watchdog_register",
                        "= " + std::to_string(a) + " is also " + item.key + " = " +
                            std::to_string(*item.address) +
                            ": the periodic write would overwrite state the amplifier reports");
    }
  }
}

}  // namespace

double ModbusConfig::position_per_count() const noexcept {
  return (motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0) / counts;
}

const std::vector<ModbusParameter>& modbus_parameters() {
  static const std::vector<ModbusParameter> table = make_table();
  return table;
}

ModbusConfig build_modbus_config(const std::map<std::string, ParameterValue>& values) {
  const Values v(values);
  ModbusConfig c;
  c.transport = v.text("transport") == "tcp" ? Transport::tcp : Transport::rtu;
  c.host = v.text("host");
  if (c.host.empty())
    throw ConfigError("host", "is empty; accepted: an IPv4 address such as \"192.168.0.10\"");
  c.port = v.integer("port");
  c.device = v.text("device");
  if (c.device.empty()) throw ConfigError("device", "is empty; accepted: a serial device path");
  c.serial.baud = v.integer("baud");
  if (!is_supported_baud(c.serial.baud))
    throw ConfigError("baud", "= " + std::to_string(c.serial.baud) +
                                  " is not a rate libmodbus 3.1.6 can set (it would silently use 9600); "
                                  "accepted: " +
                                  baud_list());
  const std::string parity = v.text("parity");
  c.serial.parity = parity == "none" ? Parity::none : parity == "even" ? Parity::even : Parity::odd;
  c.serial.data_bits = v.integer("data_bits");
  c.serial.stop_bits = v.integer("stop_bits");
  c.rs485 = v.boolean("rs485");
  c.silence = v.text("silence") == "spec" ? SilenceRule::spec : SilenceRule::characters;
  c.turnaround_s = v.number("turnaround");
  c.slave_id = v.integer("slave_id");
  if (c.slave_id > 247 && !(c.transport == Transport::tcp && c.slave_id == 255))
    throw ConfigError("slave_id",
                      "= " + std::to_string(c.slave_id) +
                          " is not a unit address; accepted: 1 to 247, or 255 with transport = tcp");
  c.response_timeout_s = v.number("response_timeout");
  c.byte_timeout_s = v.number("byte_timeout");
  c.connect_timeout_s = v.number("connect_timeout");
  c.link_budget = v.number("link_budget");
  c.failure_streak = v.integer("failure_streak");
  c.function_23 = v.boolean("function_23");
  c.rtt_samples = v.integer("rtt_samples");
  c.reset_on_start = v.boolean("reset_on_start");
  c.motion = v.text("motion") == "rotary" ? Motion::rotary : Motion::linear;
  c.counts = v.number("counts");
  c.direction = v.text("direction") == "normal" ? 1 : -1;
  c.torque_per_count = v.number("torque_per_count");
  c.mass = v.number("mass");
  c.damping = v.number("damping");

  RegisterMap& m = c.map;
  m.read_table = v.text("read_table") == "holding" ? ReadTable::holding : ReadTable::input;
  m.position = static_cast<std::uint16_t>(v.integer("position_register"));
  m.word_order = v.text("word_order") == "high-first" ? WordOrder::high_first : WordOrder::low_first;
  m.velocity = v.optional_register("velocity_register");
  m.torque = static_cast<std::uint16_t>(v.integer("torque_register"));
  m.watchdog = v.optional_register("watchdog_register");
  m.watchdog_value = static_cast<std::uint16_t>(v.integer("watchdog_value"));
  const std::string refresh = v.text("watchdog_refresh");
  m.watchdog_refresh = refresh == "write"     ? WatchdogRefresh::write
                       : refresh == "counter" ? WatchdogRefresh::counter
                                              : WatchdogRefresh::any_frame;
  const std::string enable = v.text("enable");
  m.enable = enable == "none"   ? EnableKind::none
             : enable == "coil" ? EnableKind::coil
                                : EnableKind::register_bit;
  m.enable_address = static_cast<std::uint16_t>(v.integer("enable_address"));
  m.enable_bit = v.integer("enable_bit");
  m.status = v.optional_register("status_register");
  m.status_enabled_bit = v.integer("status_enabled_bit");
  m.status_fault_bit = v.integer("status_fault_bit");
  m.fault = v.optional_register("fault_register");
  try {
    m.fault_bits = parse_fault_bits(v.text("fault_bits"));
  } catch (const std::invalid_argument& e) {
    throw ConfigError("fault_bits", e.what());
  }
  m.reset = v.optional_register("reset_register");
  m.reset_value = static_cast<std::uint16_t>(v.integer("reset_value"));
  check_map(c);
  return c;
}

}  // namespace hapticd::drivers::modbus
