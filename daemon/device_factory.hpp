#pragma once
/// \file
/// Builds the configured device through the driver registry: the driver's
/// typed parameters are checked against its own description, and every
/// error is placed at the exact key's file:line:column.

#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "daemon/config/config.hpp"
#include "drivers/device.hpp"
#include "drivers/parameter.hpp"

namespace hapticd::daemon {

struct BuiltDevice {
  std::unique_ptr<drivers::Device> device;  ///< closed: configure() comes next
  nlohmann::json parameters;                ///< every value in force, for device.describe
};

/// Throws config::ConfigError naming the file, line and key of a bad value,
/// or the device.driver line for a planned (not built) driver.
BuiltDevice build_device(const config::DaemonConfig& config);

/// The position to blame for a DeviceError's key: the key itself, else the
/// first key of its table ("hand" -> "hand.mode"), else device.driver.
config::SourcePosition device_key_position(const config::DeviceConfig& device, const std::string& key);

/// A DeviceError as a config error at its key.
config::ConfigError device_config_error(const config::DeviceConfig& device,
                                        const drivers::DeviceError& error);

}  // namespace hapticd::daemon
