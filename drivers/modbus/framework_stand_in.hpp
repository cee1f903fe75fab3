#pragma once
/// \file
/// TEMPORARY, until the driver framework (issue 7) is on main: the lifecycle
/// types of drivers/device.hpp as that spec fixes them, so the
/// Modbus device can be written and tested now. Deleted at the merge; the
/// device then includes drivers/device.hpp and derives from Device.

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "drivers/device.hpp"

namespace hapticd::drivers {

struct LoopContext {
  double period_s = 1e-3;
};

struct DeviceModel {
  Motion motion = Motion::rotary;
  double effective_mass = 0.0;
  double viscous_damping = 0.0;
  double position_resolution = 0.0;
  int delay_periods = 0;
  std::string source = "config";
  std::string description;
};

enum class DeviceState { closed, configured, enabled, fault };

struct NamedCounter {
  std::string name;
  std::uint64_t value = 0;
};

struct DeviceStatusV2 {
  DeviceState state = DeviceState::closed;
  std::uint64_t read_errors = 0, write_errors = 0, faults = 0;
  std::string fault_reason;
  std::string last_error;
  std::vector<NamedCounter> counters;
};

class DeviceError : public std::runtime_error {
 public:
  explicit DeviceError(const std::string& message, std::string key = {})
      : std::runtime_error(message), key_(std::move(key)) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

}  // namespace hapticd::drivers
