#pragma once
/// \file
/// The simulated drive's CiA 402 state machine (CiA 402-2 / IEC 61800-7-201,
/// the PDS finite state automaton), written from the standard's tables, not
/// taken from the driver's codec (its 402/state_machine.hpp): the device
/// control commands by the controlword's bits, the transitions they cause,
/// and the statusword each state shows.
///
///   command            controlword bits 7 3 2 1 0     transitions
///   Shutdown                        0 x 1 1 0         2, 6, 8
///   Switch On                       0 0 1 1 1         3
///   Disable Operation               0 0 1 1 1         5
///   Enable Operation                0 1 1 1 1         4, 16 (and 3 + 4 from Ready to Switch On)
///   Disable Voltage                 0 x x 0 x         7, 9, 10, 12
///   Quick Stop                      0 x 0 1 x         7, 10, 11
///   Fault Reset                     0 -> 1 on bit 7   15
///
///   state                    statusword bits 6 5 3 2 1 0
///   Not Ready to Switch On               0 x 0 0 0 0
///   Switch On Disabled                   1 x 0 0 0 0
///   Ready to Switch On                   0 1 0 0 0 1
///   Switched On                          0 1 0 0 1 1
///   Operation Enabled                    0 1 0 1 1 1
///   Quick Stop Active                    0 0 0 1 1 1
///   Fault Reaction Active                0 x 1 1 1 1
///   Fault                                0 x 1 0 0 0
/// (x: this drive shows 0.) Transitions 0 and 1 (power on), 13 (a fault)
/// and 14 (the fault reaction done) are the drive's own.

#include <cstdint>
#include <optional>
#include <string_view>

namespace hapticd::drivers::canopen::sim {

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
std::string_view state_name(DriveState state) noexcept;  ///< "Operation Enabled", ...

/// A device control command by its bit pattern; Switch On and Disable
/// Operation share one (0111), as do Enable Operation and Switch On +
/// Enable Operation (1111).
enum class ControlCommand : std::uint8_t {
  shutdown,
  switch_on,  ///< or Disable Operation
  enable_operation,
  disable_voltage,
  quick_stop,
  fault_reset,
};

/// The command in `controlword` given the previous one (the fault reset is
/// the 0 -> 1 edge of bit 7); nullopt for a pattern of no command (bit 7
/// held high, no edge).
std::optional<ControlCommand> control_command(std::uint16_t previous, std::uint16_t controlword) noexcept;

/// The state after `command` in `state`: the transition table; the state
/// itself where the command causes none. Transition 16 (Quick Stop Active
/// to Operation Enabled) only with a 0x605A quick stop option code of 5..8.
DriveState after_command(DriveState state, ControlCommand command, std::int16_t quick_stop_option) noexcept;

/// Statusword bits 0..6 of a state (without bit 4, voltage enabled).
std::uint16_t state_statusword(DriveState state) noexcept;

/// Statusword bits this drive sets besides the state's.
namespace status_bit {
inline constexpr std::uint16_t voltage_enabled = 1U << 4;
inline constexpr std::uint16_t remote = 1U << 9;
inline constexpr std::uint16_t following_command = 1U << 12;  ///< cyclic synchronous modes
}  // namespace status_bit

/// Controlword bit 8: halt.
inline constexpr std::uint16_t halt_bit = 1U << 8;

}  // namespace hapticd::drivers::canopen::sim
