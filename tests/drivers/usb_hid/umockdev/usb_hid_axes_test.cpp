// A usb-hid board with two axes (issue 22) on the emulated bus, through
// libusb and the framework's Device: both encoders read from one IN report,
// both commands written in one OUT report per period, each axis with its own
// scales; a bad report zeroes nothing by itself but gives no reading for any
// axis; nothing on the period path allocates.

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <thread>
#include <vector>

#include "drivers/device.hpp"
#include "drivers/usb_hid/usb_hid_device.hpp"
#include "emulated_board_fixture.hpp"
#include "tests/support/alloc_counter.hpp"

namespace hapticd::drivers::usb_hid::usb_hid_axes_test {
namespace {

using testing::RampPlant;

constexpr double counts_x = 20000.0, counts_y = 50000.0;  // counts per metre
constexpr double scale_x = 2.0, scale_y = 5.0;            // N at the largest command

/// The simulated board's two-axis layout (sim/usb_hid/board_reports.hpp, README.md).
UsbHidConfig two_axis_config() {
  UsbHidConfig c;
  c.selector.vendor_id = 0x1209;
  c.selector.product_id = 0x0001;
  c.motion = Motion::linear;
  ReportLayout& l = c.layout;
  l.in.position = consecutive_fields(field(4, 4, true), 2);
  l.in.enabled = bit_at(12, 0);
  l.in.fault = bit_at(12, 1);
  l.in.watchdog = bit_at(12, 2);
  l.in.fault_code = field(13, 1, false);
  l.out.size = 10;
  l.out.command = consecutive_fields(field(2, 2, true), 2);
  l.out.enable = bit_at(6, 0);
  l.out.reset = bit_at(6, 1);
  l.out.deadman = field(8, 2, false);
  c.axes = {{counts_x, scale_x, 0.1, 0.0}, {counts_y, scale_y, 0.3, 1.0}};
  return c;
}

class TwoAxisBoardTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!sim::UmockdevUsbBoard::preload_active())
      GTEST_FAIL() << "libumockdev-preload is not loaded in this process, though the build links it";
    // Each plant moves 1 mm per N per period: every count is predictable.
    x = std::make_unique<RampPlant>(1e-3);
    y = std::make_unique<RampPlant>(1e-3);
    board = std::make_unique<sim::SimulatedBoard>(
        std::vector<sim::BoardAxis>{{x.get(), 1.0 / counts_x, scale_x}, {y.get(), 1.0 / counts_y, scale_y}},
        1e-3);
    testbed = std::make_unique<sim::UmockdevUsbBoard>(sim::EmulatedUsbIdentity{}, *board);
  }
  void TearDown() override {
    testbed.reset();
    board.reset();
  }

  std::unique_ptr<RampPlant> x, y;
  std::unique_ptr<sim::SimulatedBoard> board;
  std::unique_ptr<sim::UmockdevUsbBoard> testbed;
};

TEST_F(TwoAxisBoardTest, BothAxesReadAndWrittenOneReportPerPeriod) {
  Device device("usb-hid", std::make_unique<UsbHidDevice>(two_axis_config()));
  device.configure({1e-3});
  ASSERT_EQ(device.axes(), 2);
  const DeviceModel model = device.model();
  ASSERT_EQ(model.axes.size(), 2U);
  EXPECT_DOUBLE_EQ(model.axes[1].mass, 0.3);
  EXPECT_DOUBLE_EQ(model.effective_mass, 0.1) << "the lightest axis in the one-axis fields";
  device.enable();
  std::array<Reading, 2> r{};
  const std::array<double, 2> forces{1.0, -2.5};  // 0.5 of each axis' full scale
  const std::uint64_t out_before = testbed->counters().out_submitted;
  const int periods = 50;
  for (int p = 0; p < periods; ++p) {
    ASSERT_EQ(device.read_axes(r), IoResult::ok) << p;
    ASSERT_EQ(device.write_axes(forces), IoResult::ok) << p;
  }
  EXPECT_EQ(testbed->counters().out_submitted - out_before, static_cast<std::uint64_t>(periods))
      << "one OUT report per period carries both axes";
  const sim::BoardSnapshot s = board->snapshot();
  EXPECT_EQ(s.outputs[0], 16384);   // round(1.0 / 2.0 x 32767)
  EXPECT_EQ(s.outputs[1], -16384);  // round(-2.5 / 5.0 x 32767)
  EXPECT_NEAR(s.applied_forces[0], 1.0, scale_x / 32767);
  EXPECT_NEAR(s.applied_forces[1], -2.5, scale_y / 32767);
  ASSERT_EQ(x->forces().size(), y->forces().size()) << "both plants step once per OUT report";
  // The positions read are each plant's, through its own counts per metre.
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  EXPECT_GT(r[0].position, 0.0);
  EXPECT_LT(r[1].position, 0.0);
  EXPECT_NEAR(r[0].position, x->position(), 0.5 / counts_x + 1e-12);
  EXPECT_NEAR(r[1].position, y->position(), 0.5 / counts_y + 1e-12);
  device.disable();
  EXPECT_EQ(board->snapshot().outputs[1], 0);
  device.close();
}

