#pragma once
/// \file
/// The simulated drive's own reading of the CiA 301 wire, written from the
/// standard (CiA 301 v4.2: 7.3.5 the predefined connection set, 7.2.8 NMT
/// and error control, 7.2.5 SYNC, 7.2.7 EMCY, 7.5.2.35-38 the PDO
/// parameters), not from the driver's codecs (drivers/canopen/301/): a
/// misreading in one shows as a failure instead of passing both ends. SDO
/// is in sdo_server.hpp, CiA 402 in drive_state_machine.hpp.
///
/// The frame is the seam's (cia301::Frame: the id word of struct can_frame,
/// the length, 8 bytes), as CanSocket carries it; its flag bits are
/// <linux/can.h>'s.

#include <compare>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "drivers/canopen/301/frame.hpp"

namespace hapticd::drivers::canopen::sim {

using Frame = cia301::Frame;

/// An object dictionary entry: 16-bit index, 8-bit sub-index (CiA 301 7.4.1).
struct Address {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  // NOLINTNEXTLINE(modernize-use-nullptr): clang-tidy 14 takes the defaulted comparison's 0 for a pointer
  friend constexpr auto operator<=>(const Address&, const Address&) = default;
};
/// "0x6041:00"
std::string to_text(Address address);

/// An 11-bit data frame (no RTR, no 29-bit identifier, no error frame) of
/// at most 8 bytes: the only kind the predefined connection set uses.
bool is_data_frame(const Frame& frame) noexcept;

/// Multi-byte values on the wire are little-endian (CiA 301 7.1.2).
std::uint32_t get_le(const Frame& frame, std::size_t offset, std::size_t bytes) noexcept;
void put_le(Frame& frame, std::size_t offset, std::uint32_t value, std::size_t bytes) noexcept;

// ---- the predefined connection set (CiA 301 7.3.5, Table 63) ----------------

/// The 11-bit CAN-ID = function code (4 bits) << 7 | node-ID (7 bits).
namespace function_code {
inline constexpr std::uint32_t nmt = 0x0;    ///< with node-ID 0
inline constexpr std::uint32_t sync = 0x1;   ///< with node-ID 0
inline constexpr std::uint32_t emcy = 0x1;   ///< with the producer's node-ID
inline constexpr std::uint32_t tpdo1 = 0x3;  ///< TPDO n: 0x3 + 2 (n - 1)
inline constexpr std::uint32_t rpdo1 = 0x4;  ///< RPDO n: 0x4 + 2 (n - 1)
inline constexpr std::uint32_t sdo_server_to_client = 0xB;
inline constexpr std::uint32_t sdo_client_to_server = 0xC;
inline constexpr std::uint32_t nmt_error_control = 0xE;  ///< heartbeat, boot-up
}  // namespace function_code

constexpr std::uint32_t can_id(std::uint32_t function, std::uint8_t node) noexcept {
  return function << 7 | node;
}
/// The default CAN-ID of TPDO / RPDO `n` (1..4) of `node`.
constexpr std::uint32_t default_tpdo_id(int n, std::uint8_t node) noexcept {
  return can_id(function_code::tpdo1 + 2U * static_cast<std::uint32_t>(n - 1), node);
}
constexpr std::uint32_t default_rpdo_id(int n, std::uint8_t node) noexcept {
  return can_id(function_code::rpdo1 + 2U * static_cast<std::uint32_t>(n - 1), node);
}

// ---- NMT (CiA 301 7.2.8.3.1, 7.2.8.3.2) -------------------------------------

/// Node control: 2 bytes, the command specifier and the node-ID (0: all).
enum class NmtCommand : std::uint8_t {
  start_remote_node = 1,
  stop_remote_node = 2,
  enter_pre_operational = 128,
  reset_node = 129,
  reset_communication = 130,
};
struct NmtRequest {
  NmtCommand command;
  std::uint8_t node;  ///< 0: every node
};
/// A node-control message (CAN-ID 0, 2 bytes, a defined command); nullopt otherwise.
std::optional<NmtRequest> parse_nmt(const Frame& frame) noexcept;

/// The NMT state in a heartbeat (bits 6..0 of its one byte).
enum class NmtState : std::uint8_t {
  boot_up = 0,
  stopped = 4,
  operational = 5,
  pre_operational = 127,
};
std::string_view nmt_state_name(NmtState state) noexcept;  ///< "pre-operational", ...

Frame heartbeat(std::uint8_t node, NmtState state) noexcept;
struct Heartbeat {
  std::uint8_t node;
  NmtState state;
};
/// Another node's heartbeat or boot-up (0x701..0x77F, 1 byte, a defined
/// state; bit 7 is reserved); nullopt otherwise.
std::optional<Heartbeat> parse_heartbeat(const Frame& frame) noexcept;

/// 0x1016 consumer heartbeat time entry: bits 31..24 reserved (0), 23..16
/// the producer's node-ID, 15..0 the time in ms; node 0 or 0 ms: unused.
struct ConsumerEntry {
  std::uint32_t reserved = 0;
  std::uint8_t node = 0;
  std::uint16_t time_ms = 0;
  bool used() const noexcept { return node >= 1 && node <= 127 && time_ms != 0; }
};
ConsumerEntry consumer_entry(std::uint32_t word) noexcept;

// ---- SYNC (CiA 301 7.2.5) and EMCY (7.2.7) ----------------------------------

/// The SYNC of the default 0x1005: CAN-ID 0x080, no data or a 1-byte counter.
bool is_sync(const Frame& frame) noexcept;

/// An EMCY: 8 bytes, the error code (2), the error register 0x1001 (1),
/// 5 manufacturer bytes (0 here).
Frame emergency(std::uint8_t node, std::uint16_t error_code, std::uint8_t error_register) noexcept;

/// EMCY error codes this drive produces (CiA 301 Table 21).
namespace error_code {
inline constexpr std::uint16_t error_reset = 0x0000;
inline constexpr std::uint16_t generic = 0x1000;
inline constexpr std::uint16_t heartbeat = 0x8130;   ///< life guard or heartbeat error
inline constexpr std::uint16_t pdo_length = 0x8210;  ///< PDO not processed due to length error
}  // namespace error_code

/// The error register 0x1001 bits (CiA 301 7.5.2.2).
namespace error_register_bit {
inline constexpr std::uint8_t generic = 1U << 0;
inline constexpr std::uint8_t current = 1U << 1;
inline constexpr std::uint8_t voltage = 1U << 2;
inline constexpr std::uint8_t temperature = 1U << 3;
inline constexpr std::uint8_t communication = 1U << 4;
}  // namespace error_register_bit

// ---- PDO parameters (CiA 301 7.5.2.35-38) -----------------------------------

/// Communication parameter sub 1: bit 31 set = the PDO is not valid, bit 30
/// set = no RTR, bit 29 set = 29-bit CAN-ID, bits 28..11 zero for an 11-bit
/// one, bits 10..0 the CAN-ID.
struct PdoCobId {
  bool valid = false;
  bool rtr_allowed = false;
  bool extended = false;
  std::uint32_t upper_bits = 0;  ///< bits 28..11 (0 for an 11-bit CAN-ID)
  std::uint32_t can_id = 0;
};
PdoCobId pdo_cob_id(std::uint32_t word) noexcept;
/// The word of an 11-bit CAN-ID without RTR, valid or not.
std::uint32_t pdo_cob_id_word(std::uint32_t can_id, bool valid) noexcept;
/// CiA 301's restricted CAN-IDs (Table 64): no PDO may use them.
bool restricted_can_id(std::uint32_t can_id) noexcept;

/// Communication parameter sub 2: 0 synchronous acyclic, 1..240 every n-th
/// SYNC, 241..251 reserved, 252/253 on RTR only, 254/255 event-driven.
namespace transmission {
inline constexpr std::uint8_t last_synchronous = 240;
inline constexpr std::uint8_t event_manufacturer = 254;
inline constexpr std::uint8_t event_profile = 255;
}  // namespace transmission
constexpr bool synchronous(std::uint8_t type) noexcept { return type <= transmission::last_synchronous; }

/// Mapping parameter sub 1..64: bits 31..16 the index, 15..8 the
/// sub-index, 7..0 the length in bits.
struct MappedObject {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint8_t bits = 0;
};
MappedObject mapped_object(std::uint32_t word) noexcept;
std::uint32_t mapping_word(std::uint16_t index, std::uint8_t sub, std::uint8_t bits) noexcept;

}  // namespace hapticd::drivers::canopen::sim
