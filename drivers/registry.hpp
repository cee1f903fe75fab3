#pragma once
/// \file
/// Every driver hapticd knows, each describing itself (JACK2's
/// jack_driver_desc_t): name, one-line summary, typed parameters and a
/// factory. The config parser, its errors, `hapticd --list-drivers`,
/// `hapticctl device` and docs/driver-parameters.md come from this one table.
/// A driver not yet written is listed as planned, with its parameters, and
/// refuses to start with one line saying so.

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "drivers/device.hpp"
#include "drivers/parameter.hpp"

namespace hapticd::drivers {

struct DriverDescription {
  std::string name;     ///< the value of device.driver: "loopback", "canopen", ...
  std::string summary;  ///< one line
  bool ready = false;   ///< false: planned, not built in this version
  std::vector<ParameterSpec> parameters;
  /// Builds the (closed) device from its checked parameters; throws
  /// DeviceError naming the key for what the spec alone cannot check.
  /// Empty when planned.
  std::function<std::unique_ptr<Device>(const DriverParameters&)> make;
};

/// In documentation order: the loopback first, then the real drivers.
const std::vector<DriverDescription>& driver_registry();
/// nullptr if no driver has this name.
const DriverDescription* find_driver(std::string_view name) noexcept;
/// "loopback, usb-hid, canopen, modbus, gpio-pwm" (all) or the ready ones only.
std::string driver_names(bool ready_only = false);

nlohmann::json to_json(const DriverDescription& driver);
/// The reference page (docs/driver-parameters.md) for every driver.
std::string to_markdown(const std::vector<DriverDescription>& drivers);

}  // namespace hapticd::drivers
