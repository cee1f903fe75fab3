#pragma once
/// \file
/// Builds the configured device. Only the loopback driver is built in this
/// version; the other driver kinds the config accepts get a clear refusal.

#include <memory>

#include "daemon/config/config.hpp"
#include "drivers/device.hpp"
#include "drivers/loopback/loopback_device.hpp"

namespace hapticd::daemon {

struct BuiltDevice {
  std::unique_ptr<drivers::Device> device;
  /// Non-null when the device is the loopback simulator (hand.set, fault.inject).
  drivers::loopback::LoopbackDevice* loopback = nullptr;
};

/// Throws config::ConfigError naming the file, line and key of a bad value.
BuiltDevice build_device(const config::DaemonConfig& config);

}  // namespace hapticd::daemon
