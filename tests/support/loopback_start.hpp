#pragma once
/// \file
/// Test helper: a loopback device through the lifecycle to enabled, at the
/// period its config was made for (what the daemon does with the loop's).

#include "drivers/loopback/loopback_device.hpp"

namespace hapticd::testing {

/// configure() when closed, then enable() (again after a disable()).
inline void start(drivers::loopback::LoopbackDevice& device) {
  if (device.status().state == drivers::DeviceState::closed) device.configure({device.config().period_s});
  device.enable();
}

}  // namespace hapticd::testing
