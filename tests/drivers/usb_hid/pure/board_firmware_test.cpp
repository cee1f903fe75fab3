// The board's obligations (README.md "What the board's firmware must do"):
// the dead-man fed only by new sequence numbers, output off unless enabled
// and healthy, latched faults and trips cleared by a reset report.

#include <gtest/gtest.h>

#include <array>
#include <cstdint>

#include "sim/usb_hid/board_firmware.hpp"

namespace hapticd::drivers::usb_hid::sim {
namespace {

std::array<std::uint8_t, 8> out_report(std::uint32_t seq, std::int64_t command, bool enable,
                                       std::uint32_t deadman_us = 3000, bool reset = false) {
  OutReport r;
  r.sequence = seq;
  r.command = command;
  r.enable = enable;
  r.reset = reset;
  r.deadman_us = deadman_us;
  std::array<std::uint8_t, 8> bytes{};
  encode_out(r, OutLayout{}, bytes);
  return bytes;
}

InReport in_report(BoardFirmware& fw, std::int64_t counts = 0) {
  std::array<std::uint8_t, 16> bytes{};
  EXPECT_EQ(fw.make_in_report(counts, bytes), 16U);
  InReport r;
  decode_in(bytes, InLayout{}, r);
  return r;
}

TEST(BoardFirmware, AppliesNewReportsOnlyWhenEnabled) {
  BoardFirmware fw{ReportLayout{}};
  EXPECT_TRUE(fw.on_out_report(out_report(1, 500, false), 0));
  EXPECT_EQ(fw.output(), 0);
  EXPECT_TRUE(fw.on_out_report(out_report(2, 500, true), 1000));
  EXPECT_EQ(fw.output(), 500);
  const InReport r = in_report(fw, -7);
  EXPECT_EQ(r.sequence, 1U);
  EXPECT_EQ(r.ack, 2U);
  EXPECT_EQ(r.position_counts, -7);
  EXPECT_TRUE(r.enabled);
  EXPECT_EQ(in_report(fw).sequence, 2U);
}

TEST(BoardFirmware, DeadManTripsWhenNoNewSequenceArrives) {
  BoardFirmware fw{ReportLayout{}};
  fw.on_out_report(out_report(1, 500, true, 3000), 0);
  fw.on_tick(3000);
  EXPECT_EQ(fw.output(), 500) << "at the deadline, not past it";
  // The same report again (a stuck host or a replayed buffer) must not feed it.
  EXPECT_FALSE(fw.on_out_report(out_report(1, 500, true, 3000), 2500));
  EXPECT_EQ(fw.counters().repeated_reports, 1U);
  fw.on_tick(3001);
  EXPECT_TRUE(fw.watchdog_tripped());
  EXPECT_EQ(fw.output(), 0);
  const InReport r = in_report(fw);
  EXPECT_TRUE(r.watchdog);
  EXPECT_FALSE(r.enabled);
  EXPECT_EQ(r.fault_code, static_cast<std::uint32_t>(BoardFaultCode::watchdog));
  // New reports alone do not re-arm the output: the trip is latched.
  fw.on_out_report(out_report(2, 500, true), 4000);
  EXPECT_EQ(fw.output(), 0);
  fw.on_out_report(out_report(3, 500, true, 3000, true), 5000);
  EXPECT_FALSE(fw.watchdog_tripped());
  EXPECT_EQ(fw.output(), 500);
  EXPECT_EQ(fw.counters().resets, 1U);
}

TEST(BoardFirmware, NoTripWhileOff) {
  BoardFirmware fw{ReportLayout{}};
  fw.on_out_report(out_report(1, 0, false, 1000), 0);
  fw.on_tick(1'000'000);
  EXPECT_FALSE(fw.watchdog_tripped());
}

TEST(BoardFirmware, ZeroDeadManMeansTheBoardsDefault) {
  BoardFirmware fw{ReportLayout{}};
  fw.on_out_report(out_report(1, 5, true, 0), 0);
  fw.on_tick(default_deadman_us);
  EXPECT_FALSE(fw.watchdog_tripped());
  fw.on_tick(default_deadman_us + 1);
  EXPECT_TRUE(fw.watchdog_tripped());
}

TEST(BoardFirmware, FaultClearsOnlyWhenTheCauseIsGone) {
  BoardFirmware fw{ReportLayout{}};
  fw.on_out_report(out_report(1, 500, true), 0);
  fw.raise_fault(BoardFaultCode::over_current);
  EXPECT_EQ(fw.output(), 0);
  InReport r = in_report(fw);
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
  BoardFirmware fw{ReportLayout{}};
  const std::array<std::uint8_t, 7> short_report{1, 0, 0x10, 0, 1, 0, 0};
  EXPECT_FALSE(fw.on_out_report(short_report, 0));
  EXPECT_EQ(fw.counters().bad_reports, 1U);
  EXPECT_EQ(fw.output(), 0);
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid::sim
