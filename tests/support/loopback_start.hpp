#pragma once
/// \file
/// Test helpers: a loopback driver inside the framework's Device, and the
/// lifecycle to enabled at the period its config was made for (what the
/// daemon does with the loop's).

#include <memory>

#include "drivers/device.hpp"
#include "drivers/loopback/loopback_device.hpp"

namespace hapticd::testing {

/// configure() when closed, then enable() (again after a disable()).
inline void start(drivers::Device& device) {
  if (device.status().state == drivers::DeviceState::closed)
    device.configure({device.hooks_as<drivers::loopback::LoopbackDevice>().config().period_s});
  device.enable();
}

/// The Device the engine drives (`device`) and the loopback driver's own
/// calls on its simulator (`plant`: the hand, fault injection, snapshots).
struct LoopbackRig {
  explicit LoopbackRig(const drivers::loopback::LoopbackConfig& config = {},
                       const drivers::simulation::HandScript& hand = {})
      : owned(drivers::loopback::make_loopback_device(config, hand)),
        device(*owned),
        plant(device.hooks_as<drivers::loopback::LoopbackDevice>()) {}
  std::unique_ptr<drivers::Device> owned;
  drivers::Device& device;
  drivers::loopback::LoopbackDevice& plant;
};

}  // namespace hapticd::testing
