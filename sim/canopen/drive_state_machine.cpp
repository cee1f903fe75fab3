#include "sim/canopen/drive_state_machine.hpp"

namespace hapticd::drivers::canopen::sim {

namespace {

using S = DriveState;
using C = ControlCommand;

constexpr std::uint16_t fault_reset_bit = 1U << 7;

/// The device control commands: (controlword & mask) == value, bit 7 low.
struct Pattern {
  std::uint16_t mask;
  std::uint16_t value;
  ControlCommand command;
};
constexpr Pattern patterns[] = {
    {0x0087, 0x0006, C::shutdown},          // 0 x 1 1 0
    {0x008F, 0x0007, C::switch_on},         // 0 0 1 1 1 (also Disable Operation)
    {0x008F, 0x000F, C::enable_operation},  // 0 1 1 1 1
    {0x0082, 0x0000, C::disable_voltage},   // 0 x x 0 x
    {0x0086, 0x0002, C::quick_stop},        // 0 x 0 1 x
};

struct Transition {
  DriveState from;
  ControlCommand command;
  DriveState to;
  int number;  ///< CiA 402's
};
constexpr Transition transitions[] = {
    {S::switch_on_disabled, C::shutdown, S::ready_to_switch_on, 2},
    {S::ready_to_switch_on, C::switch_on, S::switched_on, 3},
    {S::ready_to_switch_on, C::enable_operation, S::operation_enabled, 3},  // 3 then 4
    {S::switched_on, C::enable_operation, S::operation_enabled, 4},
    {S::operation_enabled, C::switch_on, S::switched_on, 5},  // Disable Operation
    {S::switched_on, C::shutdown, S::ready_to_switch_on, 6},
    {S::ready_to_switch_on, C::disable_voltage, S::switch_on_disabled, 7},
    {S::ready_to_switch_on, C::quick_stop, S::switch_on_disabled, 7},
    {S::operation_enabled, C::shutdown, S::ready_to_switch_on, 8},
    {S::operation_enabled, C::disable_voltage, S::switch_on_disabled, 9},
    {S::switched_on, C::disable_voltage, S::switch_on_disabled, 10},
    {S::switched_on, C::quick_stop, S::switch_on_disabled, 10},
    {S::operation_enabled, C::quick_stop, S::quick_stop_active, 11},
    {S::quick_stop_active, C::disable_voltage, S::switch_on_disabled, 12},
    {S::fault, C::fault_reset, S::switch_on_disabled, 15},
    {S::quick_stop_active, C::enable_operation, S::operation_enabled, 16},
};

struct StateBits {
  DriveState state;
  std::uint16_t bits;  ///< 6 5 3 2 1 0
};
constexpr StateBits statuswords[] = {
    {S::not_ready_to_switch_on, 0b000'0000}, {S::switch_on_disabled, 0b100'0000},
    {S::ready_to_switch_on, 0b010'0001},     {S::switched_on, 0b010'0011},
    {S::operation_enabled, 0b010'0111},      {S::quick_stop_active, 0b000'0111},
    {S::fault_reaction_active, 0b000'1111},  {S::fault, 0b000'1000},
};

}  // namespace

std::string_view state_name(DriveState state) noexcept {
  switch (state) {
    case S::not_ready_to_switch_on:
      return "Not Ready to Switch On";
    case S::switch_on_disabled:
      return "Switch On Disabled";
    case S::ready_to_switch_on:
      return "Ready to Switch On";
    case S::switched_on:
      return "Switched On";
    case S::operation_enabled:
      return "Operation Enabled";
    case S::quick_stop_active:
      return "Quick Stop Active";
    case S::fault_reaction_active:
      return "Fault Reaction Active";
    case S::fault:
      return "Fault";
  }
  return "?";
}

std::optional<ControlCommand> control_command(std::uint16_t previous, std::uint16_t controlword) noexcept {
  if ((controlword & fault_reset_bit) != 0 && (previous & fault_reset_bit) == 0) return C::fault_reset;
  for (const Pattern& p : patterns)
    if ((controlword & p.mask) == p.value) return p.command;
  return std::nullopt;
}

DriveState after_command(DriveState state, ControlCommand command, std::int16_t quick_stop_option) noexcept {
  for (const Transition& t : transitions) {
    if (t.from != state || t.command != command) continue;
    if (t.number == 16 && (quick_stop_option < 5 || quick_stop_option > 8)) return state;
    return t.to;
  }
  return state;
}

std::uint16_t state_statusword(DriveState state) noexcept {
  for (const StateBits& s : statuswords)
    if (s.state == state) return s.bits;
  return 0;
}

}  // namespace hapticd::drivers::canopen::sim