TEST_F(TwoAxisBoardTest, ShortReportIsNoReadingForAnyAxis) {
  Device device("usb-hid", std::make_unique<UsbHidDevice>(two_axis_config()));
  device.configure({1e-3});
  device.enable();
  std::array<Reading, 2> r{};
  const std::array<double, 2> forces{0.5, 0.5};
  for (int p = 0; p < 5; ++p) {
    ASSERT_EQ(device.read_axes(r), IoResult::ok);
    ASSERT_EQ(device.write_axes(forces), IoResult::ok);
  }
  // Let the last report arrive, then make the board's next one short.
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  board->truncate_next_report();
  ASSERT_EQ(device.write_axes(forces), IoResult::ok);
  std::array<Reading, 2> after{{{-7.0, false}, {-7.0, false}}};
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // the handler answers the IN URB
  IoResult result = device.read_axes(after);
  EXPECT_EQ(result, IoResult::error) << "15 of 16 bytes: neither axis has a reading this period";
  EXPECT_EQ(after[0].position, -7.0);
  EXPECT_EQ(after[1].position, -7.0);
  EXPECT_EQ(device.hooks_as<UsbHidDevice>().link_status().session.short_reports, 1U);
  // The next good report is a reading again for both.
  ASSERT_EQ(device.write_axes(forces), IoResult::ok);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(device.read_axes(after), IoResult::ok);
  EXPECT_NEAR(after[0].position, x->position(), 0.5 / counts_x + 1e-12);
}

TEST_F(TwoAxisBoardTest, EncoderFaultOnTheBoardFaultsEveryAxis) {
  Device device("usb-hid", std::make_unique<UsbHidDevice>(two_axis_config()));
  device.configure({1e-3});
  device.enable();
  std::array<Reading, 2> r{};
  const std::array<double, 2> forces{0.5, 0.5};
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  board->raise_fault(sim::FaultCode::encoder);
  IoResult result = IoResult::ok;
  for (int p = 0; p < 20 && result == IoResult::ok; ++p) {
    device.write_axes(forces);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    result = device.read_axes(r);
  }
  EXPECT_EQ(result, IoResult::fault);
  EXPECT_EQ(device.hooks_as<UsbHidDevice>().link_status().fault_text,
            "board fault: encoder error (code 0x05)");
  device.write_axes(forces);
  const sim::BoardSnapshot s = board->snapshot();
  EXPECT_EQ(s.outputs[0], 0);
  EXPECT_EQ(s.outputs[1], 0);
}

