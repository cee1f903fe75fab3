// The host side of the protocol period by period: new, held, stale and
// missed IN reports, timeouts, status bits, transfer outcomes, the OUT
// sequence (continued from the board's ack) and the fault reset handshake.

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

#include "drivers/usb_hid/host_session.hpp"

namespace hapticd::drivers::usb_hid::host_session_test {
namespace {

constexpr std::uint8_t in_ep = 0x81;

class Session : public ::testing::Test {
 protected:
  Session() : session(layout, limits()) {}
  static SessionLimits limits() {
    SessionLimits l;
    l.timeout_periods = 3;
    l.period_s = 1e-3;
    return l;
  }
  /// Delivers one IN report from the board.
  void board_sends(const InReport& r) {
    std::array<std::uint8_t, 16> bytes{};
    encode_in(r, layout.in, bytes);
    session.on_in(TransferOutcome::completed, bytes, in_ep);
  }
  InReport report(std::uint32_t sequence, std::int64_t position = 0, std::uint32_t ack = 0) {
    InReport r;
    r.sequence = sequence;
    r.position_counts[0] = position;
    r.ack = ack;
    r.enabled = true;
    return r;
  }
  IoResult period(InReport& out) { return session.end_read(out); }
  OutReport send(std::int64_t command = 100, bool enable = true) {
    std::array<std::uint8_t, 8> bytes{};
    EXPECT_EQ(session.make_out(command, enable, 3000, bytes), 8U);
    OutReport out;
    decode_out(bytes, layout.out, out);
    return out;
  }

