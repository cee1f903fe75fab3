#include "drivers/canopen/402/state_machine.hpp"

namespace hapticd::drivers::canopen::cia402 {
namespace {

struct Row {
  std::uint16_t mask;
  std::uint16_t value;
  DriveState state;
};
// CiA 402 statusword table (bits 0-3, 5, 6; bit 5 only where it tells states apart).
constexpr Row rows[] = {
    {0x004F, 0x0000, DriveState::not_ready_to_switch_on}, {0x004F, 0x0040, DriveState::switch_on_disabled},
    {0x006F, 0x0021, DriveState::ready_to_switch_on},     {0x006F, 0x0023, DriveState::switched_on},
    {0x006F, 0x0027, DriveState::operation_enabled},      {0x006F, 0x0007, DriveState::quick_stop_active},
    {0x004F, 0x000F, DriveState::fault_reaction_active},  {0x004F, 0x0008, DriveState::fault},
};

}  // namespace

std::string_view to_string(DriveState state) noexcept {
  switch (state) {
    case DriveState::not_ready_to_switch_on:
      return "Not Ready to Switch On";
    case DriveState::switch_on_disabled:
      return "Switch On Disabled";
    case DriveState::ready_to_switch_on:
      return "Ready to Switch On";
    case DriveState::switched_on:
      return "Switched On";
    case DriveState::operation_enabled:
      return "Operation Enabled";
    case DriveState::quick_stop_active:
      return "Quick Stop Active";
    case DriveState::fault_reaction_active:
      return "Fault Reaction Active";
    case DriveState::fault:
      return "Fault";
  }
  return "unknown drive state";
}

std::string_view to_string(Command command) noexcept {
  switch (command) {
    case Command::shutdown:
      return "Shutdown";
    case Command::switch_on:
      return "Switch On";
    case Command::enable_operation:
      return "Enable Operation";
    case Command::disable_voltage:
      return "Disable Voltage";
    case Command::quick_stop:
      return "Quick Stop";
    case Command::fault_reset:
      return "Fault Reset";
  }
  return "unknown command";
}

std::optional<DriveState> decode_statusword(std::uint16_t statusword) noexcept {
  for (const Row& r : rows)
    if ((statusword & r.mask) == r.value) return r.state;
  return std::nullopt;
}

std::uint16_t state_bits(DriveState state) noexcept {
  for (const Row& r : rows)
    if (r.state == state) return r.value;
  return 0;
}

Command decode_controlword(std::uint16_t previous, std::uint16_t current) noexcept {
  if ((current & control_bit::fault_reset) != 0 && (previous & control_bit::fault_reset) == 0)
    return Command::fault_reset;
  if ((current & control_bit::enable_voltage) == 0) return Command::disable_voltage;
  if ((current & control_bit::quick_stop) == 0) return Command::quick_stop;
  if ((current & control_bit::switch_on) == 0) return Command::shutdown;
  if ((current & control_bit::enable_operation) == 0) return Command::switch_on;
  return Command::enable_operation;
}

DriveState next_state(DriveState state, Command command) noexcept {
  using S = DriveState;
  using C = Command;
  switch (state) {
    case S::switch_on_disabled:
      return command == C::shutdown ? S::ready_to_switch_on : state;  // 2
    case S::ready_to_switch_on:
      if (command == C::switch_on) return S::switched_on;                                           // 3
      if (command == C::enable_operation) return S::operation_enabled;                              // 3 + 4
      if (command == C::disable_voltage || command == C::quick_stop) return S::switch_on_disabled;  // 7
      return state;
    case S::switched_on:
      if (command == C::enable_operation) return S::operation_enabled;                              // 4
      if (command == C::shutdown) return S::ready_to_switch_on;                                     // 6
      if (command == C::disable_voltage || command == C::quick_stop) return S::switch_on_disabled;  // 10
      return state;
    case S::operation_enabled:
      if (command == C::switch_on) return S::switched_on;               // 5 (Disable Operation)
      if (command == C::shutdown) return S::ready_to_switch_on;         // 8
      if (command == C::disable_voltage) return S::switch_on_disabled;  // 9
      if (command == C::quick_stop) return S::quick_stop_active;        // 11
      return state;
    case S::quick_stop_active:
      if (command == C::disable_voltage) return S::switch_on_disabled;  // 12
      if (command == C::enable_operation) return S::operation_enabled;  // 16
      return state;
    case S::fault:
      return command == C::fault_reset ? S::switch_on_disabled : state;  // 15
    case S::not_ready_to_switch_on:
    case S::fault_reaction_active:
      return state;  // the drive leaves these on its own (transitions 1, 14)
  }
  return state;
}

DriveState on_fault(DriveState state) noexcept {
  return state == DriveState::fault ? state : DriveState::fault_reaction_active;
}

std::uint16_t controlword_towards_enabled(DriveState state, std::uint16_t last_sent) noexcept {
  switch (state) {
    case DriveState::fault:
      // Bit 7 low for one cycle, then high: the edge the drive resets on.
      return (last_sent & control_bit::fault_reset) != 0 ? controlword::disable_voltage
                                                         : controlword::fault_reset;
    case DriveState::switch_on_disabled:
      return controlword::shutdown;
    case DriveState::ready_to_switch_on:
      return controlword::switch_on;
    case DriveState::switched_on:
    case DriveState::operation_enabled:
      return controlword::enable_operation;
    case DriveState::quick_stop_active:
    case DriveState::not_ready_to_switch_on:
    case DriveState::fault_reaction_active:
      return controlword::disable_voltage;
  }
  return controlword::disable_voltage;
}

}  // namespace hapticd::drivers::canopen::cia402
