// The report layout byte by byte: the default layout of README.md "Reports"
// field by field, a non-default layout (report IDs, big-endian, narrow
// fields), the field notation, validation and the sequence arithmetic.

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "drivers/usb_hid/report_codec.hpp"

namespace hapticd::drivers::usb_hid::report_codec_test {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes encode(const OutReport& report, const OutLayout& layout = {}) {
  Bytes out(layout.size, 0xEE);
  EXPECT_EQ(encode_out(report, layout, out), layout.size);
  return out;
}

Bytes encode(const InReport& report, const InLayout& layout = {}) {
  Bytes out(layout.size, 0xEE);
  EXPECT_EQ(encode_in(report, layout, out), layout.size);
  return out;
}

// ---- default OUT report: 8 bytes, little-endian (README.md "OUT report") ----

TEST(DefaultOutReport, EveryFieldAtItsBytes) {
  OutReport r;
  r.sequence = 0x1234;
  r.command[0] = -2;  // 0xfffe
  r.enable = true;
  r.deadman_us = 3000;  // 0x0bb8
  EXPECT_EQ(encode(r), (Bytes{0x34, 0x12, 0xFE, 0xFF, 0x01, 0x00, 0xB8, 0x0B}));
}

TEST(DefaultOutReport, EachFieldAloneTouchesOnlyItsBytes) {
  const Bytes zero(8, 0);
  EXPECT_EQ(encode(OutReport{}), zero);
  OutReport r;
  r.sequence = 0xBEEF;
  EXPECT_EQ(encode(r), (Bytes{0xEF, 0xBE, 0, 0, 0, 0, 0, 0}));
  r = {};
  r.command[0] = 32767;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0xFF, 0x7F, 0, 0, 0, 0}));
  r = {};
  r.command[0] = -32767;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0x01, 0x80, 0, 0, 0, 0}));
  r = {};
  r.enable = true;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0, 0, 0x01, 0, 0, 0}));
  r = {};
  r.reset = true;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0, 0, 0x02, 0, 0, 0}));
  r = {};
  r.deadman_us = 65535;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0, 0, 0, 0, 0xFF, 0xFF}));
}

TEST(DefaultOutReport, DecodesWhatItEncodes) {
  OutReport r;
  r.sequence = 65535;
  r.command[0] = -12345;
  r.enable = true;
  r.reset = true;
  r.deadman_us = 2500;
  OutReport back;
  ASSERT_EQ(decode_out(encode(r), OutLayout{}, back), DecodeStatus::ok);
  EXPECT_EQ(back, r);
}

// ---- default IN report: 16 bytes (README.md "IN report") ----

TEST(DefaultInReport, EveryFieldFromItsBytes) {
  const Bytes bytes = {0x01, 0x02,              // sequence 0x0201
                       0x34, 0x12,              // ack 0x1234
                       0x60, 0x79, 0xFE, 0xFF,  // position -100000
                       0x07,                    // enabled, fault, watchdog
                       0x02,                    // fault code: over-temperature
                       0,    0,    0,    0,    0, 0};
  InReport r;
  ASSERT_EQ(decode_in(bytes, InLayout{}, r), DecodeStatus::ok);
  EXPECT_EQ(r.sequence, 0x0201U);
  EXPECT_EQ(r.ack, 0x1234U);
  EXPECT_EQ(r.position_counts[0], -100000);
  EXPECT_TRUE(r.enabled);
  EXPECT_TRUE(r.fault);
  EXPECT_TRUE(r.watchdog);
  EXPECT_EQ(r.fault_code, 2U);
}