TEST_F(TwoAxisBoardTest, ReadAxesWriteAxesAllocateNothing) {
  Device device("usb-hid", std::make_unique<UsbHidDevice>(two_axis_config()));
  device.configure({1e-3});
  device.enable();
  std::array<Reading, 2> r{};
  std::array<double, 2> forces{0.0, 0.0};
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  ASSERT_EQ(device.write_axes(forces), IoResult::ok);
  std::size_t allocations = 0;
  int not_ok = 0;
  {
    hapticd::testing::AllocationGuard guard;
    for (int p = 0; p < 500; ++p) {
      not_ok += device.read_axes(r) != IoResult::ok;
      forces = {0.01 * (p % 7), -0.02 * (p % 5)};
      not_ok += device.write_axes(forces) != IoResult::ok;
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(not_ok, 0);
  EXPECT_EQ(device.status().read_errors + device.status().write_errors, 0U);
}

// Six axes, the most a device has: a 30-byte IN and an 18-byte OUT report,
// each axis' command reaching its own plant, and still nothing allocates.
TEST(SixAxisBoard, EveryAxisInOneReportAndNothingAllocates) {
  if (!sim::UmockdevUsbBoard::preload_active()) GTEST_FAIL() << "libumockdev-preload is not loaded";
  constexpr std::size_t n = 6;
  std::vector<std::unique_ptr<RampPlant>> plants;
  std::vector<sim::BoardAxis> axes;
  UsbHidConfig c;
  c.selector.vendor_id = 0x1209;
  c.selector.product_id = 0x0001;
  c.motion = Motion::linear;
  for (std::size_t k = 0; k < n; ++k) {
    plants.push_back(std::make_unique<RampPlant>(1e-3));
    const double counts = 10000.0 * static_cast<double>(k + 1);
    const double scale = 1.0 + static_cast<double>(k);
    axes.push_back({plants.back().get(), 1.0 / counts, scale});
    c.axes.push_back({counts, scale, 0.1, 0.0});
  }
  sim::SimulatedBoard board(axes, 1e-3);
  sim::UmockdevUsbBoard testbed(sim::EmulatedUsbIdentity{}, board);
  ReportLayout& l = c.layout;
  l.in.size = board.in_report_size();
  l.in.position = consecutive_fields(field(4, 4, true), n);
  l.in.enabled = bit_at(28, 0);
  l.in.fault = bit_at(28, 1);
  l.in.watchdog = bit_at(28, 2);
  l.in.fault_code = field(29, 1, false);
  l.out.size = board.out_report_size();
  l.out.command = consecutive_fields(field(2, 2, true), n);
  l.out.enable = bit_at(14, 0);
  l.out.reset = bit_at(14, 1);
  l.out.deadman = field(16, 2, false);
  ASSERT_EQ(l.in.size, 30U);
  ASSERT_EQ(l.out.size, 18U);

  Device device("usb-hid", std::make_unique<UsbHidDevice>(c));
  device.configure({1e-3});
  ASSERT_EQ(device.axes(), 6);
  device.enable();
  std::array<Reading, n> r{};
  std::array<double, n> forces{};
  for (std::size_t k = 0; k < n; ++k) forces[k] = 0.25 * static_cast<double>(k + 1) * (k % 2 == 0 ? 1 : -1);
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  ASSERT_EQ(device.write_axes(forces), IoResult::ok);
  std::size_t allocations = 0;
  int not_ok = 0;
  {
    hapticd::testing::AllocationGuard guard;
    for (int p = 0; p < 500; ++p) {
      not_ok += device.read_axes(r) != IoResult::ok;
      not_ok += device.write_axes(forces) != IoResult::ok;
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(not_ok, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // the report of the last OUT report
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  const sim::BoardSnapshot s = board.snapshot();
  for (std::size_t k = 0; k < n; ++k) {
    // round(F / full scale x 32767) per axis, each with its own scale.
    const auto expected = std::llround(forces[k] / (1.0 + static_cast<double>(k)) * 32767.0);
    EXPECT_EQ(s.outputs[k], expected) << "axis " << k + 1;
    EXPECT_NEAR(r[k].position, plants[k]->position(), 0.5 / (10000.0 * static_cast<double>(k + 1)) + 1e-12)
        << "axis " << k + 1;
    EXPECT_EQ(r[k].position > 0.0, forces[k] > 0.0) << "axis " << k + 1;
  }
  device.close();
}

TEST_F(TwoAxisBoardTest, OneAxisCallsOnATwoAxisBoardAreRefused) {
  Device device("usb-hid", std::make_unique<UsbHidDevice>(two_axis_config()));
  device.configure({1e-3});
  device.enable();
  std::array<Reading, 1> one{};
  EXPECT_EQ(device.read_axes(one), IoResult::error);
  Reading r;
  EXPECT_EQ(device.read(r), IoResult::error) << "the framework takes every axis in one call";
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid::usb_hid_axes_test
