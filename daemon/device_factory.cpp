#include "daemon/device_factory.hpp"

#include "drivers/registry.hpp"

namespace hapticd::daemon {

config::SourcePosition device_key_position(const config::DeviceConfig& device, const std::string& key) {
  if (!key.empty()) {
    for (const auto& p : device.parameters) {
      if (p.key == key) return p.where;
    }
    // A table parameter given as [device.<driver>.<key>]: its first entry.
    for (const auto& p : device.parameters) {
      if (p.key.starts_with(key + ".")) return p.where;
    }
  }
  return device.table_where;
}

namespace {

/// A refused key as a config error at that key's position (the error names
/// the key structurally; no message is searched).
config::ConfigError keyed_error(const config::DeviceConfig& device, const std::string& key,
                                const char* what) {
  const std::string dotted = "device." + device.driver + (key.empty() ? "" : "." + key);
  return {device_key_position(device, key), dotted, what};
}

}  // namespace

config::ConfigError device_config_error(const config::DeviceConfig& device,
                                        const drivers::DeviceError& error) {
  return keyed_error(device, error.key(), error.what());
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
    throw config::ConfigError(
        device.driver_where, "device.driver",
        "device.driver = \"" + device.driver +
            "\" is planned, not built in this version of hapticd; ready: " + drivers::driver_names(true));
  }
  std::map<std::string, drivers::ParameterValue, std::less<>> given;
  for (const auto& p : device.parameters) given[p.key] = p.value;
  try {
    const drivers::DriverParameters parameters(device.driver, driver->parameters, given);
    return {drivers::make_device(*driver, parameters), parameters.to_json()};
  } catch (const drivers::ParameterError& e) {
    throw keyed_error(device, e.key(), e.what());
  } catch (const drivers::DeviceError& e) {
    throw device_config_error(device, e);
  } catch (const std::invalid_argument& e) {  // malformed text: no key to name
    throw keyed_error(device, {}, e.what());
  }
}

}  // namespace hapticd::daemon
