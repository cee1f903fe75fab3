#pragma once
/// \file
/// CiA 402 (drives and motion control) objects this subset uses, the modes
/// of operation (0x6060/0x6061), and the entry descriptions of the drive
/// profile objects. Units: 0x6071 target torque and 0x6077 torque actual are
/// per mille of 0x6076 motor rated torque, which is in mN m (mN for a linear
/// motor); 0x6064 position and 0x606C velocity are in the drive's position
/// units (encoder increments unless its factor group says otherwise).

#include <cstdint>
#include <optional>
#include <string_view>

#include "drivers/canopen/301/object_dictionary.hpp"

namespace hapticd::drivers::canopen::cia402 {

namespace object {
inline constexpr std::uint16_t abort_connection_option = 0x6007;  ///< INTEGER16: reaction to a lost master
inline constexpr std::uint16_t error_code = 0x603F;               ///< UNSIGNED16: last error (as in the EMCY)
inline constexpr std::uint16_t controlword = 0x6040;              ///< UNSIGNED16
inline constexpr std::uint16_t statusword = 0x6041;               ///< UNSIGNED16
inline constexpr std::uint16_t quick_stop_option = 0x605A;        ///< INTEGER16
inline constexpr std::uint16_t modes_of_operation = 0x6060;       ///< INTEGER8
inline constexpr std::uint16_t modes_of_operation_display = 0x6061;  ///< INTEGER8
inline constexpr std::uint16_t position_actual = 0x6064;             ///< INTEGER32, position units
inline constexpr std::uint16_t velocity_actual = 0x606C;             ///< INTEGER32, velocity units
inline constexpr std::uint16_t target_torque = 0x6071;               ///< INTEGER16, per mille of 0x6076
inline constexpr std::uint16_t max_torque = 0x6072;                  ///< UNSIGNED16, per mille of 0x6076
inline constexpr std::uint16_t rated_torque = 0x6076;                ///< UNSIGNED32, mN m
inline constexpr std::uint16_t torque_actual = 0x6077;               ///< INTEGER16, per mille of 0x6076
inline constexpr std::uint16_t interpolation_time_period =
    0x60C2;                                                     ///< 1: UNSIGNED8 value, 2: INTEGER8 exponent
inline constexpr std::uint16_t supported_drive_modes = 0x6502;  ///< UNSIGNED32, bit per mode
}  // namespace object

/// 0x6060 / 0x6061 values (INTEGER8).
enum class Mode : std::int8_t {
  none = 0,
  profile_position = 1,
  velocity = 2,
  profile_velocity = 3,
  profile_torque = 4,
  homing = 6,
  interpolated_position = 7,
  cyclic_synchronous_position = 8,
  cyclic_synchronous_velocity = 9,
  cyclic_synchronous_torque = 10,
};
std::string_view to_string(
    Mode mode) noexcept;  ///< "cyclic synchronous torque", or "manufacturer-specific mode"
std::string_view describe_mode(std::int8_t value) noexcept;
/// 0x6502 bit of a mode (bit 9 = cyclic synchronous torque), if the mode has one.
std::optional<unsigned> supported_mode_bit(Mode mode) noexcept;

/// 0x6007 values.
namespace abort_connection {
inline constexpr std::int16_t no_action = 0;
inline constexpr std::int16_t fault = 1;            ///< malfunction: fault reaction, then Fault
inline constexpr std::int16_t disable_voltage = 2;  ///< to Switch On Disabled
inline constexpr std::int16_t quick_stop = 3;
}  // namespace abort_connection

/// 0x60C2: interpolation time = value * 10^exponent s (sub 1 UNSIGNED8, sub 2 INTEGER8).
struct InterpolationPeriod {
  std::uint8_t value = 0;
  std::int8_t exponent = 0;
  friend bool operator==(const InterpolationPeriod&, const InterpolationPeriod&) = default;
};
/// The exact representation of a period of whole microseconds (1 us .. 255 s);
/// nullopt when it has none (e.g. 333.3 us). Prefers the largest exponent.
std::optional<InterpolationPeriod> encode_interpolation_period(double period_s) noexcept;
double decode_interpolation_period(InterpolationPeriod p) noexcept;

/// Description of a drive-profile entry (0x6000..0x67FF subset).
std::optional<cia301::ObjectInfo> find_drive_object(cia301::ObjectAddress address) noexcept;
/// Either profile: what the commissioning method and the simulated drive look up.
std::optional<cia301::ObjectInfo> find_standard_object(cia301::ObjectAddress address) noexcept;

}  // namespace hapticd::drivers::canopen::cia402