TEST(DefaultInReport, EachFieldAloneTouchesOnlyItsBytes) {
  InReport r;
  EXPECT_EQ(encode(r), Bytes(16, 0));
  r.sequence = 0xABCD;
  EXPECT_EQ(encode(r), (Bytes{0xCD, 0xAB, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}));
  r = {};
  r.ack = 0x0102;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0x02, 0x01, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0}));
  r = {};
  r.position_counts[0] = 0x12345678;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0, 0, 0x78, 0x56, 0x34, 0x12, 0, 0, 0, 0, 0, 0, 0, 0}));
  r = {};
  r.position_counts[0] = -1;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0, 0, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0, 0, 0, 0, 0}));
  r = {};
  r.enabled = true;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0, 0, 0, 0, 0, 0, 0x01, 0, 0, 0, 0, 0, 0, 0}));
  r = {};
  r.fault = true;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0, 0, 0, 0, 0, 0, 0x02, 0, 0, 0, 0, 0, 0, 0}));
  r = {};
  r.watchdog = true;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0, 0, 0, 0, 0, 0, 0x04, 0, 0, 0, 0, 0, 0, 0}));
  r = {};
  r.fault_code = 7;
  EXPECT_EQ(encode(r), (Bytes{0, 0, 0, 0, 0, 0, 0, 0, 0, 0x07, 0, 0, 0, 0, 0, 0}));
}

TEST(DefaultInReport, PositionExtremes) {
  for (const std::int64_t counts :
       {std::int64_t{std::numeric_limits<std::int32_t>::min()}, std::int64_t{-1}, std::int64_t{0},
        std::int64_t{std::numeric_limits<std::int32_t>::max()}}) {
    InReport r;
    r.position_counts[0] = counts;
    InReport back;
    ASSERT_EQ(decode_in(encode(r), InLayout{}, back), DecodeStatus::ok);
    EXPECT_EQ(back.position_counts[0], counts);
  }
}

TEST(DefaultInReport, ShortReportRefused) {
  InReport r;
  EXPECT_EQ(decode_in(Bytes(15, 0), InLayout{}, r), DecodeStatus::short_report);
  EXPECT_EQ(decode_in(Bytes{}, InLayout{}, r), DecodeStatus::short_report);
  EXPECT_EQ(decode_in(Bytes(64, 0), InLayout{}, r), DecodeStatus::ok) << "a longer packet carries the report";
}

// ---- a non-default layout: report IDs, big-endian, narrow fields ----

ReportLayout vendor_layout() {
  ReportLayout l;
  l.in.size = 9;
  l.in.report_id = 0x05;
  l.in.position[0] = parse_integer_field("1:i32be");
  l.in.sequence = parse_integer_field("5:u8");
  l.in.ack = parse_integer_field("6:u8");
  l.in.enabled = parse_bit_field("7.7");
  l.in.fault = parse_bit_field("7.0");
  l.in.watchdog = parse_bit_field("none");
  l.in.fault_code = parse_integer_field("8:u8");
  l.out.size = 6;
  l.out.report_id = 0x06;
  l.out.command[0] = parse_integer_field("1:i32be");
  l.out.sequence = parse_integer_field("5:u8");
  l.out.enable = parse_bit_field("0.0");  // on the report ID byte: refused below, moved in BytesAsLaidOut
  return l;
}

TEST(VendorLayout, ReportIdByteIsNotAField) {
  ReportLayout l = vendor_layout();
  try {
    validate(l);
    FAIL() << "enable bit on the report ID byte accepted";
  } catch (const LayoutError& e) {
    EXPECT_EQ(e.key(), "out_enable_bit");
    EXPECT_NE(std::string(e.what()).find("overlaps out_report_id"), std::string::npos) << e.what();
  }
}

TEST(VendorLayout, BytesAsLaidOut) {
  ReportLayout l = vendor_layout();
  l.out.size = 7;
  l.out.enable = parse_bit_field("6.3");
  l.out.reset = parse_bit_field("none");
  l.out.deadman = parse_integer_field("none");
  ASSERT_NO_THROW(validate(l));
  OutReport out;
  out.sequence = 0x1FF;  // u8: only 0xff goes on the wire
  out.command[0] = -2;
  out.enable = true;
  out.reset = true;       // no reset bit in this layout: not encoded
  out.deadman_us = 1000;  // no dead-man field: not encoded
  EXPECT_EQ(encode(out, l.out), (Bytes{0x06, 0xFF, 0xFF, 0xFF, 0xFE, 0xFF, 0x08}));

  const Bytes in = {0x05, 0x80, 0x00, 0x00, 0x01, 0x2A, 0x29, 0x81, 0x03};
  InReport r;
  ASSERT_EQ(decode_in(in, l.in, r), DecodeStatus::ok);
  EXPECT_EQ(r.position_counts[0], std::int64_t{-2147483647});  // 0x80000001 big-endian
  EXPECT_EQ(r.sequence, 0x2AU);
  EXPECT_EQ(r.ack, 0x29U);
  EXPECT_TRUE(r.enabled);
  EXPECT_TRUE(r.fault);
  EXPECT_FALSE(r.watchdog);
  EXPECT_EQ(r.fault_code, 3U);
  Bytes wrong_id = in;
  wrong_id[0] = 0x04;
  EXPECT_EQ(decode_in(wrong_id, l.in, r), DecodeStatus::wrong_report_id);
}

TEST(Fields, SignExtensionAndByteOrder) {
  const Bytes b = {0x80, 0xFF, 0x7F, 0x01};
  EXPECT_EQ(read_field(b, parse_integer_field("0:i8")), -128);
  EXPECT_EQ(read_field(b, parse_integer_field("0:u8")), 128);
  EXPECT_EQ(read_field(b, parse_integer_field("0:i16le")), -128);    // 0xff80
  EXPECT_EQ(read_field(b, parse_integer_field("0:i16be")), -32513);  // 0x80ff
  EXPECT_EQ(read_field(b, parse_integer_field("1:u16be")), 0xFF7F);
  EXPECT_EQ(read_field(b, parse_integer_field("0:u32le")), std::int64_t{0x017FFF80});
  EXPECT_EQ(read_field(b, parse_integer_field("0:i32be")),
            std::int64_t{static_cast<std::int32_t>(0x80FF7F01U)});
}

TEST(Fields, NotationRoundTrips) {
  for (const char* text : {"0:u8", "3:i8", "4:u16le", "4:u16be", "2:i16le", "2:i16be", "0:u32le", "60:u32be",
                           "1:i32le", "1:i32be", "none"})
    EXPECT_EQ(to_string(parse_integer_field(text)), text);
  for (const char* text : {"0.0", "8.7", "63.3", "none"}) EXPECT_EQ(to_string(parse_bit_field(text)), text);
}

TEST(Fields, BadNotationSaysWhatIsAccepted) {
  for (const char* text : {"4", "4:i24le", "x:u8", "64:u8", ":u8", "4:U8", "-1:u8"}) {
    try {
      parse_integer_field(text);
      ADD_FAILURE() << text << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("accepted"), std::string::npos) << e.what();
    }
  }
  for (const char* text : {"8", "8.8", "8.-1", "a.1", "64.0"})
    EXPECT_THROW(parse_bit_field(text), std::invalid_argument) << text;
}

// ---- validation ----

TEST(Validate, DefaultLayoutIsValid) { EXPECT_NO_THROW(validate(ReportLayout{})); }

void expect_layout_error(const ReportLayout& l, const std::string& key, const std::string& words) {
  try {
    validate(l);
    ADD_FAILURE() << "accepted; expected an error on " << key;
  } catch (const LayoutError& e) {
    EXPECT_EQ(e.key(), key) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(Validate, RefusesWhatCannotWork) {
  ReportLayout l;
  l.in.position[0] = parse_integer_field("3:i32le");
  expect_layout_error(l, "in_position", "overlaps in_ack (byte 3, bit 0)");
  l = {};
  l.in.fault_code = parse_integer_field("15:u16le");
  expect_layout_error(l, "in_fault_code", "needs bytes 15..16 but the IN report has 16 bytes");
  l = {};
  l.in.watchdog = parse_bit_field("8.1");
  expect_layout_error(l, "in_watchdog_bit", "overlaps in_fault_bit");
  l = {};
  l.in.sequence = IntegerField{};
  expect_layout_error(l, "in_sequence", "required");
  l = {};
  l.out.enable = BitField{};
  expect_layout_error(l, "out_enable_bit", "required");
  l = {};
  l.out.sequence = parse_integer_field("0:i16le");
  expect_layout_error(l, "out_sequence", "must be unsigned");
  l = {};
  l.out.command[0] = parse_integer_field("2:u16le");
  expect_layout_error(l, "out_command", "must be signed");
  l = {};
  l.out.size = 65;
  expect_layout_error(l, "out_report_size", "accepted: 1 to 64");
  l = {};
  l.in.report_id = 256;
  expect_layout_error(l, "in_report_id", "0..255");
  l = {};
  l.in.report_id = 1;
  expect_layout_error(l, "in_sequence", "overlaps in_report_id");
}

// ---- sequences, command scaling, fault codes ----

TEST(Sequence, DistanceWrapsModuloTheFieldWidth) {
  const IntegerField u16 = parse_integer_field("0:u16le");
  EXPECT_EQ(sequence_distance(65535, 0, u16), 1);
  EXPECT_EQ(sequence_distance(0, 65535, u16), -1);
  EXPECT_EQ(sequence_distance(10, 10, u16), 0);
  EXPECT_EQ(sequence_distance(10, 13, u16), 3);
  EXPECT_EQ(sequence_distance(0, 32768, u16), 32768);
  EXPECT_EQ(sequence_distance(0, 32769, u16), -32767);
  const IntegerField u8 = parse_integer_field("0:u8");
  EXPECT_EQ(sequence_distance(255, 0, u8), 1);
  EXPECT_EQ(sequence_distance(250, 4, u8), 10);
  EXPECT_EQ(next_sequence(255, u8), 0U);
  EXPECT_EQ(next_sequence(65535, u16), 0U);
  const IntegerField u32 = parse_integer_field("0:u32le");
  EXPECT_EQ(sequence_distance(0xFFFFFFFFU, 0, u32), 1);
  EXPECT_EQ(next_sequence(0xFFFFFFFFU, u32), 0U);
}

TEST(Command, ScaledRoundedAndSaturated) {
  const IntegerField i16 = OutLayout{}.command[0];
  EXPECT_EQ(i16.largest(), 32767);
  EXPECT_EQ(command_counts(0.5, 1.0, i16), 16384);  // 16383.5 rounds away from zero
  EXPECT_EQ(command_counts(-0.5, 1.0, i16), -16384);
  EXPECT_EQ(command_counts(1.0, 1.0, i16), 32767);
  EXPECT_EQ(command_counts(7.0, 1.0, i16), 32767);
  EXPECT_EQ(command_counts(-7.0, 1.0, i16), -32767) << "symmetric: -32768 is never sent";
  EXPECT_EQ(command_counts(std::nan(""), 1.0, i16), 0);
  EXPECT_EQ(command_counts(INFINITY, 1.0, i16), 0);
  EXPECT_EQ(command_counts(0.2, 0.0, i16), 0);
  EXPECT_DOUBLE_EQ(command_force(32767, 0.8, i16), 0.8);
  EXPECT_DOUBLE_EQ(command_force(-16384, 2.0, i16), -16384.0 / 32767.0 * 2.0);
  const IntegerField i8 = parse_integer_field("0:i8");
  EXPECT_EQ(command_counts(0.5, 1.0, i8), 64);  // 63.5
}

TEST(FaultCodes, ProtocolTableAndUnknownCodes) {
  EXPECT_EQ(fault_code_text(1), "over-current");
  EXPECT_EQ(fault_code_text(6), "dead-man watchdog (no new OUT report in time)");
  EXPECT_EQ(fault_code_text(0x2A), "code 0x2a (not in the protocol's table)");
  EXPECT_EQ(fault_code_text(0x101), "code 0x101 (not in the protocol's table)");
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid::report_codec_test
