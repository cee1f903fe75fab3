#include "daemon/engine/safety.hpp"

namespace hapticd::daemon::engine {

std::string_view to_string(FaultReason reason) noexcept {
  switch (reason) {
    case FaultReason::none:
      return "none";
    case FaultReason::estop:
      return "estop";
    case FaultReason::non_finite_position:
      return "non-finite position from the device";
    case FaultReason::non_finite_command:
      return "non-finite command from the scene";
    case FaultReason::device_fault:
      return "device fault";
    case FaultReason::read_error_streak:
      return "read error streak";
    case FaultReason::write_error:
      return "write error";
    case FaultReason::overrun_streak:
      return "overrun streak";
  }
  return "unknown";
}

}  // namespace hapticd::daemon::engine
