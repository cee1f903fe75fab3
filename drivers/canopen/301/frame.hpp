#pragma once
/// \file
/// One classic CAN frame as the codecs see it: the identifier word exactly as
/// SocketCAN's `struct can_frame` carries it (11-bit id, or with the
/// CAN_EFF/RTR/ERR flag bits of <linux/can.h>), the data length 0..8 and the
/// data bytes. CANopen (CiA 301) puts every multi-byte value on the wire
/// little-endian, whatever the host: put_le/get_le say so once.

#include <array>
#include <cstddef>
#include <cstdint>

namespace hapticd::drivers::canopen::cia301 {

struct Frame {
  std::uint32_t id = 0;  ///< can_id word: 11-bit identifier plus SocketCAN flag bits
  std::uint8_t len = 0;  ///< data length code, 0..8
  std::array<std::uint8_t, 8> data{};

  friend bool operator==(const Frame&, const Frame&) = default;
};

/// SocketCAN flag bits of the can_id word (<linux/can.h>), restated so the
/// codecs need no system header; can_socket.cpp checks they match.
inline constexpr std::uint32_t can_eff_flag = 0x80000000U;  ///< 29-bit identifier
inline constexpr std::uint32_t can_rtr_flag = 0x40000000U;  ///< remote transmission request
inline constexpr std::uint32_t can_err_flag = 0x20000000U;  ///< error frame from the controller
inline constexpr std::uint32_t can_sff_mask = 0x000007FFU;  ///< 11-bit identifier

/// True for an ordinary 11-bit data frame (what CANopen's predefined
/// connection set uses); false for RTR, 29-bit and error frames.
constexpr bool is_standard_data_frame(const Frame& f) noexcept {
  return (f.id & (can_eff_flag | can_rtr_flag | can_err_flag)) == 0 && f.len <= 8;
}

/// Little-endian store/load of the low `bytes` bytes of `value` at `offset`.
constexpr void put_le(std::array<std::uint8_t, 8>& data, std::size_t offset, std::uint32_t value,
                      std::size_t bytes) noexcept {
  for (std::size_t i = 0; i < bytes && offset + i < data.size(); ++i)
    data[offset + i] = static_cast<std::uint8_t>(value >> (8 * i));
}
constexpr std::uint32_t get_le(const std::array<std::uint8_t, 8>& data, std::size_t offset,
                               std::size_t bytes) noexcept {
  std::uint32_t value = 0;
  for (std::size_t i = 0; i < bytes && offset + i < data.size(); ++i)
    value |= static_cast<std::uint32_t>(data[offset + i]) << (8 * i);
  return value;
}

}  // namespace hapticd::drivers::canopen::cia301
