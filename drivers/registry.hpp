#pragma once
/// \file
/// Every driver hapticd knows: the list, one line per driver, and lookups
/// in it. What a driver says of itself is its DriverDescription
/// (driver_description.hpp). A driver not yet written is listed as planned,
/// with its parameters, and refuses to start with one line saying so.

#include <string>
#include <string_view>
#include <vector>

#include "drivers/driver_description.hpp"

namespace hapticd::drivers {

/// In documentation order: the loopback first, then the real drivers.
const std::vector<DriverDescription>& driver_registry();
/// nullptr if no driver has this name.
const DriverDescription* find_driver(std::string_view name) noexcept;
/// "loopback, usb-hid, canopen, modbus, gpio-pwm" (all) or the ready ones only.
std::string driver_names(bool ready_only = false);

}  // namespace hapticd::drivers
