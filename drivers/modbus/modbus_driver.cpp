// The modbus driver's self-description for the registry (parameters with
// types, units, ranges, help: the one ParameterSpec vocabulary) and its
// factory.

#include "drivers/driver_description.hpp"
#include "drivers/modbus/modbus_config.hpp"
#include "drivers/modbus/modbus_device.hpp"

namespace hapticd::drivers::modbus {

namespace {

using P = ParameterSpec;

/// The keys every device takes, with the amplifier's default mass.
std::vector<ParameterSpec> model_parameters() {
  return {
      motion_parameter("rotary (rad, N m) or linear (m, N)"),
      mass_parameter("moving inertia or mass, for the stability gate (the amplifier cannot report it)")
          .defaults_to(0.01),
      damping_parameter("viscous damping to ground"),
  };
}

/// The link: TCP or RTU, and the unit it talks to.
std::vector<ParameterSpec> link_parameters() {
  return {
      P::choice("transport", {"tcp", "rtu"}, "Modbus TCP or RTU (serial)").defaults_to("tcp"),
      P::text("host", "TCP: the amplifier's address").defaults_to("127.0.0.1"),
      P::integer("port", "", "TCP: port").defaults_to(502.0).at_least(1).at_most(65535),
      P::text("device", "RTU: serial device").defaults_to("/dev/ttyUSB0"),
      P::integer("baud", "baud",
                 "RTU: line rate; one libmodbus 3.1.6 maps to a termios speed (not 2000000, not 14400)")
          .defaults_to(115200.0)
          .at_least(300)
          .at_most(4000000),
      P::choice("parity", {"none", "even", "odd"},
                "RTU: parity (the spec's default is even; none normally goes with 2 stop bits)")
          .defaults_to("even"),
      P::integer("data_bits", "bit", "RTU: data bits (RTU carries 8-bit bytes)")
          .defaults_to(8.0)
          .at_least(8)
          .at_most(8),
      P::integer("stop_bits", "bit", "RTU: stop bits").defaults_to(1.0).at_least(1).at_most(2),
      P::boolean("rs485", "RTU: switch the port to RS-485 mode (TIOCSRS485) after it is open")
          .defaults_to(false),
      P::choice(
          "silence", {"spec", "characters"},
          "RTU: inter-frame silence t3.5 in the budget: spec = 3.5 characters up to 19200 baud and 1.75 "
          "ms above; characters = 3.5 characters at any rate (check the amplifier's manual)")
          .defaults_to("spec"),
      P::duration(
          "turnaround",
          "RTU: the amplifier's processing time between request and response, from its manual (budget "
          "only)")
          .defaults_to(0.0)
          .at_least(0.0)
          .at_most(1.0),
      P::integer("slave_id", "",
                 "unit identifier: 1..247 (RTU and TCP), or 255 for a TCP device addressed directly")
          .defaults_to(1.0)
          .at_least(1)
          .at_most(255),
  };
}

/// How long an exchange may take and what its failures do.
std::vector<ParameterSpec> timing_parameters() {
  return {
      P::duration("response_timeout",
                  "how long one transaction may wait for its response; must sit well inside the period")
          .defaults_to(0.0, "0: link_budget x period / transactions")
          .at_least(0.0)
          .at_most(10.0),
      P::duration(
          "byte_timeout",
          "gap allowed between response bytes; 0 = off, the response timeout bounds the whole response")
          .defaults_to(0.0)
          .at_least(0.0)
          .at_most(1.0),
      P::duration(
          "connect_timeout",
          "TCP connect and reconnect bound; also how long an exchange off the loop (configure, enable, "
          "fault clear, disable) waits for its reply; SIGTERM ends either wait within 0.1 s")
          .defaults_to(1.0)
          .at_least(1e-3)
          .at_most(60.0),
      P::number("link_budget", "", "fraction of the period the Modbus exchange may take")
          .defaults_to(0.5)
          .at_least(0.05)
          .at_most(0.95),
      P::integer("failure_streak", "periods",
                 "consecutive failed transactions (timeout, CRC error, malformed reply) that latch a fault")
          .defaults_to(3.0)
          .at_least(1)
          .at_most(1000),
      P::boolean("function_23",
                 "the amplifier supports read/write multiple registers (fc 23): one transaction per period; "
                 "false: fc 16 then fc 3/4")
          .defaults_to(true),
      P::choice("read_table", {"holding", "input"},
                "position, velocity, status and fault are holding registers (fc 3/23) or input registers (fc "
                "4)")
          .defaults_to("holding"),
      P::integer("rtt_samples", "", "TCP: round trips measured at configure for the budget")
          .defaults_to(200.0)
          .at_least(10)
          .at_most(10000),
      P::boolean(
          "reset_on_start",
          "write the reset register at configure when the amplifier reports a fault (e.g. its watchdog "
          "tripped after hapticd was killed)")
          .defaults_to(false),
  };
}

/// Counts and commands to SI.
std::vector<ParameterSpec> scaling_parameters() {
  return {
      P::number("counts", "counts/rev | counts/m",
                "position counts per revolution (rotary) or per metre (linear)")
          .defaults_to(16384.0)
          .at_least(1)
          .at_most(1e12),
      P::choice("direction", {"normal", "reversed"}, "reversed flips the sign of position and torque")
          .defaults_to("normal"),
      P::number("torque_per_count", "N m | N", "torque (force) of one torque-command count")
          .defaults_to(0.001)
          .at_least(1e-9)
          .at_most(1e6),
  };
}

/// The amplifier's registers: PDU addresses, 0-based (AP 4.4).
std::vector<ParameterSpec> map_parameters() {
  const std::string pdu = "PDU address, 0-based (a manual's 40001 is 0)";
  auto whole = [](const char* name, double fallback, double lowest, double highest, std::string help) {
    return P::integer(name, "", std::move(help)).defaults_to(fallback).at_least(lowest).at_most(highest);
  };
  return {
      whole("position_register", 0, 0, 65534, "first of the two registers of the 32-bit position, " + pdu),
      P::choice("word_order", {"high-first", "low-first"},
                "which register of a 32-bit pair holds the high 16 bits")
          .defaults_to("high-first"),
      whole("velocity_register", 2, -1, 65534,
            "first of the two registers of the 32-bit velocity (counts/s), -1 = none"),
      whole("torque_register", 10, 0, 65535, "signed 16-bit torque command, " + pdu),
      whole(
          "watchdog_register", 11, -1, 65535,
          "the amplifier's watchdog, -1 = none (then see the protocol note: an external dead-man is needed)"),
      whole("watchdog_value", 50, 1, 65535,
            "write: written to arm the watchdog and at every refresh, in the amplifier's unit (the simulated "
            "one: ms); counter: the alive counter's first value"),
      P::choice(
          "watchdog_refresh", {"write", "any-frame", "counter"},
          "write: the register is rewritten every period (next to torque_register); any-frame: the "
          "amplifier restarts it on every valid frame; counter: an alive counter, one more every period "
          "(wrapping 0xFFFF -> 0; next to torque_register), for an amplifier that trips on an unchanged "
          "value")
          .defaults_to("write"),
      P::choice("enable", {"none", "coil", "register-bit"}, "how the power stage is switched")
          .defaults_to("register-bit"),
      whole("enable_address", 12, 0, 65535, "the enable coil or register, " + pdu),
      whole("enable_bit", 0, 0, 15, "register-bit: the enable bit"),
      whole("status_register", 4, -1, 65535, "status word, -1 = none"),
      whole("status_enabled_bit", 0, -1, 15, "status bit set while the power stage is on, -1 = none"),
      whole("status_fault_bit", 1, -1, 15, "status bit set in fault, -1 = none"),
      whole("fault_register", 5, -1, 65535, "fault word (nonzero = in fault), -1 = none"),
      P::text("fault_bits", "meaning of the fault word's bits, bit:name pairs, comma separated")
          .defaults_to("0:over-current,1:over-voltage,2:watchdog,3:following-error,4:over-temperature"),
      whole("reset_register", 13, -1, 65535, "written with reset_value by `fault clear`, -1 = none"),
      whole("reset_value", 1, 0, 65535, "value that resets the amplifier's faults"),
  };
}

}  // namespace

const std::vector<ParameterSpec>& modbus_parameters() {
  static const std::vector<ParameterSpec> parameters = [] {
    std::vector<ParameterSpec> all = model_parameters();
    for (const auto& group : {link_parameters(), timing_parameters(), scaling_parameters(), map_parameters()})
      all.insert(all.end(), group.begin(), group.end());
    return all;
  }();
  return parameters;
}

DriverDescription modbus_driver() {
  return {"modbus", "servo amplifier over Modbus RTU or TCP (libmodbus): fc 23 per period, watchdog register",
          true, modbus_parameters(), [](const DriverParameters& p) -> std::unique_ptr<DeviceHooks> {
            return std::make_unique<ModbusDevice>(modbus_config_from(p));
          }};
}

}  // namespace hapticd::drivers::modbus
