#pragma once
/// \file
/// The CiA 402 drive state machine: the state from the statusword (0x6041)
/// by its mask/value table, the controlword (0x6040) commands, the drive's
/// transitions (what the simulated drive does) and the master's next
/// controlword towards Operation Enabled (what the driver sends).
///
///   state                   statusword mask  value    controlword command    bits 7,3..0
///   Not Ready to Switch On  0x004F           0x0000   Shutdown               0 x110 (0x06)
///   Switch On Disabled      0x004F           0x0040   Switch On              0 0111 (0x07)
///   Ready to Switch On      0x006F           0x0021   Enable Operation       0 1111 (0x0F)
///   Switched On             0x006F           0x0023   Disable Voltage        0 xx0x (0x00)
///   Operation Enabled       0x006F           0x0027   Quick Stop             0 x01x (0x02)
///   Quick Stop Active       0x006F           0x0007   Disable Operation      0 0111 (0x07)
///   Fault Reaction Active   0x004F           0x000F   Fault Reset            0 -> 1 edge of bit 7
///   Fault                   0x004F           0x0008
/// Bit 8 of the controlword is Halt.

#include <cstdint>
#include <optional>
#include <string_view>

namespace hapticd::drivers::canopen::cia402 {

enum class DriveState : std::uint8_t {
  not_ready_to_switch_on,
  switch_on_disabled,
  ready_to_switch_on,
  switched_on,
  operation_enabled,
  quick_stop_active,
  fault_reaction_active,
  fault,
};
std::string_view to_string(DriveState state) noexcept;  ///< "Operation Enabled", ...

/// Statusword bits.
namespace status_bit {
inline constexpr std::uint16_t ready_to_switch_on = 1U << 0;
inline constexpr std::uint16_t switched_on = 1U << 1;
inline constexpr std::uint16_t operation_enabled = 1U << 2;
inline constexpr std::uint16_t fault = 1U << 3;
inline constexpr std::uint16_t voltage_enabled = 1U << 4;
inline constexpr std::uint16_t quick_stop = 1U << 5;  ///< 0 = quick stop active
inline constexpr std::uint16_t switch_on_disabled = 1U << 6;
inline constexpr std::uint16_t warning = 1U << 7;
inline constexpr std::uint16_t remote = 1U << 9;
inline constexpr std::uint16_t target_reached = 1U << 10;
inline constexpr std::uint16_t internal_limit_active = 1U << 11;
inline constexpr std::uint16_t following_command =
    1U << 12;  ///< cyclic modes: the drive follows the command value
}  // namespace status_bit

/// The state the statusword shows; nullopt for a pattern in no row of the table.
std::optional<DriveState> decode_statusword(std::uint16_t statusword) noexcept;
/// The state bits (0..6) of a state; the drive ORs in voltage, remote, ...
std::uint16_t state_bits(DriveState state) noexcept;

/// Controlword bits.
namespace control_bit {
inline constexpr std::uint16_t switch_on = 1U << 0;
inline constexpr std::uint16_t enable_voltage = 1U << 1;
inline constexpr std::uint16_t quick_stop = 1U << 2;  ///< 0 = quick stop
inline constexpr std::uint16_t enable_operation = 1U << 3;
inline constexpr std::uint16_t fault_reset = 1U << 7;
inline constexpr std::uint16_t halt = 1U << 8;
}  // namespace control_bit

/// The controlword of each command (bits 7 and 3..0; others zero).
namespace controlword {
inline constexpr std::uint16_t shutdown = 0x0006;
inline constexpr std::uint16_t switch_on = 0x0007;
inline constexpr std::uint16_t enable_operation = 0x000F;
inline constexpr std::uint16_t disable_voltage = 0x0000;
inline constexpr std::uint16_t quick_stop = 0x0002;
inline constexpr std::uint16_t disable_operation = 0x0007;
inline constexpr std::uint16_t fault_reset = 0x0080;
}  // namespace controlword

enum class Command : std::uint8_t {
  shutdown,
  switch_on,         ///< also Disable Operation (same bits, 0111)
  enable_operation,  ///< also Switch On + Enable Operation from Ready to Switch On
  disable_voltage,
  quick_stop,
  fault_reset,  ///< the 0 -> 1 edge of bit 7
};
std::string_view to_string(Command command) noexcept;

/// The command a drive reads from a controlword, given the previous one (the
/// fault reset is an edge). Disable Voltage and Quick Stop win over the
/// others, as their bits are active low / the voltage enable.
Command decode_controlword(std::uint16_t previous, std::uint16_t current) noexcept;

/// The drive's transition on a command (CiA 402 transitions 2-12, 15, 16;
/// Switch On + Enable Operation from Ready to Switch On takes 3 then 4).
/// Transitions 0, 1, 13, 14 are the drive's own (power-up and fault); see
/// on_fault(). A command with no transition from a state leaves it.
DriveState next_state(DriveState state, Command command) noexcept;
/// Transition 13: any state but Fault goes to Fault Reaction Active on a fault.
DriveState on_fault(DriveState state) noexcept;
/// Does the power stage drive the motor in this state (torque applied)?
constexpr bool power_stage_on(DriveState s) noexcept { return s == DriveState::operation_enabled; }

/// The master's next controlword towards Operation Enabled from the state the
/// statusword shows, given the controlword it sent last (the fault reset is
/// a 0 -> 1 edge of bit 7 over two cycles: bit 7 low, then high). Halt and
/// the mode-specific bits are not set here.
std::uint16_t controlword_towards_enabled(DriveState state, std::uint16_t last_sent) noexcept;

}  // namespace hapticd::drivers::canopen::cia402
