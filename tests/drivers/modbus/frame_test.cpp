// Modbus frames byte by byte against the published examples: the Modbus
// Application Protocol Specification V1.1b3 (6.3, 6.4, 6.5, 6.6, 6.12,
// 6.17, 7), Modbus over Serial Line V1.02 (6.2.2 CRC) and Modbus Messaging
// on TCP/IP V1.0b (3.1.3 MBAP).
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "drivers/modbus/modbus_frame.hpp"

namespace frame_test {

namespace mb = hapticd::drivers::modbus;
using Bytes = std::vector<std::uint8_t>;

namespace {

Bytes hex(const std::string& text) {
  Bytes out;
  std::istringstream in(text);
  std::string byte;
  while (in >> byte) out.push_back(static_cast<std::uint8_t>(std::stoul(byte, nullptr, 16)));
  return out;
}

template <class Build>
Bytes built(Build build) {
  std::array<std::uint8_t, 300> buffer{};
  const std::size_t n = build(std::span<std::uint8_t>(buffer));
  return Bytes(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n));
}

}  // namespace

TEST(ModbusFrame, ReadHoldingRegistersMatchesSpecExample) {
  // V1.1b3 6.3: read registers 108-110 (address 0x6B, 3 registers).
  EXPECT_EQ(built([](auto out) { return mb::build_read_registers_request(out, 0x03, 0x006B, 3); }),
            hex("03 00 6B 00 03"));
  const std::uint16_t values[] = {0x022B, 0x0000, 0x0064};
  EXPECT_EQ(built([&](auto out) { return mb::build_read_registers_response(out, 0x03, values); }),
            hex("03 06 02 2B 00 00 00 64"));
  std::array<std::uint16_t, 3> parsed{};
  std::uint8_t exception = 0xFF;
  const Bytes rsp = hex("03 06 02 2B 00 00 00 64");
  ASSERT_EQ(mb::parse_read_response(rsp, 0x03, parsed, exception), mb::PduStatus::ok);
  EXPECT_EQ(parsed, (std::array<std::uint16_t, 3>{0x022B, 0x0000, 0x0064}));
  EXPECT_EQ(exception, 0);
}

TEST(ModbusFrame, ReadInputRegistersMatchesSpecExample) {
  // V1.1b3 6.4: read input register 9 (address 0x08).
  EXPECT_EQ(built([](auto out) { return mb::build_read_registers_request(out, 0x04, 0x0008, 1); }),
            hex("04 00 08 00 01"));
  const std::uint16_t value[] = {0x000A};
  EXPECT_EQ(built([&](auto out) { return mb::build_read_registers_response(out, 0x04, value); }),
            hex("04 02 00 0A"));
}

TEST(ModbusFrame, WriteSingleCoilAndRegisterMatchSpecExamples) {
  // V1.1b3 6.5: coil 173 ON; 6.6: register 2 to 0x0003. Both responses echo.
  EXPECT_EQ(built([](auto out) { return mb::build_write_single_coil_request(out, 0x00AC, true); }),
            hex("05 00 AC FF 00"));
  EXPECT_EQ(built([](auto out) { return mb::build_write_single_coil_request(out, 0x00AC, false); }),
            hex("05 00 AC 00 00"));
  EXPECT_EQ(built([](auto out) { return mb::build_write_single_register_request(out, 0x0001, 0x0003); }),
            hex("06 00 01 00 03"));
}

TEST(ModbusFrame, WriteMultipleRegistersMatchesSpecExample) {
  // V1.1b3 6.12: registers 2 and 3 to 0x000A and 0x0102.
  const std::uint16_t values[] = {0x000A, 0x0102};
  EXPECT_EQ(built([&](auto out) { return mb::build_write_multiple_request(out, 0x0001, values); }),
            hex("10 00 01 00 02 04 00 0A 01 02"));
  EXPECT_EQ(built([](auto out) { return mb::build_write_multiple_response(out, 0x0001, 2); }),
            hex("10 00 01 00 02"));
  std::uint8_t exception = 0;
  EXPECT_EQ(mb::parse_write_multiple_response(hex("10 00 01 00 02"), 0x0001, 2, exception),
            mb::PduStatus::ok);
  EXPECT_EQ(mb::parse_write_multiple_response(hex("10 00 02 00 02"), 0x0001, 2, exception),
            mb::PduStatus::malformed);
}

