#pragma once
/// \file
/// CiA 301 network management: the NMT node-control message (COB-ID 0x000,
/// 2 bytes: command specifier, node-ID or 0 for all), the NMT error-control
/// message (heartbeat and boot-up, COB-ID 0x700 + node, 1 byte: the NMT state)
/// and SYNC (COB-ID 0x080, no data, or 1 byte counter when 0x1019 > 1).

#include <cstdint>
#include <optional>
#include <string_view>

#include "drivers/canopen/301/frame.hpp"

namespace hapticd::drivers::canopen::cia301 {

/// NMT command specifiers (CiA 301 node control).
enum class NmtCommand : std::uint8_t {
  start = 0x01,                  ///< enter operational
  stop = 0x02,                   ///< enter stopped
  enter_pre_operational = 0x80,  ///< enter pre-operational
  reset_node = 0x81,             ///< reset application
  reset_communication = 0x82,    ///< reset communication
};
std::optional<NmtCommand> to_nmt_command(std::uint8_t cs) noexcept;
std::string_view to_string(NmtCommand command) noexcept;

/// NMT states as a heartbeat reports them (CiA 301 error control).
enum class NmtState : std::uint8_t {
  boot_up = 0x00,  ///< the boot-up message (sent once on entering pre-operational)
  stopped = 0x04,
  operational = 0x05,
  pre_operational = 0x7F,
};
std::optional<NmtState> to_nmt_state(std::uint8_t value) noexcept;
std::string_view to_string(NmtState state) noexcept;

Frame encode_nmt(NmtCommand command, std::uint8_t node) noexcept;  ///< node 0: all nodes
struct NmtMessage {
  NmtCommand command;
  std::uint8_t node;  ///< 0 = all nodes
};
std::optional<NmtMessage> decode_nmt(const Frame& frame) noexcept;
/// Does an NMT message address this node (directly or by broadcast)?
constexpr bool addresses(const NmtMessage& m, std::uint8_t node) noexcept {
  return m.node == 0 || m.node == node;
}

Frame encode_heartbeat(std::uint8_t node, NmtState state) noexcept;
struct Heartbeat {
  std::uint8_t node;
  NmtState state;
};
/// Bit 7 is the node-guarding toggle (not used by heartbeat); it is ignored.
std::optional<Heartbeat> decode_heartbeat(const Frame& frame) noexcept;

Frame encode_sync() noexcept;
Frame encode_sync(std::uint8_t counter) noexcept;  ///< with counter (0x1019 > 1)
bool is_sync(const Frame& frame) noexcept;

/// 0x1016 consumer heartbeat time entry: bits 23..16 the producer's
/// node-ID, bits 15..0 the time in ms (bits 31..24 zero). 0 ms or node 0
/// leaves the entry unused.
constexpr std::uint32_t encode_consumer_heartbeat(std::uint8_t node, std::uint16_t time_ms) noexcept {
  return (static_cast<std::uint32_t>(node) << 16) | time_ms;
}
struct ConsumerHeartbeat {
  std::uint8_t node;
  std::uint16_t time_ms;
  constexpr bool used() const noexcept { return node != 0 && node <= 127 && time_ms != 0; }
};
constexpr ConsumerHeartbeat decode_consumer_heartbeat(std::uint32_t entry) noexcept {
  return {static_cast<std::uint8_t>((entry >> 16) & 0xFFU), static_cast<std::uint16_t>(entry & 0xFFFFU)};
}

}  // namespace hapticd::drivers::canopen::cia301
