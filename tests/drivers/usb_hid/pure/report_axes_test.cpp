// A board with several axes (issue 22): the report layout with one encoder
// and one command field per axis. Round trips through the codec, the
// layout's bounds and overlaps refused with the axis named, the config keys
// (axes, field lists or consecutive fields, per-axis scales), and the
// driver's codec against the simulated board's own byte-by-byte reports
// (sim/usb_hid/board_reports.hpp) for every axis count.

#include <gtest/gtest.h>

#include <map>
#include <string>

#include "drivers/driver_description.hpp"
#include "drivers/usb_hid/report_codec.hpp"
#include "drivers/usb_hid/usb_hid_config.hpp"
#include "sim/usb_hid/board_firmware.hpp"
#include "sim/usb_hid/board_reports.hpp"

namespace hapticd::drivers::usb_hid {
DriverDescription usb_hid_driver();  // usb_hid_driver.cpp
}  // namespace hapticd::drivers::usb_hid

namespace hapticd::drivers::usb_hid::report_axes_test {

namespace {

using Given = std::map<std::string, ParameterValue, std::less<>>;

/// The simulated board's layout for `n` axes (board_reports.hpp), in the codec's terms.
ReportLayout board_layout(std::size_t n) {
  ReportLayout l;
  l.in.size = sim::in_report_bytes_for(n);
  l.in.position = consecutive_fields(field(4, 4, true), n);
  const std::size_t status = 4 + 4 * n;
  l.in.enabled = bit_at(status, 0);
  l.in.fault = bit_at(status, 1);
  l.in.watchdog = bit_at(status, 2);
  l.in.fault_code = field(status + 1, 1, false);
  l.out.size = sim::out_report_bytes_for(n);
  l.out.command = consecutive_fields(field(2, 2, true), n);
  l.out.enable = bit_at(2 + 2 * n, 0);
  l.out.reset = bit_at(2 + 2 * n, 1);
  l.out.deadman = field(4 + 2 * n, 2, false);
  return l;
}

std::string refusal(const ReportLayout& l, std::string& key) {
  try {
    validate(l);
  } catch (const LayoutError& e) {
    key = e.key();
    return e.what();
  }
  return "accepted";
}

TEST(UsbHidAxes, OneAxisBoardLayoutIsTheDefaultByteForByte) {
  const ReportLayout d;
  const ReportLayout one = board_layout(1);
  EXPECT_EQ(one.in.size, d.in.size);
  EXPECT_EQ(one.in.position, d.in.position);
  EXPECT_EQ(one.in.enabled, d.in.enabled);
  EXPECT_EQ(one.in.fault_code, d.in.fault_code);
  EXPECT_EQ(one.out.size, d.out.size);
  EXPECT_EQ(one.out.command, d.out.command);
  EXPECT_EQ(one.out.enable, d.out.enable);
  EXPECT_EQ(one.out.deadman, d.out.deadman);
  EXPECT_EQ(d.axes(), 1U);
  // The same OUT report as before the axes: 0-1 sequence, 2-3 command, 4 bits, 6-7 dead-man.
  OutReport r;
  r.sequence = 0x0102;
  r.command[0] = -2;
  r.enable = true;
  r.deadman_us = 3000;
  std::array<std::uint8_t, 8> bytes{};
  ASSERT_EQ(encode_out(r, d.out, bytes), 8U);
  EXPECT_EQ(bytes, (std::array<std::uint8_t, 8>{0x02, 0x01, 0xFE, 0xFF, 0x01, 0x00, 0xB8, 0x0B}));
}

TEST(UsbHidAxes, EveryAxisRoundTripsThroughTheCodec) {
  for (std::size_t n = 1; n <= max_report_axes; ++n) {
    const ReportLayout l = board_layout(n);
    ASSERT_NO_THROW(validate(l)) << n << " axes";
    EXPECT_EQ(l.axes(), n);
    InReport in;
    in.sequence = 77;
    in.ack = 76;
    in.enabled = true;
    OutReport out;
    out.sequence = 9;
    out.enable = true;
    for (std::size_t k = 0; k < n; ++k) {
      const auto sign = k % 2 == 0 ? 1 : -1;
      in.position_counts[k] = sign * (100000 * static_cast<std::int64_t>(k + 1) + 3);
      out.command[k] = sign * (1000 * static_cast<std::int64_t>(k + 1) + 7);
    }
    std::array<std::uint8_t, max_report_size> bytes{};
    ASSERT_EQ(encode_in(in, l.in, bytes), l.in.size);
    InReport in_back;
    ASSERT_EQ(decode_in(std::span(bytes).first(l.in.size), l.in, in_back), DecodeStatus::ok);
    EXPECT_EQ(in_back, in) << n << " axes";
    ASSERT_EQ(encode_out(out, l.out, bytes), l.out.size);
    OutReport out_back;
    ASSERT_EQ(decode_out(std::span(bytes).first(l.out.size), l.out, out_back), DecodeStatus::ok);
    EXPECT_EQ(out_back, out) << n << " axes";
    // One byte short is short for every axis: no axis decodes.
    EXPECT_EQ(decode_in(std::span(bytes).first(l.in.size - 1), l.in, in_back), DecodeStatus::short_report);
  }
}

TEST(UsbHidAxes, ExtremeCountsOfEachAxisSurvive) {
  ReportLayout l = board_layout(3);
  InReport in;
  in.position_counts = {-2147483648LL, 2147483647LL, -1, 0, 0, 0};
  std::array<std::uint8_t, max_report_size> bytes{};
  encode_in(in, l.in, bytes);
  InReport back;
  ASSERT_EQ(decode_in(bytes, l.in, back), DecodeStatus::ok);
  EXPECT_EQ(back.position_counts, in.position_counts);
  // Commands saturate per axis at their own field's largest value.
  l.out.command[1] = field(4, 1, true);  // i8 for axis 2
  l.out.command[2] = field(5, 2, true);
  l.out.enable = bit_at(7, 0);
  l.out.reset = bit_at(7, 1);
  l.out.deadman = field(8, 2, false);
  l.out.size = 10;
  ASSERT_NO_THROW(validate(l));
  EXPECT_EQ(command_counts(2.0, 1.0, l.out.command[0]), 32767);
  EXPECT_EQ(command_counts(-2.0, 1.0, l.out.command[1]), -127);
}

TEST(UsbHidAxes, FieldsOutsideTheReportAreRefusedNamingTheAxis) {
  ReportLayout l = board_layout(6);
  l.in.size = 16;  // six i32 counts need bytes 4..27
  std::string key;
  EXPECT_EQ(refusal(l, key), "in_position (axis 4) needs bytes 16..19 but the IN report has 16 bytes");
  EXPECT_EQ(key, "in_position");
  l = board_layout(6);
  l.out.size = 12;  // six i16 commands need bytes 2..13
  EXPECT_EQ(refusal(l, key), "out_command (axis 6) needs bytes 12..13 but the OUT report has 12 bytes");
  EXPECT_EQ(key, "out_command");
}

TEST(UsbHidAxes, OverlapsBetweenAxesAndWithOtherFieldsAreRefused) {
  std::string key;
  ReportLayout l = board_layout(2);
  l.in.position[1] = field(6, 4, true);  // axis 2 starts inside axis 1
  EXPECT_EQ(refusal(l, key), "in_position (axis 2) overlaps in_position (axis 1) (byte 6, bit 0)");
  EXPECT_EQ(key, "in_position");
  // Two axes in the default IN report: axis 2 (8..11) takes the status byte.
  l = ReportLayout{};
  l.in.position = consecutive_fields(field(4, 4, true), 2);
  l.out.command = consecutive_fields(field(2, 2, true), 2);
  EXPECT_EQ(refusal(l, key), "in_enabled_bit overlaps in_position (axis 2) (byte 8, bit 0)");
  EXPECT_EQ(key, "in_enabled_bit");
  l = board_layout(2);
  l.out.command[1] = field(3, 2, true);
  EXPECT_EQ(refusal(l, key), "out_command (axis 2) overlaps out_command (axis 1) (byte 3, bit 0)");
  EXPECT_EQ(key, "out_command");
}

TEST(UsbHidAxes, CommandsMustMatchThePositionsOneByOne) {
  std::string key;
  ReportLayout l = board_layout(2);
  l.out.command[1] = IntegerField{};
  EXPECT_EQ(refusal(l, key), "out_command has 1 field but in_position has 2; accepted: one command per axis");
  EXPECT_EQ(key, "out_command");
  l = board_layout(3);
  l.in.position[1] = IntegerField{};
  EXPECT_EQ(refusal(l, key),
            "in_position gives axis 3 but not axis 2; accepted: 1 to 6 fields, one per axis, axis 1 first");
  l = board_layout(2);
  l.out.command[1] = field(4, 2, false);
  EXPECT_EQ(refusal(l, key),
            "out_command (axis 2) = \"4:u16le\" must be signed (i8, i16le/be, i32le/be): the command is a "
            "signed duty or torque");
}

TEST(UsbHidAxes, TheBoardsReportsDecodeWithTheConfiguredLayout) {
  // The board writes its reports byte by byte (board_reports.cpp); the
  // driver reads them with the codec and the layout the README gives.
  for (std::size_t n = 1; n <= sim::max_board_axes; ++n) {
    const ReportLayout l = board_layout(n);
    sim::BoardFirmware firmware(n);
    std::array<std::int64_t, 6> counts{};
    for (std::size_t k = 0; k < n; ++k) counts[k] = -50 + 1000 * static_cast<std::int64_t>(k);
    std::array<std::uint8_t, sim::max_in_report_bytes> in{};
    const std::size_t length = firmware.make_in_report(std::span<const std::int64_t>(counts.data(), n), in);
    ASSERT_EQ(length, l.in.size);
    InReport report;
    ASSERT_EQ(decode_in(std::span(in).first(length), l.in, report), DecodeStatus::ok);
    for (std::size_t k = 0; k < n; ++k) EXPECT_EQ(report.position_counts[k], counts[k]) << n << "/" << k;
    OutReport out;
    out.sequence = 1;
    out.enable = true;
    for (std::size_t k = 0; k < n; ++k) out.command[k] = 300 * static_cast<std::int64_t>(k) - 200;
    std::array<std::uint8_t, max_report_size> bytes{};
    const std::size_t size = encode_out(out, l.out, bytes);
    ASSERT_TRUE(firmware.on_out_report(std::span(bytes).first(size), 0));
    for (std::size_t k = 0; k < n; ++k) EXPECT_EQ(firmware.output(k), out.command[k]) << n << "/" << k;
    // A report one byte short is not applied (no axis moves).
    out.sequence = 2;
    encode_out(out, l.out, bytes);
    EXPECT_FALSE(firmware.on_out_report(std::span(bytes).first(size - 1), 0));
  }
}

// ---- the config keys ----

UsbHidConfig from(Given given) {
  given.emplace("vendor_id", std::string("0x1209"));
  given.emplace("product_id", std::string("1"));
  return usb_hid_config_from(DriverParameters("usb-hid", usb_hid_driver().parameters, given));
}

/// The simulated board's two-axis layout as config keys (README.md).
Given two_axis_keys() {
  return {{"axes", 2.0},
          {"in_enabled_bit", std::string("12.0")},
          {"in_fault_bit", std::string("12.1")},
          {"in_watchdog_bit", std::string("12.2")},
          {"in_fault_code", std::string("13:u8")},
          {"out_report_size", 10.0},
          {"out_enable_bit", std::string("6.0")},
          {"out_reset_bit", std::string("6.1")},
          {"out_deadman", std::string("8:u16le")}};
}

std::string config_refusal(Given given, std::string& key) {
  try {
    from(std::move(given));
  } catch (const ParameterError& e) {
    key = e.key();
    return e.what();
  }
  return "accepted";
}

TEST(UsbHidAxes, ConsecutiveFieldsFromAxisOnesField) {
  const UsbHidConfig c = from(two_axis_keys());
  EXPECT_EQ(c.layout, board_layout(2)) << "in_position 4:i32le and out_command 2:i16le continue per axis";
  ASSERT_EQ(c.axis_count(), 2U);
  EXPECT_EQ(c.motion, Motion::linear);
  EXPECT_DOUBLE_EQ(c.position_per_count(1), 1.0 / 16384.0);
  EXPECT_DOUBLE_EQ(c.command_full_scale_of(1), 1.0);
  EXPECT_DOUBLE_EQ(c.axes[1].mass, 0.01);
}

TEST(UsbHidAxes, FieldListsAndPerAxisScales) {
  Given g = two_axis_keys();
  g["in_position"] = std::string("8:i32le, 4:i32be");
  g["out_command"] = std::string("4:i16le,2:i16le");
  g["axis_counts_per_unit"] = std::string("20000,40000");
  g["axis_command_full_scale"] = std::string("2.5, 4");
  g["axis_mass"] = std::string("0.1,0.3");
  g["axis_damping"] = std::string("0,1.5");
  g["direction"] = std::string("inverted");
  const UsbHidConfig c = from(g);
  EXPECT_EQ(c.layout.in.position[0], field(8, 4, true));
  EXPECT_EQ(c.layout.in.position[1], field(4, 4, true, ByteOrder::big));
  EXPECT_EQ(c.layout.out.command[0], field(4, 2, true));
  EXPECT_DOUBLE_EQ(c.position_per_count(0), -1.0 / 20000.0);
  EXPECT_DOUBLE_EQ(c.position_per_count(1), -1.0 / 40000.0);
  EXPECT_DOUBLE_EQ(c.command_full_scale_of(0), 2.5);
  EXPECT_DOUBLE_EQ(c.command_full_scale_of(1), 4.0);
  EXPECT_DOUBLE_EQ(c.axes[0].mass, 0.1);
  EXPECT_DOUBLE_EQ(c.axes[1].damping, 1.5);
}

TEST(UsbHidAxes, ConfigRefusalsNameTheKeyAndWhatIsAccepted) {
  std::string key;
  Given g = two_axis_keys();
  g["in_position"] = std::string("4:i32le,8:i32le,16:i32le");
  EXPECT_EQ(
      config_refusal(g, key),
      "device.usb-hid.in_position has 3 fields for axes = 2; accepted: one field (axis 1, the next axes "
      "right after it) or 2 comma-separated fields, one per axis");
  EXPECT_EQ(key, "in_position");
  g = two_axis_keys();
  g["axis_mass"] = std::string("0.1");
  EXPECT_EQ(
      config_refusal(g, key),
      "device.usb-hid.axis_mass = \"0.1\" is not accepted; accepted: 2 comma-separated numbers in [1e-09, "
      "1e+06] kg, one per axis");
  EXPECT_EQ(key, "axis_mass");
  g = two_axis_keys();
  g["axis_counts_per_unit"] = std::string("16384,-1");
  EXPECT_EQ(config_refusal(g, key).substr(0, 55),
            "device.usb-hid.axis_counts_per_unit = \"16384,-1\" is not");
  g = two_axis_keys();
  g["motion"] = std::string("rotary");
  EXPECT_EQ(
      config_refusal(g, key),
      "device.usb-hid.motion = \"rotary\" is not accepted with axes = 2; accepted: \"linear\" (a Cartesian "
      "stage of linear axes, m and N)");
  EXPECT_EQ(key, "motion");
  EXPECT_EQ(
      config_refusal({{"axis_mass", std::string("0.1")}}, key),
      "device.usb-hid.axis_mass is for a board with several axes; accepted with axes = 2 to 6 (one axis: "
      "mass)");
  // Two axes left in the default report: axis 2's count runs into the status bits.
  EXPECT_EQ(config_refusal({{"axes", 2.0}}, key),
            "device.usb-hid.in_enabled_bit overlaps in_position (axis 2) (byte 8, bit 0)");
  EXPECT_EQ(key, "in_enabled_bit");
}

TEST(UsbHidAxes, OneAxisConfigIsUnchanged) {
  const UsbHidConfig c = from({});
  EXPECT_EQ(c.layout, ReportLayout{});
  EXPECT_TRUE(c.axes.empty());
  EXPECT_EQ(c.axis_count(), 1U);
  EXPECT_EQ(c.motion, Motion::rotary);
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid::report_axes_test
