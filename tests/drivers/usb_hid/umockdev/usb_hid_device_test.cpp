// The usb-hid hooks (UsbHidDevice: the board's side of the lifecycle and the
// per-period exchange), called in the framework's order, against the
// emulated board through libusb: start-up checks, output on and off, faults
// with the board's reason, and fault clear while an RT-like thread keeps
// calling read()/write() (unplug + re-plug, a board fault, a tripped
// dead-man left by a previous host). The order itself is the framework's
// (tests/drivers/device_test.cpp).

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include "drivers/device.hpp"
#include "drivers/stop_request.hpp"
#include "drivers/usb_hid/usb_hid_device.hpp"
#include "emulated_board_fixture.hpp"
#include "tests/support/alloc_counter.hpp"

namespace hapticd::drivers::usb_hid::usb_hid_device_test {
namespace {

using testing::EmulatedBoardTest;

UsbHidConfig sim_config() {
  UsbHidConfig c;
  c.selector.vendor_id = 0x1209;
  c.selector.product_id = 0x0001;
  c.command_full_scale = 1.0;
  return c;
}

template <class Done>
bool within(double seconds, Done done) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!done()) {
    if (std::chrono::steady_clock::now() > give_up) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

/// The engine's part: read, then write, once per period on its own thread.
class RtLoop {
 public:
  RtLoop(DeviceHooks& link, double force) : link_(link), force_(force), thread_([this] { run(); }) {}
  ~RtLoop() {
    stop_.store(true);
    thread_.join();
  }
  std::uint64_t ok() const { return ok_.load(); }
  std::uint64_t faults() const { return faults_.load(); }
  /// The longest time between two periods' starts so far, in ms.
  double longest_gap_ms() const { return static_cast<double>(longest_gap_us_.load()) / 1e3; }

 private:
  void run() {
    auto last = std::chrono::steady_clock::now();
    while (!stop_.load()) {
      const auto now = std::chrono::steady_clock::now();
      const auto gap = std::chrono::duration_cast<std::chrono::microseconds>(now - last).count();
      longest_gap_us_.store(std::max<std::int64_t>(longest_gap_us_.load(), gap));
      last = now;
      Reading r;
      const IoResult read = link_.read(r);
      const IoResult write = link_.write(read == IoResult::ok ? force_ : 0.0);
      (read == IoResult::ok && write == IoResult::ok ? ok_ : faults_).fetch_add(1);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  DeviceHooks& link_;
  double force_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> ok_{0}, faults_{0};
  std::atomic<std::int64_t> longest_gap_us_{0};
  std::thread thread_;
};

TEST_F(EmulatedBoardTest, LifecycleOutputOnThenOff) {
  UsbHidDevice link(sim_config());
  link.configure({1e-3});
  Reading r;
  EXPECT_EQ(link.read(r), IoResult::ok);
  EXPECT_EQ(r.position, 0.0);
  EXPECT_EQ(link.write(0.5), IoResult::ok);
  EXPECT_FALSE(board->snapshot().output_on) << "not enabled yet: the OUT report has enable = 0";
  link.enable();
  for (int p = 0; p < 10; ++p) {
    ASSERT_EQ(link.read(r), IoResult::ok);
    ASSERT_EQ(link.write(0.5), IoResult::ok);
  }
  auto s = board->snapshot();
  EXPECT_TRUE(s.output_on);
  EXPECT_EQ(s.output_counts, 16384);  // 0.5 of full scale, rounded
  EXPECT_GT(r.position, 0.0);
  link.disable();
  s = board->snapshot();
  EXPECT_FALSE(s.output_on) << "disable sends a report with the output off";
  EXPECT_EQ(s.output_counts, 0);
  EXPECT_EQ(s.applied_force, 0.0);
  EXPECT_EQ(link.read(r), IoResult::ok) << "read() stays valid until close()";
  link.enable();  // again, as after a clear
  ASSERT_EQ(link.write(0.5), IoResult::ok);
  EXPECT_TRUE(board->snapshot().output_on);
  link.close();
  EXPECT_FALSE(testbed->counters().claimed);
  EXPECT_TRUE(testbed->counters().kernel_driver_bound);
}

// The order is the framework's (tests/drivers/device_test.cpp); here the
// board's hooks under it: refused calls never reach the board, and a close
// that never configured leaves the interface unclaimed.
TEST_F(EmulatedBoardTest, OutOfOrderCallsAreRefusedNotFatal) {
  Device device("usb-hid", std::make_unique<UsbHidDevice>(sim_config()));
  Reading r;
  EXPECT_EQ(device.read(r), IoResult::error);
  EXPECT_EQ(device.write(0.1), IoResult::error);
  EXPECT_THROW(device.enable(), std::logic_error);
  EXPECT_THROW(device.clear_fault(), std::logic_error);
  device.disable();
  device.close();
  device.configure({1e-3});
  EXPECT_THROW(device.configure({1e-3}), std::logic_error);
  device.close();
  device.close();
  EXPECT_EQ(device.read(r), IoResult::error) << "closed";
  EXPECT_FALSE(testbed->counters().claimed);
}

TEST_F(EmulatedBoardTest, TwoInTransfersAlwaysQueued) {
  UsbHidDevice link(sim_config());
  link.configure({1e-3});
  link.enable();
  Reading r;
  for (int p = 0; p < 50; ++p) {
    ASSERT_EQ(link.read(r), IoResult::ok);
    // read() reaped the report and resubmitted its transfer: both wait at
    // the board, so the host controller polls at every interval.
    EXPECT_EQ(testbed->counters().in_flight_in, 2U) << p;
    ASSERT_EQ(link.write(0.1), IoResult::ok);
    EXPECT_EQ(testbed->counters().in_flight_in, 1U) << "the board answered one with its new report";
  }
}

TEST_F(EmulatedBoardTest, PeriodTheEndpointCannotCarryIsRefused) {
  UsbHidDevice link(sim_config());
  try {
    link.configure({500e-6});
    FAIL() << "a 500 us period accepted on a full-speed board";
  } catch (const DeviceError& e) {
    EXPECT_STREQ(
        e.what(),
        "IN endpoint 0x81 is polled every 1 ms (full speed (12 Mbit/s), bInterval 1): a 500 us period "
        "needs one report per period; a full-speed board is polled at most every 1 ms (bInterval 1)");
  }
  EXPECT_FALSE(testbed->counters().claimed) << "released again";
}

TEST_F(EmulatedBoardTest, WrongBoardNamesTheKey) {
  UsbHidConfig c = sim_config();
  c.selector.serial = "LAB-7";
  UsbHidDevice link(c);
  try {
    link.configure({1e-3});
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.key(), "serial");
  }
}

TEST_F(EmulatedBoardTest, UnplugFaultsAndReplugResumesAfterFaultClear) {
  UsbHidDevice link(sim_config());
  link.configure({1e-3});
  link.enable();
  // The same period: the unplug is seen by the first read after it.
  Reading r;
  ASSERT_EQ(link.read(r), IoResult::ok);
  ASSERT_EQ(link.write(0.1), IoResult::ok);
  testbed->unplug();
  EXPECT_EQ(link.read(r), IoResult::fault);
  EXPECT_EQ(link.write(0.1), IoResult::fault);
  EXPECT_EQ(link.link_status().fault_text, "USB board unplugged (LIBUSB_ERROR_NO_DEVICE)");

  RtLoop rt(link, 0.1);
  try {
    link.clear_fault();
    FAIL() << "cleared with the board gone";
  } catch (const DeviceError& e) {
    EXPECT_NE(std::string(e.what()).find("is not on the bus: plug it in"), std::string::npos) << e.what();
  }
  testbed->replug();
  EXPECT_TRUE(within(5.0, [&] { return link.link_status().transport.hotplug_arrivals >= 1; }))
      << "the RT loop's event handling delivers the hotplug callback";
  EXPECT_EQ(link.clear_fault(), "USB board unplugged (LIBUSB_ERROR_NO_DEVICE)");
  const std::uint64_t ok_before = rt.ok();
  EXPECT_TRUE(within(5.0, [&] { return rt.ok() > ok_before + 20; }));
  const LinkStatus s = link.link_status();
  EXPECT_EQ(s.fault.reason, LinkFault::none);
  EXPECT_EQ(s.reopens, 1U);
  EXPECT_TRUE(board->snapshot().output_on) << "the fresh board runs again";
}

TEST_F(EmulatedBoardTest, BoardFaultClearsOnlyWhenTheCauseIsGone) {
  UsbHidDevice link(sim_config());
  link.configure({1e-3});
  link.enable();
  RtLoop rt(link, 0.1);
  ASSERT_TRUE(within(5.0, [&] { return rt.ok() > 5; }));
  board->raise_fault(sim::FaultCode::over_current, true);
  ASSERT_TRUE(within(5.0, [&] { return link.link_status().fault.reason == LinkFault::board_fault; }));
  EXPECT_EQ(link.link_status().fault_text, "board fault: over-current (code 0x01)");
  try {
    link.clear_fault();
    FAIL() << "cleared while the over-current is still there";
  } catch (const DeviceError& e) {
    EXPECT_STREQ(e.what(), "the board is still in fault: board fault: over-current (code 0x01)");
  }
  board->clear_cause();
  EXPECT_EQ(link.clear_fault(), "board fault: over-current (code 0x01)");
  const std::uint64_t ok_before = rt.ok();
  EXPECT_TRUE(within(5.0, [&] { return rt.ok() > ok_before + 5; }));
  EXPECT_TRUE(board->snapshot().output_on);
}

TEST_F(EmulatedBoardTest, DeadManLeftByAPreviousHostIsResetAtEnable) {
  {
    UsbHidDevice first(sim_config());
    first.configure({1e-3});
    first.enable();
    Reading r;
    for (int p = 0; p < 3; ++p) {
      first.read(r);
      first.write(0.2);
    }
    board->advance_time_us(10'000);  // the host went quiet with the output on
    EXPECT_TRUE(board->snapshot().watchdog_tripped);
    first.write(0.2);  // too late: the board reports the trip in its next IN report
    EXPECT_EQ(first.read(r), IoResult::fault);
    EXPECT_EQ(first.link_status().fault.reason, LinkFault::board_watchdog);
  }
  UsbHidDevice second(sim_config());
  try {
    second.configure({1e-3});
    second.enable();
  } catch (const DeviceError& e) {
    FAIL() << e.what();
  }
  EXPECT_FALSE(board->snapshot().watchdog_tripped);
  Reading r;
  EXPECT_EQ(second.read(r), IoResult::ok);
  EXPECT_EQ(second.write(0.2), IoResult::ok);
  EXPECT_TRUE(board->snapshot().output_on);
}

// Issue 17 item 9: enable's reset handshake with a tripped board runs up to
// 4 x timeout_periods periods (seconds with a long timeout); it gives way to
// the daemon's stop and leaves the output off.
TEST_F(EmulatedBoardTest, TheResetHandshakeAtEnableGivesWayToAStop) {
  {
    UsbHidDevice first(sim_config());
    first.configure({1e-3});
    first.enable();
    Reading r;
    first.read(r);
    first.write(0.2);
    board->advance_time_us(10'000);  // the host went quiet with the output on: the dead-man trips
    first.write(0.2);
    ASSERT_EQ(first.read(r), IoResult::fault);
  }
  StopRequest stop;
  UsbHidDevice second(sim_config());
  second.configure({1e-3, stop.token()});
  stop.request("the test");
  try {
    second.enable();
    FAIL() << "enabled";
  } catch (const StopRequested& e) {
    EXPECT_STREQ(e.what(),
                 "usb-hid: resetting the board's fault before enabling: abandoned, hapticd is stopping");
  }
  EXPECT_FALSE(second.link_status().enabled);
  EXPECT_FALSE(board->snapshot().output_on);
}

TEST_F(EmulatedBoardTest, HostThatGoesQuietIsStoppedByTheBoardsDeadMan) {
  // What SIGKILL of hapticd leaves: no disable(), no more OUT reports. The
  // board's own clock (wall time, frame ticks) trips the dead-man.
  make_board(sim::EmulatedUsbIdentity{}, sim::BoardClock::wall);
  sim::FrameTicker frames(*board);
  UsbHidConfig config = sim_config();
  // 60 ms, the most the default u16 out_deadman holds at 1 ms: sixty times
  // the period, so a loop that still trips it while running is a failure
  // with its figure, not a reason to skip.
  config.deadman_periods = 60;
  UsbHidDevice link(config);
  link.configure({1e-3});
  link.enable();
  {
    RtLoop rt(link, 0.3);
    ASSERT_TRUE(within(5.0, [&] { return rt.ok() > 20; }));
    ASSERT_FALSE(board->snapshot().watchdog_tripped)
        << "the dead-man tripped while the loop ran: its longest period was " << rt.longest_gap_ms()
        << " ms, the dead-man 60 ms";
    EXPECT_TRUE(board->snapshot().output_on);
  }  // the loop stops dead
  EXPECT_TRUE(within(1.0, [&] { return board->snapshot().watchdog_tripped; }));
  const auto s = board->snapshot();
  EXPECT_FALSE(s.output_on);
  EXPECT_EQ(s.output_counts, 0);
  EXPECT_EQ(s.firmware.watchdog_trips, 1U);
}

// Through the framework's Device, as the engine calls it: every read and
// write of the guarded periods is ok, and none allocates.
TEST_F(EmulatedBoardTest, ReadWriteAllocateNothing) {
  Device device("usb-hid", std::make_unique<UsbHidDevice>(sim_config()));
  device.configure({1e-3});
  device.enable();
  Reading r;
  ASSERT_EQ(device.read(r), IoResult::ok);
  ASSERT_EQ(device.write(0.0), IoResult::ok);
  std::size_t allocations = 0;
  int not_ok = 0;
  {
    hapticd::testing::AllocationGuard guard;
    for (int p = 0; p < 500; ++p) {
      not_ok += device.read(r) != IoResult::ok;
      not_ok += device.write(0.01 * (p % 7)) != IoResult::ok;
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(not_ok, 0) << "read/write calls that were not ok";
  EXPECT_EQ(device.hooks_as<UsbHidDevice>().link_status().fault.reason, LinkFault::none);
  const DeviceStatus s = device.status();
  EXPECT_EQ(s.read_errors + s.write_errors + s.faults, 0U);
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid::usb_hid_device_test
