#pragma once
/// \file
/// SocketCAN error frames (<linux/can/error.h>): the controller reports bus
/// problems as frames with CAN_ERR_FLAG in the id, the error classes in the
/// id's low bits and details in the data (data[1] controller status). The
/// driver subscribes (CAN_RAW_ERR_FILTER) to bus-off, controller problems,
/// restarted, no ACK and TX timeout; not to bus errors or lost arbitration,
/// which can arrive at every bit error and flood the RT loop. And what
/// arrives on the socket that is no frame at all (MalformedMessage).

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

/// What arrived instead of a can_frame. Only a message of exactly
/// sizeof(struct can_frame) (16 bytes) with a data length of 0..8 is a frame
/// (CAN FD is not enabled on the socket, so a 72-byte canfd_frame is none).
struct MalformedMessage {
  std::uint32_t bytes = 0;   ///< the message's real length (MSG_TRUNC), 0 for an empty one
  bool truncated = false;    ///< longer than the receive buffer and the kernel did not say how long
  std::uint32_t can_id = 0;  ///< bytes == 16: the can_frame's can_id
  std::uint8_t can_len = 0;  ///< bytes == 16: its len (> 8)
};
/// "a 72-byte message on the CAN socket: not a can_frame (16 bytes)".
std::string describe(const MalformedMessage& message);

}  // namespace hapticd::drivers::canopen
