#pragma once
/// \file
/// The `modbus` driver's registry entry: its parameter table and factory.
#include "drivers/registry.hpp"

namespace hapticd::drivers::modbus {

DriverDescription modbus_driver();

}  // namespace hapticd::drivers::modbus
