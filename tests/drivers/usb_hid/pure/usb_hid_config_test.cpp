// The usb-hid parameters: each key's accepted values through the driver's
// one parameter table (DriverParameters, then usb_hid_config_from), the
// error naming the key, scaling, and the checks that need the period.

#include <gtest/gtest.h>

#include <numbers>
#include <string>

#include "drivers/driver_description.hpp"
#include "drivers/usb_hid/usb_hid_config.hpp"

namespace hapticd::drivers::usb_hid {
DriverDescription usb_hid_driver();  // usb_hid_driver.cpp (the registry's X-macro declares it too)
}  // namespace hapticd::drivers::usb_hid

namespace hapticd::drivers::usb_hid::usb_hid_config_test {

namespace {

using Given = std::map<std::string, ParameterValue, std::less<>>;

UsbHidConfig from(Given given) {
  given.emplace("vendor_id", std::string("0x1209"));
  given.emplace("product_id", std::string("1"));
  return usb_hid_config_from(DriverParameters("usb-hid", usb_hid_driver().parameters, given));
}

UsbHidConfig board() { return from({}); }

void expect_refused(const std::string& key, ParameterValue value, const std::string& words) {
  try {
    from({{key, value}});
    ADD_FAILURE() << key << " = " << to_text(value) << " accepted";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.key(), key);
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(UsbHidConfig, KeysSetTheirFields) {
  UsbHidConfig c = board();
  EXPECT_EQ(c.selector.vendor_id, 0x1209);
  EXPECT_EQ(c.selector.product_id, 0x0001);
  c = from({{"serial", std::string("LAB-7")},
            {"path", std::string("3-1.4")},
            {"interface", 2.0},
            {"in_endpoint", std::string("0x83")},
            {"out_endpoint", std::string("0x02")},
            {"events", std::string("thread")},
            {"in_position", std::string("1:i32be")},  // with the fields it would overlap moved
            {"in_sequence", std::string("14:u16le")},
            {"in_ack", std::string("none")},
            {"out_reset_bit", std::string("none")}});
  EXPECT_EQ(c.selector.serial, "LAB-7");
  EXPECT_EQ(c.selector.path, "3-1.4");
  EXPECT_EQ(c.selector.interface_number, 2);
  EXPECT_EQ(c.selector.in_endpoint, 0x83);
  EXPECT_EQ(c.selector.out_endpoint, 0x02);
  EXPECT_EQ(c.events, EventHandling::thread);
  EXPECT_EQ(c.layout.in.position[0], field(1, 4, true, ByteOrder::big));
  EXPECT_EQ(c.layout.in.sequence, field(14, 2, false));
  EXPECT_FALSE(c.layout.in.ack.present());
  EXPECT_FALSE(c.layout.out.reset.present);
}

TEST(UsbHidConfig, DefaultsAreTheReadmesLayout) {
  const UsbHidConfig c = board();
  const ReportLayout d;
  EXPECT_EQ(c.layout.in.position[0], d.in.position[0]);
  EXPECT_EQ(c.layout.in.fault_code, d.in.fault_code);
  EXPECT_EQ(c.layout.out.command[0], d.out.command[0]);
  EXPECT_EQ(c.layout.out.deadman, d.out.deadman);
  EXPECT_EQ(c.selector.in_endpoint, 0);  // auto
  EXPECT_FALSE(c.inverted);
  EXPECT_EQ(c.motion, Motion::rotary);
  EXPECT_DOUBLE_EQ(c.mass, 0.01);
}

// The messages of the keys the table checks are DriverParameters' own ("a
// whole number in [2, 16]"); the text notations' are the driver's parsers'.
TEST(UsbHidConfig, BadValuesNameTheKeyAndWhatIsAccepted) {
  expect_refused("vendor_id", std::string("0x12345"), "accepted: 0x0000..0xffff");
  expect_refused("product_id", std::string("zz"), "accepted: 0x0000..0xffff");
  expect_refused("in_endpoint", std::string("0x01"),
                 "accepted: \"auto\" or an IN endpoint address 0x81..0x8f");
  expect_refused("out_endpoint", std::string("0x81"), "OUT endpoint address 0x01..0x0f");
  expect_refused("in_transfers", 1.0, "accepted: a whole number in [2, 16]");
  expect_refused("counts_per_unit", -5.0, "accepted: a number > 0");
  expect_refused("motion", std::string("spherical"), "accepted: one of rotary, linear");
  expect_refused("direction", std::string("backwards"), "accepted: one of normal, inverted");
  expect_refused("events", std::string("poll"), "accepted: one of loop, thread");
  expect_refused("in_sequence", std::string("0:u24le"), "accepted: OFFSET:TYPE");
  expect_refused("out_enable_bit", std::string("4.9"), "BIT 0..7");
  expect_refused("hidraw", std::string("/dev/hidraw0"), "is not a parameter of the usb-hid driver");
}

TEST(UsbHidConfig, ScalingAndDirection) {
  UsbHidConfig c = board();
  c.counts_per_unit = 4096;
  EXPECT_DOUBLE_EQ(c.position_per_count(), 2.0 * std::numbers::pi / 4096);
  c = from({{"counts_per_unit", 4096.0}, {"direction", std::string("inverted")}});
  EXPECT_DOUBLE_EQ(c.position_per_count(), -2.0 * std::numbers::pi / 4096);
  c = from({{"counts_per_unit", 1e6}, {"motion", std::string("linear")}});
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
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.key(), "vendor_id");
  }
  c = board();
  EXPECT_NO_THROW(c.validate(1e-3));
  c.deadman_periods = 7;  // 70 ms does not fit u16 microseconds
  try {
    c.validate(10e-3);
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.key(), "deadman_periods");
    EXPECT_STREQ(e.what(),
                 "deadman_periods = 7 is 70 ms at this period; out_deadman (6:u16le) holds at most 65535 us");
  }
  c = board();
  c.layout.in.ack = parse_integer_field("4:u16le");
  try {
    c.validate(1e-3);
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.key(), "in_position");
  }
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid::usb_hid_config_test