TEST(ModbusFrame, WriteAndReadRegistersMatchesSpecExample) {
  // V1.1b3 6.17: read 6 registers from address 3 (register 4), write 3
  // registers 0x00FF at address 0x0E (register 15). The read part comes
  // first in the request; the server writes before it reads.
  const std::uint16_t write[] = {0x00FF, 0x00FF, 0x00FF};
  EXPECT_EQ(built([&](auto out) { return mb::build_write_and_read_request(out, 0x0003, 6, 0x000E, write); }),
            hex("17 00 03 00 06 00 0E 00 03 06 00 FF 00 FF 00 FF"));
  const std::uint16_t read[] = {0x00FE, 0x0ACD, 0x0001, 0x0003, 0x000D, 0x00FF};
  EXPECT_EQ(built([&](auto out) { return mb::build_write_and_read_response(out, read); }),
            hex("17 0C 00 FE 0A CD 00 01 00 03 00 0D 00 FF"));

  mb::RegisterRequest req;
  const Bytes pdu = hex("17 00 03 00 06 00 0E 00 03 06 00 FF 00 FF 00 FF");
  ASSERT_EQ(mb::parse_request(pdu, req), mb::PduStatus::ok);
  EXPECT_EQ(req.function, 0x17);
  EXPECT_EQ(req.read_address, 3);
  EXPECT_EQ(req.read_count, 6);
  EXPECT_EQ(req.write_address, 0x0E);
  EXPECT_EQ(req.write_count, 3);
  EXPECT_EQ(req.write_value(2), 0x00FF);
}

TEST(ModbusFrame, ExceptionResponseMatchesSpecExample) {
  // V1.1b3 7: read coils at a nonexistent address -> 81 02 (illegal data address).
  EXPECT_EQ(built([](auto out) { return mb::build_exception_response(out, 0x01, 0x02); }), hex("81 02"));
  std::array<std::uint16_t, 6> values{};
  std::uint8_t exception = 0;
  EXPECT_EQ(mb::parse_read_response(hex("97 04"), 0x17, values, exception), mb::PduStatus::exception);
  EXPECT_EQ(exception, mb::exception_code::server_device_failure);
  EXPECT_EQ(mb::exception_name(0x02), "illegal data address");
  EXPECT_EQ(mb::exception_name(0x07), "unknown exception");  // 07 is not defined by V1.1b3
  EXPECT_TRUE(mb::exception_is_transient(0x06));
  EXPECT_FALSE(mb::exception_is_transient(0x04));
}

TEST(ModbusFrame, CrcMatchesSerialLineSpecAndPublishedFrames) {
  // Modbus over Serial Line 6.2.2 example: slave 2, function 7 -> CRC 0x1241, sent 41 12.
  EXPECT_EQ(mb::crc16(hex("02 07")), 0x1241);
  // The spec's PDUs addressed to slave 0x11 as RTU frames, as published with their CRC.
  EXPECT_EQ(built([](auto out) { return mb::build_rtu_adu(out, 0x11, hex("03 00 6B 00 03")); }),
            hex("11 03 00 6B 00 03 76 87"));
  EXPECT_EQ(
      built([](auto out) { return mb::build_rtu_adu(out, 0x11, hex("10 00 01 00 02 04 00 0A 01 02")); }),
      hex("11 10 00 01 00 02 04 00 0A 01 02 C6 F0"));
  EXPECT_EQ(built([](auto out) { return mb::build_rtu_adu(out, 0x01, hex("03 00 00 00 0A")); }),
            hex("01 03 00 00 00 0A C5 CD"));
  // Appending a frame's own CRC gives a zero remainder.
  EXPECT_EQ(mb::crc16(hex("11 03 00 6B 00 03 76 87")), 0x0000);
}