  ReportLayout layout;
  HostSession session;
  InReport latest;
};

TEST_F(Session, NothingYetIsAnError) { EXPECT_EQ(period(latest), IoResult::error); }

TEST_F(Session, NewReportsThenHeldThenTimeout) {
  board_sends(report(7, 100));
  EXPECT_EQ(period(latest), IoResult::ok);
  EXPECT_EQ(latest.position_counts[0], 100);
  board_sends(report(8, 101));
  EXPECT_EQ(period(latest), IoResult::ok);
  EXPECT_EQ(latest.position_counts[0], 101);
  // A period without a report holds the last position (a full-speed board
  // polled every 1 ms drifts against a 1 ms loop: some periods get none).
  EXPECT_EQ(period(latest), IoResult::ok);
  EXPECT_EQ(latest.position_counts[0], 101);
  EXPECT_EQ(period(latest), IoResult::ok);
  EXPECT_EQ(session.counters().held_periods, 2U);
  EXPECT_EQ(period(latest), IoResult::fault) << "third period without a report";
  EXPECT_EQ(session.fault().reason, LinkFault::in_timeout);
  EXPECT_EQ(session.fault().detail, 3U);
  EXPECT_EQ(session.describe(session.fault()), "no IN report from the board for 3 periods (3 ms)");
  board_sends(report(9, 102));
  EXPECT_EQ(period(latest), IoResult::fault) << "latched until reset";
}

TEST_F(Session, RepeatedSequenceIsStaleAndLatchesWithTheNumber) {
  board_sends(report(41));
  EXPECT_EQ(period(latest), IoResult::ok);
  for (int i = 0; i < 2; ++i) {
    board_sends(report(41));
    EXPECT_EQ(period(latest), IoResult::ok);
  }
  board_sends(report(40));  // older still
  EXPECT_EQ(period(latest), IoResult::fault);
  EXPECT_EQ(session.fault().reason, LinkFault::stale_sequence);
  EXPECT_EQ(session.fault().detail, 40U);
  EXPECT_EQ(session.counters().stale_reports, 3U);
  EXPECT_EQ(session.describe(session.fault()),
            "the board repeats IN report sequence 40 for 3 periods (3 ms) (its firmware stopped updating)");
}

TEST_F(Session, GapsAreCountedNewestWins) {
  board_sends(report(1, 10));
  board_sends(report(4, 40));
  board_sends(report(5, 50));
  EXPECT_EQ(period(latest), IoResult::ok);
  EXPECT_EQ(latest.position_counts[0], 50);
  EXPECT_EQ(session.counters().missed_reports, 2U);
  EXPECT_EQ(session.counters().in_reports, 3U);
}

TEST_F(Session, SequenceWrapsAround) {
  board_sends(report(65535, 1));
  EXPECT_EQ(period(latest), IoResult::ok);
  board_sends(report(0, 2));
  EXPECT_EQ(period(latest), IoResult::ok);
  EXPECT_EQ(latest.position_counts[0], 2);
  EXPECT_EQ(session.counters().stale_reports, 0U);
}

TEST_F(Session, ShortReportAloneIsAnErrorThatPeriod) {
  board_sends(report(1));
  EXPECT_EQ(period(latest), IoResult::ok);
  const std::array<std::uint8_t, 5> short_bytes{};
  session.on_in(TransferOutcome::completed, short_bytes, in_ep);
  EXPECT_EQ(period(latest), IoResult::error);
  EXPECT_EQ(session.counters().short_reports, 1U);
  session.on_in(TransferOutcome::error, {}, in_ep);
  EXPECT_EQ(period(latest), IoResult::error);
  EXPECT_EQ(session.counters().transfer_errors, 1U);
  board_sends(report(2));
  session.on_in(TransferOutcome::overflow, {}, in_ep);
  EXPECT_EQ(period(latest), IoResult::ok) << "a good report in the same period wins";
}

TEST_F(Session, StatusBitsLatchWithTheBoardsReason) {
  InReport r = report(1);
  r.fault = true;
  r.fault_code = 1;
  board_sends(r);
  EXPECT_EQ(period(latest), IoResult::fault);
  EXPECT_EQ(session.fault().reason, LinkFault::board_fault);
  EXPECT_EQ(session.describe(session.fault()), "board fault: over-current (code 0x01)");
}

TEST_F(Session, WatchdogBitLatches) {
  InReport r = report(1);
  r.watchdog = true;
  board_sends(r);
  EXPECT_EQ(period(latest), IoResult::fault);
  EXPECT_EQ(session.fault().reason, LinkFault::board_watchdog);
  EXPECT_NE(session.describe(session.fault()).find("dead-man"), std::string::npos);
}

TEST_F(Session, UnplugAndStallLatch) {
  board_sends(report(1));
  session.on_in(TransferOutcome::no_device, {}, in_ep);
  EXPECT_EQ(period(latest), IoResult::fault);
  EXPECT_EQ(session.describe(session.fault()), "USB board unplugged (LIBUSB_ERROR_NO_DEVICE)");
  HostSession other(layout, limits());
  other.on_out(TransferOutcome::stall, 0x01);
  EXPECT_EQ(other.fault().reason, LinkFault::stalled);
  EXPECT_EQ(other.describe(other.fault()), "endpoint 0x01 stalled (halt feature set by the board)");
}

TEST_F(Session, OutSequenceContinuesFromTheBoardsAck) {
  board_sends(report(1, 0, 4711));  // the board last applied OUT 4711 (a previous host)
  EXPECT_EQ(period(latest), IoResult::ok);
  const OutReport first = send(123);
  EXPECT_EQ(first.sequence, 4712U);
  EXPECT_EQ(first.command[0], 123);
  EXPECT_TRUE(first.enable);
  EXPECT_FALSE(first.reset);
  EXPECT_EQ(first.deadman_us, 3000U);
  EXPECT_EQ(send().sequence, 4713U);
}

TEST_F(Session, AckLagLatches) {
  board_sends(report(1, 0, 0));
  EXPECT_EQ(period(latest), IoResult::ok);
  for (int i = 0; i < 4; ++i) send();  // the board applies none of them
  board_sends(report(2, 0, 0));
  EXPECT_EQ(period(latest), IoResult::fault);
  EXPECT_EQ(session.fault().reason, LinkFault::out_not_applied);
  EXPECT_EQ(session.fault().detail, 4U);
}

TEST_F(Session, FaultedSessionSendsOutputOff) {
  board_sends(report(1));
  session.latch(LinkFault::in_timeout, 3);
  const OutReport out = send(500);
  EXPECT_FALSE(out.enable);
  EXPECT_EQ(out.command[0], 0);
}

TEST_F(Session, ResetIsDecidedByTheFirstReportAfterTheBoardSawIt) {
  InReport r = report(1, 0, 0);
  r.fault = true;
  r.fault_code = 2;
  board_sends(r);
  EXPECT_EQ(period(latest), IoResult::fault);
  const LatchedFault cleared = session.begin_reset();
  EXPECT_EQ(cleared.reason, LinkFault::board_fault);
  EXPECT_FALSE(session.reset_done());
  const OutReport reset = send(300);
  EXPECT_TRUE(reset.reset);
  EXPECT_FALSE(reset.enable) << "output stays off until the reset is decided";
  EXPECT_EQ(reset.command[0], 0);
  // A report the board sent before it saw the reset still has the fault: not held against it.
  r.sequence = 2;
  board_sends(r);
  EXPECT_EQ(period(latest), IoResult::ok);
  EXPECT_FALSE(session.reset_done());
  // The board applied the reset report (ack = its sequence) and is clean.
  InReport clean = report(3, 0, reset.sequence);
  board_sends(clean);
  EXPECT_EQ(period(latest), IoResult::ok);
  EXPECT_TRUE(session.reset_done());
  EXPECT_TRUE(send(300).enable);
}

TEST_F(Session, ResetThatDoesNotTakeLatchesAgain) {
  InReport r = report(1, 0, 0);
  r.fault = true;
  r.fault_code = 1;
  board_sends(r);
  period(latest);
  session.begin_reset();
  const OutReport reset = send();
  r.sequence = 2;
  r.ack = reset.sequence;  // saw the reset, still over-current
  board_sends(r);
  EXPECT_EQ(period(latest), IoResult::fault);
  EXPECT_TRUE(session.reset_done());
  EXPECT_EQ(session.fault().reason, LinkFault::board_fault);
  EXPECT_EQ(session.fault().detail, 1U);
}

TEST_F(Session, RestartResyncsToTheNewBoard) {
  board_sends(report(100, 5, 900));
  period(latest);
  send();
  session.restart();  // re-plugged: a fresh board counts from 0
  EXPECT_EQ(period(latest), IoResult::error) << "no position until the new board reports";
  board_sends(report(1, 6, 0));
  EXPECT_EQ(period(latest), IoResult::ok);
  EXPECT_EQ(latest.position_counts[0], 6);
  EXPECT_EQ(send().sequence, 1U);
  EXPECT_EQ(session.counters().stale_reports, 0U);
}

TEST(SessionNoAck, ResetDecidedAfterTimeoutReports) {
  ReportLayout layout;
  layout.in.ack = IntegerField{};
  SessionLimits limits;
  limits.timeout_periods = 2;
  HostSession session(layout, limits);
  auto send_in = [&](std::uint32_t seq, bool fault) {
    InReport r;
    r.sequence = seq;
    r.fault = fault;
    std::array<std::uint8_t, 16> bytes{};
    encode_in(r, layout.in, bytes);
    session.on_in(TransferOutcome::completed, bytes, 0x81);
    InReport latest;
    return session.end_read(latest);
  };
  EXPECT_EQ(send_in(1, true), IoResult::fault);
  session.begin_reset();
  EXPECT_EQ(send_in(2, true), IoResult::ok) << "first report after the reset: maybe sent before it";
  EXPECT_FALSE(session.reset_done());
  EXPECT_EQ(send_in(3, false), IoResult::ok);
  EXPECT_TRUE(session.reset_done());
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid::host_session_test
