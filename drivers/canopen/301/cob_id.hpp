#pragma once
/// \file
/// CiA 301 predefined connection set: the COB-ID (CAN identifier) of each
/// service is a function code plus the node-ID (1..127). SYNC and NMT are
/// broadcast and carry no node-ID.

#include <cstdint>
#include <optional>

namespace hapticd::drivers::canopen::cia301 {

inline constexpr std::uint8_t min_node_id = 1;
inline constexpr std::uint8_t max_node_id = 127;

constexpr bool valid_node_id(int node) noexcept { return node >= min_node_id && node <= max_node_id; }

/// Function codes (CiA 301, predefined connection set).
namespace cob {
inline constexpr std::uint32_t nmt = 0x000;        ///< NMT node control, master -> all
inline constexpr std::uint32_t sync = 0x080;       ///< SYNC
inline constexpr std::uint32_t emcy_base = 0x080;  ///< EMCY = 0x80 + node
inline constexpr std::uint32_t tpdo1 = 0x180;      ///< TPDO1..4: 0x180, 0x280, 0x380, 0x480 + node
inline constexpr std::uint32_t rpdo1 = 0x200;      ///< RPDO1..4: 0x200, 0x300, 0x400, 0x500 + node
inline constexpr std::uint32_t sdo_tx = 0x580;     ///< SDO server -> client (response)
inline constexpr std::uint32_t sdo_rx = 0x600;     ///< SDO client -> server (request)
inline constexpr std::uint32_t heartbeat = 0x700;  ///< NMT error control (heartbeat, boot-up)
}  // namespace cob

constexpr std::uint32_t emcy_id(std::uint8_t node) noexcept { return cob::emcy_base + node; }
constexpr std::uint32_t sdo_request_id(std::uint8_t node) noexcept { return cob::sdo_rx + node; }
constexpr std::uint32_t sdo_response_id(std::uint8_t node) noexcept { return cob::sdo_tx + node; }
constexpr std::uint32_t heartbeat_id(std::uint8_t node) noexcept { return cob::heartbeat + node; }
/// Default COB-ID of TPDO n / RPDO n (n = 1..4).
constexpr std::uint32_t default_tpdo_id(int n, std::uint8_t node) noexcept {
  return cob::tpdo1 + 0x100U * static_cast<std::uint32_t>(n - 1) + node;
}
constexpr std::uint32_t default_rpdo_id(int n, std::uint8_t node) noexcept {
  return cob::rpdo1 + 0x100U * static_cast<std::uint32_t>(n - 1) + node;
}

/// The node-ID in an identifier of the form base + node (1..127), if it is one.
constexpr std::optional<std::uint8_t> node_of(std::uint32_t id, std::uint32_t base) noexcept {
  if (id <= base || id > base + max_node_id) return std::nullopt;
  return static_cast<std::uint8_t>(id - base);
}

}  // namespace hapticd::drivers::canopen::cia301