TEST(ModbusFrame, RtuAduParsesAndRejectsABadCrc) {
  Bytes frame = hex("11 03 06 02 2B 00 00 00 64");
  const std::uint16_t crc = mb::crc16(frame);
  frame.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  frame.push_back(static_cast<std::uint8_t>(crc >> 8));
  mb::Adu adu = mb::parse_rtu_adu(frame);
  ASSERT_EQ(adu.status, mb::AduStatus::ok);
  EXPECT_EQ(adu.unit, 0x11);
  EXPECT_EQ(Bytes(adu.pdu.begin(), adu.pdu.end()), hex("03 06 02 2B 00 00 00 64"));
  frame.back() ^= 0x01;
  EXPECT_EQ(mb::parse_rtu_adu(frame).status, mb::AduStatus::bad_crc);
  EXPECT_EQ(mb::parse_rtu_adu(hex("11 03 76")).status, mb::AduStatus::too_short);
}

TEST(ModbusFrame, TcpAduHasTheMbapHeader) {
  // Messaging on TCP/IP 3.1.3: transaction id, protocol 0, length = unit id + PDU, unit id.
  EXPECT_EQ(built([](auto out) { return mb::build_tcp_adu(out, 0x0001, 0x11, hex("03 00 6B 00 03")); }),
            hex("00 01 00 00 00 06 11 03 00 6B 00 03"));
  const Bytes rsp = hex("00 01 00 00 00 09 11 03 06 02 2B 00 00 00 64");
  const mb::Adu adu = mb::parse_tcp_adu(rsp);
  ASSERT_EQ(adu.status, mb::AduStatus::ok);
  EXPECT_EQ(adu.transaction, 1);
  EXPECT_EQ(adu.unit, 0x11);
  EXPECT_EQ(adu.pdu.size(), 8u);
  EXPECT_EQ(mb::parse_tcp_adu(hex("00 01 00 01 00 06 11 03 00 6B 00 03")).status,
            mb::AduStatus::bad_protocol);
  EXPECT_EQ(mb::parse_tcp_adu(hex("00 01 00 00 00 07 11 03 00 6B 00 03")).status, mb::AduStatus::bad_length);
}

TEST(ModbusFrame, QuantitiesOutsideTheSpecAreRefused) {
  std::array<std::uint8_t, 300> out{};
  EXPECT_EQ(mb::build_read_registers_request(out, 0x03, 0, 0), 0u);
  EXPECT_EQ(mb::build_read_registers_request(out, 0x03, 0, 125), 5u);
  EXPECT_EQ(mb::build_read_registers_request(out, 0x03, 0, 126), 0u);  // 6.3: 1 to 125
  EXPECT_EQ(mb::build_read_registers_request(out, 0x06, 0, 1), 0u);    // not a read function
  std::vector<std::uint16_t> many(124, 0);
  EXPECT_EQ(mb::build_write_multiple_request(out, 0, many), 0u);  // 6.12: 1 to 123
  many.resize(122);
  EXPECT_EQ(mb::build_write_and_read_request(out, 0, 1, 0, many), 0u);  // 6.17: write 1 to 121
  many.resize(121);
  EXPECT_EQ(mb::build_write_and_read_request(out, 0, 1, 0, many), 10u + 242u);
  EXPECT_EQ(mb::build_write_and_read_request(out, 0, 126, 0, std::span(many).first(1)), 0u);  // read 1 to 125
}

