#pragma once
/// \file
/// The `modbus` driver's registry entry: its parameter table and factory.
#include "drivers/driver_description.hpp"

namespace hapticd::drivers::modbus {

DriverDescription modbus_driver();

}  // namespace hapticd::drivers::modbus
