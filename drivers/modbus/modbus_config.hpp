#pragma once
/// \file
/// Typed parameters of the `modbus` driver ([device.modbus] in the config):
/// the link (TCP or RTU), the timing budget, the register map and the
/// scaling to SI. modbus_parameters() is the table (JACK2 style: name, type,
/// default, range, unit, help) that the registry, the config parser's
/// messages and the docs come from; build_modbus_config() turns typed values
/// into a checked ModbusConfig, naming the key on any error.

#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "drivers/device_hooks.hpp"
#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/rtu_timing.hpp"

namespace hapticd::drivers::modbus {

enum class Transport : std::uint8_t { tcp, rtu };

struct ModbusConfig {
  Transport transport = Transport::tcp;
  // TCP
  std::string host = "127.0.0.1";
  int port = 502;
  // RTU
  std::string device = "/dev/ttyUSB0";
  SerialFormat serial;
  bool rs485 = false;
  SilenceRule silence = SilenceRule::spec;
  double turnaround_s = 0.0;
  // Both
  int slave_id = 1;
  double response_timeout_s = 0.0;  ///< 0: link_budget * period / transactions, set at configure
  double byte_timeout_s = 0.0;      ///< 0: off (the response timeout bounds the whole response)
  double connect_timeout_s = 1.0;
  double link_budget = 0.5;  ///< fraction of the period the exchange may take
  int failure_streak = 3;    ///< consecutive failed transactions that latch a fault
  bool function_23 = true;   ///< else fc 16 + fc 3/4
  int rtt_samples = 200;     ///< TCP round trips measured at configure
  bool reset_on_start = false;
  // Scaling and the device model for the stability gate
  Motion motion = Motion::rotary;
  double counts = 16384.0;  ///< per revolution (rotary) or per metre (linear)
  int direction = 1;        ///< -1: reversed (position and torque)
  double torque_per_count = 0.001;
  double mass = 0.01;
  double damping = 0.0;
  RegisterMap map;

  /// rad or m per position count.
  double position_per_count() const noexcept;
  /// Periodic transactions: 1 (fc 23) or 2 (fc 16 + fc 3/4).
  int transactions() const noexcept { return function_23 ? 1 : 2; }
};

/// A parameter value as the config parser types it: the one ParameterValue (world/parameter.hpp).
using world::ParameterValue;

enum class ParameterType { number, integer, boolean, text, choice, duration };

struct ModbusParameter {
  std::string name;
  ParameterType type;
  ParameterValue default_value;
  std::string default_note;
  std::optional<double> minimum, maximum;
  std::vector<std::string> accepted;
  std::string unit;
  std::string help;
};

/// Every key of [device.modbus], in documentation order.
const std::vector<ModbusParameter>& modbus_parameters();

/// A bad parameter: one line, naming what is wrong and what is accepted;
/// key() is the [device.modbus] key to blame.
class ConfigError : public std::invalid_argument {
 public:
  ConfigError(const std::string& key, const std::string& message)
      : std::invalid_argument("device.modbus." + key + ": " + message), key_(key) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

/// Typed values by key (missing keys take their defaults) into a checked
/// config. Throws ConfigError on an unknown key, a wrong type, a value out
/// of range, or a register map that cannot work (overlaps, non-adjacent
/// watchdog, fc 23 with input registers ...).
ModbusConfig build_modbus_config(const std::map<std::string, ParameterValue>& values);

/// Period-dependent checks happen at configure (modbus_device), not here.

}  // namespace hapticd::drivers::modbus
