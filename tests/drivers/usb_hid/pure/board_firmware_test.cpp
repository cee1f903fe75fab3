// The board's obligations (README.md "What the board's firmware must do"):
// the dead-man fed only by new sequence numbers, output off unless enabled
// and healthy, latched faults and trips cleared by a reset report.

#include <gtest/gtest.h>

#include <array>
#include <cstdint>

#include "drivers/usb_hid/report_codec.hpp"
#include "sim/usb_hid/board_firmware.hpp"

namespace hapticd::drivers::usb_hid::sim::board_firmware_test {
namespace {

// OUT reports written byte by byte from the README's table, and IN reports
// read the same way: the firmware is checked against the protocol note,
// not against either side's codec.
std::array<std::uint8_t, 8> out_report(std::uint16_t seq, std::int16_t command, bool enable,
                                       std::uint16_t deadman_us = 3000, bool reset = false) {
  const auto c = static_cast<std::uint16_t>(command);
  return {static_cast<std::uint8_t>(seq & 0xFFU),
          static_cast<std::uint8_t>(seq >> 8U),
          static_cast<std::uint8_t>(c & 0xFFU),
          static_cast<std::uint8_t>(c >> 8U),
          static_cast<std::uint8_t>((enable ? 1U : 0U) | (reset ? 2U : 0U)),
          0,
          static_cast<std::uint8_t>(deadman_us & 0xFFU),
          static_cast<std::uint8_t>(deadman_us >> 8U)};
}

struct InFields {
  std::uint32_t sequence = 0, ack = 0;
  std::int64_t position_counts = 0;
  bool enabled = false, fault = false, watchdog = false;
  std::uint32_t fault_code = 0;
};

InFields in_report(BoardFirmware& fw, std::int64_t counts = 0) {
  std::array<std::uint8_t, 16> b{};
  EXPECT_EQ(fw.make_in_report(counts, b), 16U);
  for (std::size_t i = 10; i < 16; ++i) EXPECT_EQ(b[i], 0) << "reserved byte " << i;
  InFields r;
  r.sequence = b[0] | b[1] << 8U;
  r.ack = b[2] | b[3] << 8U;
  r.position_counts = static_cast<std::int32_t>(static_cast<std::uint32_t>(b[4]) | b[5] << 8U | b[6] << 16U |
                                                static_cast<std::uint32_t>(b[7]) << 24U);
  r.enabled = (b[8] & 1U) != 0;
  r.fault = (b[8] & 2U) != 0;
  r.watchdog = (b[8] & 4U) != 0;
  r.fault_code = b[9];
  return r;
}

TEST(BoardFirmware, AppliesNewReportsOnlyWhenEnabled) {
  BoardFirmware fw;
  EXPECT_TRUE(fw.on_out_report(out_report(1, 500, false), 0));
  EXPECT_EQ(fw.output(), 0);
  EXPECT_TRUE(fw.on_out_report(out_report(2, 500, true), 1000));
  EXPECT_EQ(fw.output(), 500);
  const InFields r = in_report(fw, -7);
  EXPECT_EQ(r.sequence, 1U);
  EXPECT_EQ(r.ack, 2U);
  EXPECT_EQ(r.position_counts, -7);
  EXPECT_TRUE(r.enabled);
  EXPECT_EQ(in_report(fw).sequence, 2U);
}

TEST(BoardFirmware, DeadManTripsWhenNoNewSequenceArrives) {
  BoardFirmware fw;
  fw.on_out_report(out_report(1, 500, true, 3000), 0);
  fw.on_tick(3000);
  EXPECT_EQ(fw.output(), 500) << "at the deadline, not past it";
  // The same report again (a stuck host or a replayed buffer) must not feed it.
  EXPECT_FALSE(fw.on_out_report(out_report(1, 500, true, 3000), 2500));
  EXPECT_EQ(fw.counters().repeated_reports, 1U);
  fw.on_tick(3001);
  EXPECT_TRUE(fw.watchdog_tripped());
  EXPECT_EQ(fw.output(), 0);
  const InFields r = in_report(fw);
  EXPECT_TRUE(r.watchdog);
  EXPECT_FALSE(r.enabled);
  EXPECT_EQ(r.fault_code, 6U);
  // New reports alone do not re-arm the output: the trip is latched.
  fw.on_out_report(out_report(2, 500, true), 4000);
  EXPECT_EQ(fw.output(), 0);
  fw.on_out_report(out_report(3, 500, true, 3000, true), 5000);
  EXPECT_FALSE(fw.watchdog_tripped());
  EXPECT_EQ(fw.output(), 500);
  EXPECT_EQ(fw.counters().resets, 1U);
}

TEST(BoardFirmware, NoTripWhileOff) {
  BoardFirmware fw;
  fw.on_out_report(out_report(1, 0, false, 1000), 0);
  fw.on_tick(1'000'000);
  EXPECT_FALSE(fw.watchdog_tripped());
}

TEST(BoardFirmware, ZeroDeadManMeansTheBoardsDefault) {
  BoardFirmware fw;
  fw.on_out_report(out_report(1, 5, true, 0), 0);
  fw.on_tick(default_deadman_us);
  EXPECT_FALSE(fw.watchdog_tripped());
  fw.on_tick(default_deadman_us + 1);
  EXPECT_TRUE(fw.watchdog_tripped());
}

TEST(BoardFirmware, FaultClearsOnlyWhenTheCauseIsGone) {
  BoardFirmware fw;
  fw.on_out_report(out_report(1, 500, true), 0);
  fw.raise_fault(FaultCode::over_current);
  EXPECT_EQ(fw.output(), 0);
  InFields r = in_report(fw);
  EXPECT_TRUE(r.fault);
  EXPECT_EQ(r.fault_code, 1U);
  fw.on_out_report(out_report(2, 500, true, 3000, true), 100);
  EXPECT_EQ(fw.fault_code(), 1U) << "still over-current";
  fw.clear_cause();
  fw.on_out_report(out_report(3, 500, true, 3000, true), 200);
  EXPECT_EQ(fw.fault_code(), 0U);
  EXPECT_EQ(fw.output(), 500);
}

TEST(BoardFirmware, IgnoresShortReports) {
  BoardFirmware fw;
  const std::array<std::uint8_t, 7> short_report{1, 0, 0x10, 0, 1, 0, 0};
  EXPECT_FALSE(fw.on_out_report(short_report, 0));
  EXPECT_EQ(fw.counters().bad_reports, 1U);
  EXPECT_EQ(fw.output(), 0);
}

TEST(BoardFirmware, SequencesWrapAtSixteenBits) {
  BoardFirmware fw;
  fw.on_out_report(out_report(0xFFFF, 0, false), 0);
  EXPECT_EQ(in_report(fw).ack, 0xFFFFU);
  std::array<std::uint8_t, 16> scratch{};
  for (int i = 0; i < 0xFFFE; ++i) fw.make_in_report(0, scratch);
  EXPECT_EQ(in_report(fw).sequence, 0U) << "65536 reports later";
  EXPECT_EQ(in_report(fw, -(std::int64_t{1} << 31)).position_counts, -(std::int64_t{1} << 31));
}

// The two sides were written apart (the driver's configurable codec, the
// board's fixed reader from the README's table): on the default layout each
// reads what the other writes.
TEST(BoardReports, TheDriversCodecAndTheBoardsAgreeOnTheDefaultLayout) {
  OutReport sent;
  sent.sequence = 0xBEEF;
  sent.command[0] = -12345;
  sent.enable = true;
  sent.reset = true;
  sent.deadman_us = 3000;
  std::array<std::uint8_t, 8> out{};
  ASSERT_EQ(encode_out(sent, OutLayout{}, out), 8U);
  BoardCommand got;
  ASSERT_TRUE(read_out_report(out, got));
  EXPECT_EQ(got.sequence, 0xBEEF);
  EXPECT_EQ(got.command[0], -12345);
  EXPECT_TRUE(got.enable);
  EXPECT_TRUE(got.reset);
  EXPECT_EQ(got.deadman_us, 3000);

  BoardStatus status;
  status.sequence = 0x1234;
  status.ack = 0xBEEF;
  status.position[0] = -100000;
  status.enabled = false;
  status.fault = true;
  status.watchdog = true;
  status.fault_code = 7;
  std::array<std::uint8_t, 16> in{};
  ASSERT_EQ(write_in_report(status, in), 16U);
  InReport read;
  ASSERT_EQ(decode_in(in, InLayout{}, read), DecodeStatus::ok);
  EXPECT_EQ(read.sequence, 0x1234U);
  EXPECT_EQ(read.ack, 0xBEEFU);
  EXPECT_EQ(read.position_counts[0], -100000);
  EXPECT_FALSE(read.enabled);
  EXPECT_TRUE(read.fault);
  EXPECT_TRUE(read.watchdog);
  EXPECT_EQ(read.fault_code, 7U);
  EXPECT_EQ(fault_code_text(read.fault_code), "emergency-stop input");

  // Full scale both ways: +-32767 counts is +-full scale; -32768 saturates.
  EXPECT_DOUBLE_EQ(command_to_force(32767, 2.0), 2.0);
  EXPECT_DOUBLE_EQ(command_to_force(-32768, 2.0), -2.0);
  const IntegerField command = OutLayout{}.command[0];
  EXPECT_EQ(command_counts(2.0, 2.0, command), 32767);
  EXPECT_DOUBLE_EQ(command_to_force(static_cast<std::int16_t>(command_counts(-0.5, 2.0, command)), 2.0),
                   command_force(command_counts(-0.5, 2.0, command), 2.0, command));
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid::sim::board_firmware_test
