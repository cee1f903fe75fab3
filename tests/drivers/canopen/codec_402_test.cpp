// CiA 402: statusword table, controlword commands, the drive's transitions,
// the master's enable sequence, modes, 0x60C2 and the drive error codes.
#include <gtest/gtest.h>

#include <cstdint>

#include "drivers/canopen/402/drive_errors.hpp"
#include "drivers/canopen/402/objects.hpp"
#include "drivers/canopen/402/state_machine.hpp"

namespace codec_402_test {

namespace co = hapticd::drivers::canopen::cia402;
using co::Command;
using co::DriveState;

TEST(Canopen402Statusword, MaskValueTable) {
  // Bare state bits from the CiA 402 table.
  EXPECT_EQ(co::decode_statusword(0x0000), DriveState::not_ready_to_switch_on);
  EXPECT_EQ(co::decode_statusword(0x0040), DriveState::switch_on_disabled);
  EXPECT_EQ(co::decode_statusword(0x0021), DriveState::ready_to_switch_on);
  EXPECT_EQ(co::decode_statusword(0x0023), DriveState::switched_on);
  EXPECT_EQ(co::decode_statusword(0x0027), DriveState::operation_enabled);
  EXPECT_EQ(co::decode_statusword(0x0007), DriveState::quick_stop_active);
  EXPECT_EQ(co::decode_statusword(0x000F), DriveState::fault_reaction_active);
  EXPECT_EQ(co::decode_statusword(0x0008), DriveState::fault);
  // As drives send them: voltage enabled (4), remote (9), warning (7), mode bits (12, 13), manufacturer (14,
  // 15).
  EXPECT_EQ(co::decode_statusword(0x0250), DriveState::switch_on_disabled);
  EXPECT_EQ(co::decode_statusword(0x0270), DriveState::switch_on_disabled);  // bit 5 free in this row
  EXPECT_EQ(co::decode_statusword(0x0231), DriveState::ready_to_switch_on);
  EXPECT_EQ(co::decode_statusword(0x0233), DriveState::switched_on);
  EXPECT_EQ(co::decode_statusword(0x1237), DriveState::operation_enabled);
  EXPECT_EQ(co::decode_statusword(0xC6B7), DriveState::operation_enabled);
  EXPECT_EQ(co::decode_statusword(0x0217), DriveState::quick_stop_active);
  EXPECT_EQ(co::decode_statusword(0x0218), DriveState::fault);
  EXPECT_EQ(co::decode_statusword(0x0238), DriveState::fault);  // bit 5 free in this row
  EXPECT_EQ(co::decode_statusword(0x021F), DriveState::fault_reaction_active);
  // In no row: switch-on-disabled with ready-to-switch-on set.
  EXPECT_FALSE(co::decode_statusword(0x0041));
  EXPECT_FALSE(co::decode_statusword(0x0001));
}

TEST(Canopen402Statusword, StateBitsRoundTrip) {
  for (const DriveState s :
       {DriveState::not_ready_to_switch_on, DriveState::switch_on_disabled, DriveState::ready_to_switch_on,
        DriveState::switched_on, DriveState::operation_enabled, DriveState::quick_stop_active,
        DriveState::fault_reaction_active, DriveState::fault})
    EXPECT_EQ(co::decode_statusword(co::state_bits(s)), s) << co::to_string(s);
}

TEST(Canopen402Controlword, CommandValues) {
  EXPECT_EQ(co::controlword::shutdown, 0x06);
  EXPECT_EQ(co::controlword::switch_on, 0x07);
  EXPECT_EQ(co::controlword::enable_operation, 0x0F);
  EXPECT_EQ(co::controlword::disable_voltage, 0x00);
  EXPECT_EQ(co::controlword::quick_stop, 0x02);
  EXPECT_EQ(co::control_bit::halt, 0x100);
  EXPECT_EQ(co::decode_controlword(0, 0x06), Command::shutdown);
  EXPECT_EQ(co::decode_controlword(0, 0x0E), Command::shutdown);  // x110
  EXPECT_EQ(co::decode_controlword(0, 0x07), Command::switch_on);
  EXPECT_EQ(co::decode_controlword(0, 0x0F), Command::enable_operation);
  EXPECT_EQ(co::decode_controlword(0, 0x10F), Command::enable_operation);  // halt does not change the command
  EXPECT_EQ(co::decode_controlword(0, 0x00), Command::disable_voltage);
  EXPECT_EQ(co::decode_controlword(0, 0x0D), Command::disable_voltage);  // xx0x
  EXPECT_EQ(co::decode_controlword(0, 0x02), Command::quick_stop);
  EXPECT_EQ(co::decode_controlword(0, 0x0B), Command::quick_stop);  // x01x
  // Fault reset is the 0 -> 1 edge of bit 7, not the level.
  EXPECT_EQ(co::decode_controlword(0x00, 0x80), Command::fault_reset);
  EXPECT_EQ(co::decode_controlword(0x0F, 0x8F), Command::fault_reset);
  EXPECT_EQ(co::decode_controlword(0x80, 0x80), Command::disable_voltage);
}

TEST(Canopen402Transitions, EveryNumberedTransition) {
  using S = DriveState;
  EXPECT_EQ(co::next_state(S::switch_on_disabled, Command::shutdown), S::ready_to_switch_on);         // 2
  EXPECT_EQ(co::next_state(S::ready_to_switch_on, Command::switch_on), S::switched_on);               // 3
  EXPECT_EQ(co::next_state(S::switched_on, Command::enable_operation), S::operation_enabled);         // 4
  EXPECT_EQ(co::next_state(S::operation_enabled, Command::switch_on), S::switched_on);                // 5
  EXPECT_EQ(co::next_state(S::switched_on, Command::shutdown), S::ready_to_switch_on);                // 6
  EXPECT_EQ(co::next_state(S::ready_to_switch_on, Command::disable_voltage), S::switch_on_disabled);  // 7
  EXPECT_EQ(co::next_state(S::ready_to_switch_on, Command::quick_stop), S::switch_on_disabled);       // 7
  EXPECT_EQ(co::next_state(S::operation_enabled, Command::shutdown), S::ready_to_switch_on);          // 8
  EXPECT_EQ(co::next_state(S::operation_enabled, Command::disable_voltage), S::switch_on_disabled);   // 9
  EXPECT_EQ(co::next_state(S::switched_on, Command::disable_voltage), S::switch_on_disabled);         // 10
  EXPECT_EQ(co::next_state(S::switched_on, Command::quick_stop), S::switch_on_disabled);              // 10
  EXPECT_EQ(co::next_state(S::operation_enabled, Command::quick_stop), S::quick_stop_active);         // 11
  EXPECT_EQ(co::next_state(S::quick_stop_active, Command::disable_voltage), S::switch_on_disabled);   // 12
  EXPECT_EQ(co::next_state(S::fault, Command::fault_reset), S::switch_on_disabled);                   // 15
  EXPECT_EQ(co::next_state(S::quick_stop_active, Command::enable_operation), S::operation_enabled);   // 16
  EXPECT_EQ(co::next_state(S::ready_to_switch_on, Command::enable_operation), S::operation_enabled);  // 3 + 4
  EXPECT_EQ(co::on_fault(S::operation_enabled), S::fault_reaction_active);                            // 13
  EXPECT_EQ(co::on_fault(S::fault), S::fault);
  // No transition: the state stays.
  EXPECT_EQ(co::next_state(S::switch_on_disabled, Command::enable_operation), S::switch_on_disabled);
  EXPECT_EQ(co::next_state(S::fault, Command::shutdown), S::fault);
  EXPECT_EQ(co::next_state(S::fault_reaction_active, Command::fault_reset), S::fault_reaction_active);
  EXPECT_TRUE(co::power_stage_on(S::operation_enabled));
  EXPECT_FALSE(co::power_stage_on(S::switched_on));
}

TEST(Canopen402Master, EnableSequenceFromEachState) {
  using S = DriveState;
  EXPECT_EQ(co::controlword_towards_enabled(S::switch_on_disabled, 0x00), 0x06);
  EXPECT_EQ(co::controlword_towards_enabled(S::ready_to_switch_on, 0x06), 0x07);
  EXPECT_EQ(co::controlword_towards_enabled(S::switched_on, 0x07), 0x0F);
  EXPECT_EQ(co::controlword_towards_enabled(S::operation_enabled, 0x0F), 0x0F);
  EXPECT_EQ(co::controlword_towards_enabled(S::quick_stop_active, 0x02), 0x00);
  EXPECT_EQ(co::controlword_towards_enabled(S::fault_reaction_active, 0x0F), 0x00);
  // Fault reset over two cycles: bit 7 low, then high; high again only after a low.
  EXPECT_EQ(co::controlword_towards_enabled(S::fault, 0x80), 0x00);
  EXPECT_EQ(co::controlword_towards_enabled(S::fault, 0x00), 0x80);
}

TEST(Canopen402Master, SequenceDrivesTheDriveStateMachineToEnabled) {
  // The master's controlwords, fed to the drive's transitions, reach
  // Operation Enabled from Fault in 4 cycles: the reset edge (bit 7 was low
  // in the last 0x0F), 0x06, 0x07, 0x0F.
  DriveState drive = DriveState::fault;
  std::uint16_t last = 0x0F;
  int cycles = 0;
  const std::uint16_t expected[] = {0x80, 0x06, 0x07, 0x0F};
  for (; cycles < 10 && drive != DriveState::operation_enabled; ++cycles) {
    const std::uint16_t cw = co::controlword_towards_enabled(drive, last);
    if (cycles < 4) {
      EXPECT_EQ(cw, expected[cycles]) << cycles;
    }
    drive = co::next_state(drive, co::decode_controlword(last, cw));
    last = cw;
  }
  EXPECT_EQ(drive, DriveState::operation_enabled);
  EXPECT_EQ(cycles, 4);
}

TEST(Canopen402Objects, ModesAndDescriptions) {
  EXPECT_EQ(static_cast<int>(co::Mode::cyclic_synchronous_torque), 10);
  EXPECT_EQ(co::supported_mode_bit(co::Mode::cyclic_synchronous_torque), 9U);
  EXPECT_EQ(co::describe_mode(10), "cyclic synchronous torque");
  EXPECT_EQ(co::describe_mode(-1), "manufacturer-specific mode");
  const auto target = co::find_standard_object({co::object::target_torque, 0});
  ASSERT_TRUE(target);
  EXPECT_EQ(target->type, hapticd::drivers::canopen::cia301::DataType::integer16);
  EXPECT_EQ(target->mappable, hapticd::drivers::canopen::cia301::Mappable::rpdo);
  EXPECT_EQ(co::find_standard_object({0x6064, 0})->mappable,
            hapticd::drivers::canopen::cia301::Mappable::tpdo);
  EXPECT_EQ(co::find_standard_object({0x6060, 0})->type,
            hapticd::drivers::canopen::cia301::DataType::integer8);
  EXPECT_EQ(co::find_standard_object({0x6076, 0})->type,
            hapticd::drivers::canopen::cia301::DataType::unsigned32);
  EXPECT_EQ(co::find_standard_object({0x6007, 0})->type,
            hapticd::drivers::canopen::cia301::DataType::integer16);
  EXPECT_EQ(co::find_standard_object({0x60C2, 2})->type,
            hapticd::drivers::canopen::cia301::DataType::integer8);
  EXPECT_EQ(co::find_standard_object({0x1017, 0})->name, "producer heartbeat time (ms)");
  EXPECT_FALSE(co::find_standard_object({0x6041, 1}));
}

TEST(Canopen402Objects, InterpolationPeriod) {
  using P = co::InterpolationPeriod;
  EXPECT_EQ(co::encode_interpolation_period(1e-3), (P{1, -3}));
  EXPECT_EQ(co::encode_interpolation_period(250e-6), (P{25, -5}));
  EXPECT_EQ(co::encode_interpolation_period(100e-6), (P{1, -4}));
  EXPECT_EQ(co::encode_interpolation_period(2e-3), (P{2, -3}));
  EXPECT_EQ(co::encode_interpolation_period(10e-3), (P{1, -2}));
  EXPECT_EQ(co::encode_interpolation_period(125e-6), (P{125, -6}));
  EXPECT_FALSE(co::encode_interpolation_period(333.3e-6));
  EXPECT_FALSE(co::encode_interpolation_period(0.0));
  EXPECT_DOUBLE_EQ(co::decode_interpolation_period({25, -5}), 250e-6);
}

TEST(Canopen402Errors, CodesInWords) {
  EXPECT_EQ(co::describe_error_code(0x2310), "continuous over current (motor side)");
  EXPECT_EQ(co::describe_error_code(0x3210), "DC link over-voltage");
  EXPECT_EQ(co::describe_error_code(0x4310), "excess drive temperature");
  EXPECT_EQ(co::describe_error_code(0x7305), "incremental sensor 1 fault");
  EXPECT_EQ(co::describe_error_code(0x8611), "following error");
  EXPECT_EQ(co::describe_error_code(0x8130), "life guard or heartbeat error");
  EXPECT_EQ(co::describe_error_code(0x2399), "current: code 0x2399 not defined by CiA 301/402");
  EXPECT_EQ(co::describe_error_code(0x81AB), "communication: code 0x81AB not defined by CiA 301/402");
  hapticd::drivers::canopen::cia301::Emergency e;
  e.error_code = 0x2310;
  e.error_register = 0x03;
  e.manufacturer = {0, 0, 0, 0x12, 0xAB};
  EXPECT_EQ(co::describe_emergency(e),
            "EMCY 0x2310: continuous over current (motor side); error register 0x03 (generic, current); "
            "manufacturer bytes 00 00 00 12 AB");
}

}  // namespace codec_402_test
