#pragma once
/// \file
/// CiA 301 emergency object (COB-ID 0x80 + node, 8 bytes): bytes 0-1 the
/// emergency error code (little-endian), byte 2 the error register (object
/// 0x1001), bytes 3-7 the manufacturer-specific error field. Error code
/// 0x0000 means "error reset or no error". The CiA 301 code classes and the
/// communication codes (0x81xx, 0x82xx) are described here; the drive
/// profile codes are in 402/drive_errors.hpp.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "drivers/canopen/301/frame.hpp"

namespace hapticd::drivers::canopen::cia301 {

struct Emergency {
  std::uint16_t error_code = 0;
  std::uint8_t error_register = 0;
  std::array<std::uint8_t, 5> manufacturer{};
  friend bool operator==(const Emergency&, const Emergency&) = default;
};

Frame encode_emergency(std::uint8_t node, const Emergency& emcy) noexcept;
/// nullopt unless the frame is an 8-byte EMCY of `node`.
std::optional<Emergency> decode_emergency(const Frame& frame, std::uint8_t node) noexcept;

/// Error codes the driver and the simulated drive use by name (CiA 301).
namespace emcy_code {
inline constexpr std::uint16_t no_error = 0x0000;
inline constexpr std::uint16_t generic = 0x1000;
inline constexpr std::uint16_t can_overrun = 0x8110;
inline constexpr std::uint16_t can_error_passive = 0x8120;
inline constexpr std::uint16_t heartbeat = 0x8130;  ///< life guard or heartbeat error
inline constexpr std::uint16_t bus_off_recovered = 0x8140;
inline constexpr std::uint16_t pdo_length = 0x8210;  ///< PDO not processed due to length error
inline constexpr std::uint16_t pdo_length_exceeded = 0x8220;
inline constexpr std::uint16_t rpdo_timeout = 0x8250;
}  // namespace emcy_code

/// Error register bits (object 0x1001).
namespace error_register {
inline constexpr std::uint8_t generic = 0x01;
inline constexpr std::uint8_t current = 0x02;
inline constexpr std::uint8_t voltage = 0x04;
inline constexpr std::uint8_t temperature = 0x08;
inline constexpr std::uint8_t communication = 0x10;
inline constexpr std::uint8_t device_profile = 0x20;
inline constexpr std::uint8_t manufacturer = 0x80;
}  // namespace error_register
/// "generic, current" for 0x03; "none" for 0.
std::string describe_error_register(std::uint8_t reg);

/// Words for the codes CiA 301 itself defines (exact communication codes,
/// then the class of the high byte / high nibble); nullopt if none applies.
std::optional<std::string_view> describe_communication_error(std::uint16_t code) noexcept;
/// The class of any error code by its high nibble ("current", "voltage",
/// "temperature", "device hardware", ...): always a word.
std::string_view error_class(std::uint16_t code) noexcept;

}  // namespace hapticd::drivers::canopen::cia301
