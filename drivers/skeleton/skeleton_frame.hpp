#pragma once
/// \file
/// The skeleton wire (README.md): one 8-byte request a period from hapticd,
/// one 8-byte reply from the peer, little-endian. Pure codec: no system
/// calls, unit-tested byte by byte (drivers/skeleton/tests). A real driver
/// puts its protocol's frames, objects or registers here.

#include <array>
#include <cstdint>
#include <optional>
#include <span>

namespace hapticd::drivers::skeleton {

inline constexpr std::size_t frame_size = 8;
using Frame = std::array<std::uint8_t, frame_size>;

/// hapticd -> peer: the command for this period.
struct Request {
  std::uint16_t sequence = 0;  ///< echoed by the reply
  bool enable = false;         ///< power stage on; off: the peer applies nothing
  bool reset = false;          ///< clear a latched fault
  std::int32_t command = 0;    ///< force or torque in counts (force_per_count each)
};

/// peer -> hapticd: the state after applying the request.
struct Reply {
  std::uint16_t sequence = 0;  ///< of the request it answers
  bool enabled = false;        ///< the power stage is on
  bool faulted = false;        ///< a fault is latched (fault_code says which)
  std::uint8_t fault_code = 0;
  std::int32_t position = 0;  ///< encoder counts
};

Frame encode(const Request& request) noexcept;
/// nullopt unless exactly frame_size bytes with the reserved bits zero.
std::optional<Reply> decode_reply(std::span<const std::uint8_t> bytes) noexcept;

}  // namespace hapticd::drivers::skeleton
