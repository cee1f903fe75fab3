#pragma once
/// \file
/// SocketCAN error frames (<linux/can/error.h>): the controller reports bus
/// problems as frames with CAN_ERR_FLAG in the id, the error classes in the
/// id's low bits and details in the data (data[1] controller status). The
/// driver subscribes (CAN_RAW_ERR_FILTER) to bus-off, controller problems,
/// restarted, no ACK and TX timeout; not to bus errors or lost arbitration,
/// which can arrive at every bit error and flood the RT loop.

#include <cstdint>
#include <string>

#include "drivers/canopen/301/frame.hpp"

namespace hapticd::drivers::canopen {

/// The error classes the driver subscribes to (the CAN_RAW_ERR_FILTER mask).
std::uint32_t subscribed_error_classes() noexcept;

enum class BusErrorSeverity : std::uint8_t {
  none,    ///< not an error frame
  notice,  ///< counted: warning level, back to error active, restarted
  fault,   ///< latches a fault: bus-off, no ACK, TX timeout, RX/TX overflow, error passive
};

struct BusError {
  std::uint32_t classes = 0;    ///< CAN_ERR_* class bits of the id
  std::uint8_t controller = 0;  ///< data[1]: CAN_ERR_CRTL_* bits
  BusErrorSeverity severity = BusErrorSeverity::none;
};
BusError decode_error_frame(const cia301::Frame& frame) noexcept;
/// "bus-off; controller: TX error passive"; "" for a frame that is not an error frame.
std::string describe(const BusError& error);

}  // namespace hapticd::drivers::canopen
