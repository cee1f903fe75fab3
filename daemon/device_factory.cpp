#include "daemon/device_factory.hpp"

#include "drivers/registry.hpp"

namespace hapticd::daemon {

config::SourcePosition device_key_position(const config::DeviceConfig& device, const std::string& key) {
  if (!key.empty()) {
    for (const auto& p : device.parameters) {
      if (p.key == key) return p.where;
    }
    for (const auto& p : device.parameters) {
      if (p.key.starts_with(key + ".")) return p.where;
    }
  }
  return device.driver_where;
}

config::ConfigError device_config_error(const config::DeviceConfig& device, const drivers::DeviceError& error) {
  const std::string key = error.key().empty() ? "device.driver" : "device." + device.driver + "." + error.key();
  return {device_key_position(device, error.key()), key, error.what()};
}

BuiltDevice build_device(const config::DaemonConfig& config) {
  const auto& device = config.device;
  const drivers::DriverDescription* driver = drivers::find_driver(device.driver);
  if (driver == nullptr) {
    throw config::ConfigError(device.driver_where, "device.driver",
                              "device.driver = \"" + device.driver +
                                  "\" is not a known driver; accepted: " + drivers::driver_names());
  }
  if (!driver->ready) {
    throw config::ConfigError(device.driver_where, "device.driver",
                              "device.driver = \"" + device.driver +
                                  "\" is planned, not built in this version of hapticd; ready: " +
                                  drivers::driver_names(true));
  }
  std::map<std::string, drivers::ParameterValue, std::less<>> given;
  for (const auto& p : device.parameters) given[p.key] = p.value;
  try {
    const drivers::DriverParameters parameters(device.driver, driver->parameters, given);
    BuiltDevice built{driver->make(parameters), parameters.to_json()};
    return built;
  } catch (const drivers::DeviceError& e) {
    throw device_config_error(device, e);
  }
}

}  // namespace hapticd::daemon
