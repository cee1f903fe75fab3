#pragma once
/// \file
/// The `modbus` driver's typed config ([device.modbus] in the config): the
/// link (TCP or RTU), the timing budget, the register map and the scaling
/// to SI, converted once from the checked parameters.

#include <map>
#include <string>
#include <vector>

#include "drivers/device_hooks.hpp"
#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/rtu_timing.hpp"
#include "drivers/parameter.hpp"

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

/// Every key of [device.modbus], in documentation order: the keys every
/// device takes first (motion, mass, damping), then the link, the timing,
/// the scaling and the register map. The one vocabulary of the registry,
/// the config's messages and docs/driver-parameters.md (modbus_driver.cpp).
const std::vector<ParameterSpec>& modbus_parameters();

/// The typed config from a checked [device.modbus] table (DriverParameters:
/// types, ranges and choices already checked against modbus_parameters()).
/// Throws ParameterError naming the key for what the table alone cannot
/// check: an empty host or device, a baud rate libmodbus cannot set, a unit
/// address the transport does not take, fault_bits that do not parse, a
/// register map that cannot work (overlaps, non-adjacent watchdog, fc 23
/// with input registers ...).
ModbusConfig modbus_config_from(const DriverParameters& parameters);

/// Shorthand for tests and tools: `given` checked against
/// modbus_parameters() (defaults filled), then modbus_config_from().
/// Throws ParameterError naming the key.
ModbusConfig modbus_config(const std::map<std::string, ParameterValue, std::less<>>& given = {});

/// Period-dependent checks happen at configure (modbus_device), not here.

}  // namespace hapticd::drivers::modbus
