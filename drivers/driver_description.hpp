#pragma once
/// \file
/// What a driver says of itself (JACK2's jack_driver_desc_t): name, one-line
/// summary, typed parameters and the factory of its hooks. Each driver's
/// <kind>_driver.cpp returns one; drivers/registry.cpp lists them. The
/// config parser, its errors, `hapticd --list-drivers`, `hapticctl device`
/// and docs/driver-parameters.md come from these descriptions.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "drivers/device.hpp"
#include "drivers/parameter.hpp"

namespace hapticd::drivers {

struct DriverDescription {
  std::string name;     ///< the value of device.driver: "loopback", "canopen", ...
  std::string summary;  ///< one line
  bool ready = false;   ///< false: planned, not built in this version
  std::vector<ParameterSpec> parameters;
  /// Builds the driver's hooks from its checked parameters; throws
  /// DeviceError or ParameterError naming the key for what the spec alone
  /// cannot check. Empty when planned.
  std::function<std::unique_ptr<DeviceHooks>(const DriverParameters&)> make;
};

/// The framework's Device (closed: configure() comes next) around the
/// driver's hooks built from `parameters`.
std::unique_ptr<Device> make_device(const DriverDescription& driver, const DriverParameters& parameters);

nlohmann::json to_json(const DriverDescription& driver);
/// The reference page (docs/driver-parameters.md) for every driver.
std::string to_markdown(const std::vector<DriverDescription>& drivers);

}  // namespace hapticd::drivers