TEST(ModbusFrame, MalformedRequestsAreClassified) {
  mb::RegisterRequest req;
  // Byte count disagrees with the quantity: exception 03 territory.
  EXPECT_EQ(mb::parse_request(hex("10 00 01 00 02 03 00 0A 01"), req), mb::PduStatus::bad_quantity);
  // Byte count right, data short.
  EXPECT_EQ(mb::parse_request(hex("10 00 01 00 02 04 00 0A 01"), req), mb::PduStatus::malformed);
  EXPECT_EQ(mb::parse_request(hex("17 00 03 00 06 00 0E 00 03 04 00 FF 00 FF"), req),
            mb::PduStatus::bad_quantity);
  EXPECT_EQ(mb::parse_request(hex("03 00 6B 00 00"), req), mb::PduStatus::bad_quantity);
  EXPECT_EQ(mb::parse_request(hex("03 00 6B 00"), req), mb::PduStatus::malformed);
  EXPECT_EQ(mb::parse_request(hex("05 00 AC 12 34"), req),
            mb::PduStatus::bad_quantity);  // 6.5: FF00 or 0000 only
  EXPECT_EQ(mb::parse_request(hex("2B 0E 01 00"), req), mb::PduStatus::unsupported);
  std::array<std::uint16_t, 3> values{};
  std::uint8_t exception = 0;
  EXPECT_EQ(mb::parse_read_response(hex("03 04 02 2B 00 00"), 0x03, values, exception),
            mb::PduStatus::malformed);
  EXPECT_EQ(mb::parse_read_response(hex("04 06 02 2B 00 00 00 64"), 0x03, values, exception),
            mb::PduStatus::wrong_function);
}

// TCP 3.1.3: a TCP stream carries ADUs back to back; the MBAP length field
// (unit id + PDU) says where each ends. Two replies in one read, split
// anywhere, are framed one at a time.
TEST(ModbusFrame, TcpStreamIsFramedByTheMbapLength) {
  // Transaction 1: fc 3 reply with one register; transaction 2: exception.
  const Bytes stream = hex("00 01 00 00 00 05 11 03 02 00 0A  00 02 00 00 00 03 11 83 02");
  bool invalid = true;
  for (std::size_t cut = 0; cut < 11; ++cut) {
    EXPECT_EQ(mb::tcp_adu_length(std::span(stream).first(cut), invalid), 0u) << cut;
    EXPECT_FALSE(invalid) << cut;
  }
  EXPECT_EQ(mb::tcp_adu_length(stream, invalid), 11u);
  const auto second = std::span(stream).subspan(11);
  EXPECT_EQ(mb::tcp_adu_length(second.first(8), invalid), 0u);
  EXPECT_EQ(mb::tcp_adu_length(second, invalid), 9u);
  const mb::Adu adu = mb::parse_tcp_adu(second);
  EXPECT_EQ(adu.transaction, 2);
  EXPECT_EQ(Bytes(adu.pdu.begin(), adu.pdu.end()), hex("83 02"));
  // Not Modbus (protocol id 1), or a length no ADU has: out of step.
  EXPECT_EQ(mb::tcp_adu_length(hex("00 01 00 01 00 05 11 03"), invalid), 0u);
  EXPECT_TRUE(invalid);
  EXPECT_EQ(mb::tcp_adu_length(hex("00 01 00 00 00 01 11 03"), invalid), 0u);
  EXPECT_TRUE(invalid);
  EXPECT_EQ(mb::tcp_adu_length(hex("00 01 00 00 00 FF 11 03"), invalid), 0u);  // 255 > 1 + 253
  EXPECT_TRUE(invalid);
}

// 6.5, 6.6: a write-single reply echoes the request.
TEST(ModbusFrame, WriteSingleRepliesEchoTheRequest) {
  const Bytes request = hex("06 00 01 00 03");
  std::uint8_t exception = 0xFF;
  EXPECT_EQ(mb::parse_echo_response(hex("06 00 01 00 03"), request, exception), mb::PduStatus::ok);
  EXPECT_EQ(exception, 0);
  EXPECT_EQ(mb::parse_echo_response(hex("06 00 01 00 04"), request, exception), mb::PduStatus::malformed);
  EXPECT_EQ(mb::parse_echo_response(hex("05 00 01 00 03"), request, exception),
            mb::PduStatus::wrong_function);
  EXPECT_EQ(mb::parse_echo_response(hex("86 02"), request, exception), mb::PduStatus::exception);
  EXPECT_EQ(exception, 0x02);
}

}  // namespace frame_test
