// UsbTransport against the emulated board: libusb's real Linux code path
// (enumeration from sysfs, open, auto-detach + claim, async interrupt URBs,
// reap, cancel, release) answered by the umockdev ioctl handler.

#include <gtest/gtest.h>

#include <vector>

#include "drivers/usb_hid/host_session.hpp"
#include "drivers/usb_hid/usb_transport.hpp"
#include "emulated_board_fixture.hpp"

namespace hapticd::drivers::usb_hid {
namespace {

using testing::EmulatedBoardTest;

UsbSelector sim_board() {
  UsbSelector s;
  s.vendor_id = 0x1209;
  s.product_id = 0x0001;
  return s;
}

TEST_F(EmulatedBoardTest, OpensClaimsAndDescribesTheBoard) {
  UsbTransport transport(TransportOptions{}, 0x1209, 0x0001);
  const OpenedBoard opened = transport.open(sim_board());
  EXPECT_EQ(opened.path, "1-2");
  EXPECT_EQ(opened.serial, "SIM0001");
  EXPECT_TRUE(opened.detached_kernel_driver);
  EXPECT_EQ(opened.in.address, 0x81);
  EXPECT_EQ(opened.out.address, 0x01);
  EXPECT_EQ(opened.in.max_packet_size, 64);
  EXPECT_EQ(opened.in.b_interval, 1);
  EXPECT_EQ(opened.in.speed, UsbSpeed::full);
  EXPECT_EQ(opened.description, "1209:0001 serial SIM0001 at 1-2, full speed (12 Mbit/s)");
  auto c = testbed->counters();
  EXPECT_TRUE(c.claimed);
  EXPECT_FALSE(c.kernel_driver_bound);
  EXPECT_EQ(c.kernel_driver_detaches, 1U);
  transport.close();
  c = testbed->counters();
  EXPECT_FALSE(c.claimed);
  EXPECT_TRUE(c.kernel_driver_bound) << "libusb re-attaches the kernel driver it detached";
  EXPECT_EQ(c.kernel_driver_attaches, 1U);
}

TEST_F(EmulatedBoardTest, ExchangesTwoHundredReportsInEachDirection) {
  TransportOptions options;
  UsbTransport transport(options, 0x1209, 0x0001);
  transport.open(sim_board());
  transport.start();
  ASSERT_TRUE(transport.wait_for_in(2.0));
  HostSession session(ReportLayout{}, SessionLimits{});
  std::uint8_t out[max_report_size];
  int periods_ok = 0;
  for (int period = 0; period < 200; ++period) {
    transport.poll();
    InCompletion in;
    while (transport.pop_in(in)) session.on_in(in.outcome, {in.bytes, in.length}, 0x81);
    InReport latest;
    if (session.end_read(latest) == IoResult::ok) ++periods_ok;
    const std::size_t n = session.make_out(1000, true, 3000, out);
    ASSERT_EQ(transport.submit_out({out, n}), SubmitResult::queued) << period;
  }
  transport.poll();
  InCompletion last;
  while (transport.pop_in(last)) session.on_in(last.outcome, {last.bytes, last.length}, 0x81);
  EXPECT_EQ(periods_ok, 200);
  const auto snapshot = board->snapshot();
  EXPECT_EQ(snapshot.firmware.out_reports, 200U);
  EXPECT_EQ(snapshot.steps, 200U);
  EXPECT_EQ(session.counters().in_reports, 201U);  // the power-on report plus one per OUT
  EXPECT_EQ(session.counters().stale_reports, 0U);
  EXPECT_EQ(session.counters().missed_reports, 0U);
  transport.stop();
  transport.close();
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid
