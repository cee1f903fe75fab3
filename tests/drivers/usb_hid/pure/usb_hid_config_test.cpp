// The usb-hid parameters: each key's accepted values, the error naming the
// key, scaling, and the checks that need the period.

#include <gtest/gtest.h>

#include <numbers>
#include <string>

#include "drivers/usb_hid/usb_hid_config.hpp"

namespace hapticd::drivers::usb_hid {
namespace {

UsbHidConfig board() {
  UsbHidConfig c;
  set_parameter(c, "vendor_id", "0x1209");
  set_parameter(c, "product_id", "1");
  return c;
}

void expect_refused(std::string_view key, std::string_view value, const std::string& words) {
  UsbHidConfig c = board();
  try {
    set_parameter(c, key, value);
    ADD_FAILURE() << key << " = " << value << " accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), key);
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(UsbHidConfig, KeysSetTheirFields) {
  UsbHidConfig c = board();
  EXPECT_EQ(c.selector.vendor_id, 0x1209);
  EXPECT_EQ(c.selector.product_id, 0x0001);
  set_parameter(c, "serial", "LAB-7");
  set_parameter(c, "path", "3-1.4");
  set_parameter(c, "interface", "2");
  set_parameter(c, "in_endpoint", "0x83");
  set_parameter(c, "out_endpoint", "0x02");
  set_parameter(c, "events", "thread");
  set_parameter(c, "in_position", "1:i32be");
  set_parameter(c, "out_reset_bit", "none");
  EXPECT_EQ(c.selector.serial, "LAB-7");
  EXPECT_EQ(c.selector.path, "3-1.4");
  EXPECT_EQ(c.selector.interface_number, 2);
  EXPECT_EQ(c.selector.in_endpoint, 0x83);
  EXPECT_EQ(c.selector.out_endpoint, 0x02);
  EXPECT_EQ(c.events, EventHandling::thread);
  EXPECT_EQ(c.layout.in.position, field(1, 4, true, ByteOrder::big));
  EXPECT_FALSE(c.layout.out.reset.present);
}

TEST(UsbHidConfig, BadValuesNameTheKeyAndWhatIsAccepted) {
  expect_refused("vendor_id", "0x12345", "accepted: 0x0000..0xffff");
  expect_refused("product_id", "zz", "accepted: 0x0000..0xffff");
  expect_refused("in_endpoint", "0x01", "accepted: \"auto\" or an IN endpoint address 0x81..0x8f");
  expect_refused("out_endpoint", "0x81", "OUT endpoint address 0x01..0x0f");
  expect_refused("in_transfers", "1", "accepted: an integer from 2 to 16");
  expect_refused("counts_per_unit", "-5", "a finite number > 0");
  expect_refused("motion", "spherical", "accepted: rotary, linear");
  expect_refused("direction", "backwards", "accepted: normal, inverted");
  expect_refused("events", "poll", "accepted: loop, thread");
  expect_refused("in_sequence", "0:u24le", "accepted: OFFSET:TYPE");
  expect_refused("out_enable_bit", "4.9", "BIT 0..7");
  expect_refused("hidraw", "/dev/hidraw0", "unknown usb-hid key");
}

TEST(UsbHidConfig, ScalingAndDirection) {
  UsbHidConfig c = board();
  c.counts_per_unit = 4096;
  EXPECT_DOUBLE_EQ(c.position_per_count(), 2.0 * std::numbers::pi / 4096);
  set_parameter(c, "direction", "inverted");
  EXPECT_DOUBLE_EQ(c.position_per_count(), -2.0 * std::numbers::pi / 4096);
  set_parameter(c, "motion", "linear");
  c.inverted = false;
  c.counts_per_unit = 1e6;
  EXPECT_DOUBLE_EQ(c.position_per_count(), 1e-6);
  c.deadman_periods = 3;
  EXPECT_EQ(c.deadman_us(1e-3), 3000U);
  EXPECT_EQ(c.deadman_us(250e-6), 750U);
}

TEST(UsbHidConfig, ValidateNeedsTheIdsAndAFittingDeadMan) {
  UsbHidConfig c;
  try {
    c.validate(1e-3);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "vendor_id");
  }
  c = board();
  EXPECT_NO_THROW(c.validate(1e-3));
  c.deadman_periods = 7;  // 70 ms does not fit u16 microseconds
  try {
    c.validate(10e-3);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "deadman_periods");
    EXPECT_STREQ(e.what(),
                 "deadman_periods = 7 is 70 ms at this period; out_deadman (6:u16le) holds at most 65535 us");
  }
  c = board();
  set_parameter(c, "in_ack", "4:u16le");
  try {
    c.validate(1e-3);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "in_position");
  }
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid
