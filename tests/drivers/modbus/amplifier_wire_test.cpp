// The simulated amplifier's own reading and writing of the wire
// (sim/modbus/amplifier_wire.*), against the published frames and the
// exceptions of the Modbus Application Protocol V1.1b3 (AP), byte by byte,
// and the amplifier's answers to requests it must refuse.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

#include "loopback_plant.hpp"
#include "sim/modbus/amplifier.hpp"
#include "sim/modbus/amplifier_wire.hpp"

namespace amplifier_wire_test {

namespace sim = hapticd::drivers::modbus::sim;
using Bytes = std::vector<std::uint8_t>;

namespace {

std::uint8_t decode(const Bytes& pdu, sim::Request& r) { return sim::decode_request(pdu, r); }

template <class Encode>
Bytes encoded(Encode encode) {
  std::array<std::uint8_t, sim::max_reply_bytes> out{};
  const std::size_t n = encode(std::span<std::uint8_t>(out));
  return Bytes(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(n));
}

}  // namespace

// SL 6.2.2's own example frame: slave 0x11 reads 3 holding registers from
// 0x006B; the CRC goes low byte first: 76 87.
TEST(AmplifierWire, TheSerialLineCrcOfThePublishedFrame) {
  const Bytes frame{0x11, 0x03, 0x00, 0x6B, 0x00, 0x03};
  EXPECT_EQ(sim::serial_line_crc(frame), 0x8776);
  // AP 6.3's reply to it, framed: address, PDU, CRC 0xBAC8 low byte first;
  // a corrupted CRC has its high byte inverted.
  const Bytes pdu{0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64};
  EXPECT_EQ(encoded([&](auto out) { return sim::frame_rtu_reply(0x11, pdu, false, out); }),
            Bytes({0x11, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64, 0xC8, 0xBA}));
  EXPECT_EQ(encoded([&](auto out) { return sim::frame_rtu_reply(0x11, pdu, true, out); }),
            Bytes({0x11, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64, 0xC8, 0x45}));
}

// AP 6.17's example: read 6 from 0x0003, write 3 (00FF each) at 0x000E.
TEST(AmplifierWire, ARequestIsReadAsTheSpecLaysItOut) {
  sim::Request r;
  ASSERT_EQ(
      decode({0x17, 0x00, 0x03, 0x00, 0x06, 0x00, 0x0E, 0x00, 0x03, 0x06, 0x00, 0xFF, 0x00, 0xFF, 0x00, 0xFF},
             r),
      sim::exception::none);
  EXPECT_EQ(r.read_address, 0x0003);
  EXPECT_EQ(r.read_quantity, 6);
  EXPECT_EQ(r.write_address, 0x000E);
  EXPECT_EQ(r.write_quantity, 3);
  EXPECT_EQ(r.values[2], 0x00FF);
  // AP 6.12: write 2 registers at 0x0001: 000A, 0102.
  ASSERT_EQ(decode({0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02}, r), sim::exception::none);
  EXPECT_EQ(r.write_quantity, 2);
  EXPECT_EQ(r.values[1], 0x0102);
  // AP 6.5: coil 0x00AC on.
  ASSERT_EQ(decode({0x05, 0x00, 0xAC, 0xFF, 0x00}, r), sim::exception::none);
  EXPECT_EQ(r.values[0], 0xFF00);
}

// The state diagrams of AP 6.x: 01 before anything else, then 03.
TEST(AmplifierWire, RequestsOutsideTheSpecGetTheirExceptionCode) {
  sim::Request r;
  EXPECT_EQ(decode({0x2B, 0x0E, 0x01, 0x00}, r), sim::exception::illegal_function);          // not served
  EXPECT_EQ(decode({0x03, 0x00, 0x00, 0x00, 0x00}, r), sim::exception::illegal_data_value);  // 0 registers
  EXPECT_EQ(decode({0x03, 0x00, 0x00, 0x00, 0x7E}, r), sim::exception::illegal_data_value);  // 126 > 125
  EXPECT_EQ(decode({0x03, 0x00, 0x00, 0x00, 0x7D}, r), sim::exception::none);                // 125
  EXPECT_EQ(decode({0x05, 0x00, 0x01, 0x12, 0x34}, r), sim::exception::illegal_data_value);  // not FF00/0000
  EXPECT_EQ(decode({0x10, 0x00, 0x01, 0x00, 0x02, 0x03, 0x00, 0x0A, 0x01}, r),
            sim::exception::illegal_data_value);  // byte count 3 for 2 registers
  EXPECT_EQ(decode({0x17, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x7A, 0xF4}, r),
            sim::exception::illegal_data_value);  // 122 > 121 to write
  EXPECT_EQ(encoded([](auto out) { return sim::encode_exception_reply(0x03, 0x02, out); }),
            Bytes({0x83, 0x02}));
}

// TCP 3.1.3: the reply's MBAP header copies the transaction and unit ids;
// the length counts the unit id and the PDU.
TEST(AmplifierWire, ATcpReplyCarriesTheRequestsIds) {
  const Bytes request{0x12, 0x34, 0x00, 0x00, 0x00, 0x06, 0x07, 0x03, 0x00, 0x00, 0x00, 0x01};
  const Bytes pdu{0x03, 0x02, 0x00, 0x0A};
  EXPECT_EQ(encoded([&](auto out) { return sim::frame_tcp_reply(request, pdu, out); }),
            Bytes({0x12, 0x34, 0x00, 0x00, 0x00, 0x05, 0x07, 0x03, 0x02, 0x00, 0x0A}));
}

// The amplifier refuses what reaches past its 64 registers or 16 coils
// (exception 02) and applies nothing of it.
TEST(AmplifierWire, AnAddressOutsideTheTablesIsRefusedAndNotApplied) {
  hapticd::drivers::modbus::testing::LoopbackPlant plant;
  sim::AmplifierSettings s;
  s.position_per_count = 1e-3;
  sim::Amplifier amplifier(s, plant);
  std::array<std::uint16_t, 64> holding{}, input{};
  std::array<std::uint8_t, 16> coils{};
  amplifier.bind(holding, input, coils);
  const Bytes past_the_end{0x10, 0x00, 0x3F, 0x00, 0x02, 0x04, 0x00, 0x01, 0x00, 0x02};  // 63 and 64
  const sim::Decision d = amplifier.on_request(past_the_end, 0.0);
  EXPECT_EQ(d.kind, sim::Decision::Kind::exception);
  EXPECT_EQ(d.exception_code, sim::exception::illegal_data_address);
  EXPECT_EQ(holding[63], 0);
  EXPECT_EQ(amplifier.on_request(Bytes{0x05, 0x00, 0x10, 0xFF, 0x00}, 0.0).exception_code,
            sim::exception::illegal_data_address);  // coil 16
  EXPECT_EQ(amplifier.on_request(Bytes{0x04, 0x00, 0x3F, 0x00, 0x01}, 0.0).kind,
            sim::Decision::Kind::reply);  // input register 63: the last one
}

}  // namespace amplifier_wire_test
