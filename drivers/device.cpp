#include "drivers/device.hpp"

namespace hapticd::drivers {

std::string_view to_string(DeviceState state) noexcept {
  switch (state) {
    case DeviceState::closed:
      return "closed";
    case DeviceState::configured:
      return "configured";
    case DeviceState::enabled:
      return "enabled";
    case DeviceState::fault:
      return "fault";
  }
  return "closed";
}

}  // namespace hapticd::drivers
