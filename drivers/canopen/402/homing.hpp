#pragma once
/// \file
/// CiA 402 homing mode (0x6060 = 6), pure: its objects, the controlword's
/// operation-start bit, the statusword's homing bits and the standard's
/// homing methods in words (CiA 402-2, "Homing mode"; IEC 61800-7-201).
///
///   controlword bit 4   homing operation start: 0 -> 1 starts, 1 -> 0 interrupts
///   controlword bit 8   halt: interrupts homing
///
///   statusword  bit 13 homing error  bit 12 homing attained  bit 10 target reached
///                   0                    0                       0   homing in progress
///                   0                    0                       1   interrupted or not started
///                   0                    1                       0   attained, target not reached
///                   0                    1                       1   completed successfully
///                   1                    0                       0   error, velocity not 0
///                   1                    0                       1   error, velocity 0
///                   1                    1                       x   reserved
///
/// After it, the position actual value (0x6064) is measured from the home
/// position the method found: CiA 402's zero position lies the home offset
/// (0x607C) past the home position, so the home position reads -0x607C.

#include <cstdint>
#include <string_view>

namespace hapticd::drivers::canopen::cia402 {

namespace object {
inline constexpr std::uint16_t home_offset = 0x607C;    ///< INTEGER32, position units
inline constexpr std::uint16_t homing_method = 0x6098;  ///< INTEGER8
inline constexpr std::uint16_t homing_speeds = 0x6099;  ///< 1: switch search, 2: zero search; UNSIGNED32
inline constexpr std::uint16_t homing_acceleration = 0x609A;  ///< UNSIGNED32, velocity units per second
}  // namespace object

namespace homing_speed_sub {
inline constexpr std::uint8_t switch_search = 1;
inline constexpr std::uint8_t zero_search = 2;
}  // namespace homing_speed_sub

/// Controlword bit 4 in homing mode.
inline constexpr std::uint16_t homing_operation_start = 1U << 4;

namespace homing_status_bit {
inline constexpr std::uint16_t target_reached = 1U << 10;
inline constexpr std::uint16_t attained = 1U << 12;
inline constexpr std::uint16_t error = 1U << 13;
}  // namespace homing_status_bit

enum class HomingStatus : std::uint8_t {
  in_progress,
  interrupted_or_not_started,
  attained_target_not_reached,
  completed,
  error_moving,   ///< homing error, velocity not 0
  error_at_rest,  ///< homing error, velocity 0
  reserved,       ///< bits 13 and 12 both set
};
/// The homing status bits of a statusword (meaningful in homing mode only).
HomingStatus decode_homing_status(std::uint16_t statusword) noexcept;
std::string_view to_string(HomingStatus status) noexcept;  ///< "homing in progress", ...

/// A 0x6098 method in words ("on the negative limit switch", "on the
/// current position"); "manufacturer-specific" below 0, "reserved" where
/// the standard defines none.
std::string_view describe_homing_method(std::int8_t method) noexcept;
/// The method moves the drive (every one but 35 and 37, homing on the current position).
bool homing_method_moves(std::int8_t method) noexcept;

}  // namespace hapticd::drivers::canopen::cia402
