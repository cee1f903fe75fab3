// libFuzzer target: the Modbus frame codec (drivers/modbus/modbus_frame.hpp)
// on what an amplifier or a client could put on the wire. The input is
// read as a whole RTU frame, a whole TCP frame and a PDU; the PDU is also
// framed both ways (so the CRC and the MBAP length are right and the
// parsers get past them) and parsed back. Must hold: nothing crashes or
// reads out of bounds; framing round-trips (unit, transaction, the same
// PDU bytes); a request the server side accepts builds back to the same
// PDU; a register-read response accepted names no more registers than the
// PDU carries. Seeds: the frames of tests/drivers/modbus/frame_test.cpp
// (fuzz/seeds/).
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "drivers/modbus/modbus_frame.hpp"

namespace {

namespace mb = hapticd::drivers::modbus;

void require(bool holds) {
  if (!holds) __builtin_trap();
}

bool same(std::span<const std::uint8_t> a, std::span<const std::uint8_t> b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end());
}

// A request the server accepted, built again from its fields (V1.1b3 6.3,
// 6.4, 6.5, 6.6, 6.12, 6.17): the same bytes, or the parser read something
// the builders would never send.
void check_request_round_trip(std::span<const std::uint8_t> pdu, const mb::RegisterRequest& r) {
  std::array<std::uint16_t, 128> values{};
  const std::size_t writes = std::min<std::size_t>(r.write_count, values.size());
  for (std::size_t i = 0; i < writes; ++i) values[i] = r.write_value(i);
  std::array<std::uint8_t, mb::limits::max_pdu + 8> out{};
  std::size_t n = 0;
  switch (r.function) {
    case 3:
    case 4:
      n = mb::build_read_registers_request(out, r.function, r.read_address, r.read_count);
      break;
    case 6:
      n = mb::build_write_single_register_request(out, r.write_address, r.write_value(0));
      break;
    case 16:
      n = mb::build_write_multiple_request(out, r.write_address, std::span(values).first(writes));
      break;
    case 23:
      n = mb::build_write_and_read_request(out, r.read_address, r.read_count, r.write_address,
                                           std::span(values).first(writes));
      break;
    default:
      return;  // fc 5: FF00/0000 only, checked by the parser itself
  }
  require(same(std::span(out).first(n), pdu));
}

void check_pdu(std::span<const std::uint8_t> pdu) {
  mb::RegisterRequest request;
  if (mb::parse_request(pdu, request) == mb::PduStatus::ok) check_request_round_trip(pdu, request);
  if (pdu.empty()) return;
  std::array<std::uint16_t, 125> values{};  // fc 3/4 carry at most 125 registers
  std::uint8_t exception = 0;
  for (std::size_t count : {std::size_t{1}, std::size_t{8}, values.size()}) {
    if (mb::parse_read_response(pdu, pdu[0], std::span(values).first(count), exception) == mb::PduStatus::ok)
      require(pdu.size() >= 2 + 2 * count);
  }
  (void)mb::parse_write_multiple_response(pdu, 0, 1, exception);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> input(data, size);
  // The bytes as whole frames, as a link reads them.
  if (const auto rtu = mb::parse_rtu_adu(input); rtu.status == mb::AduStatus::ok) check_pdu(rtu.pdu);
  if (const auto tcp = mb::parse_tcp_adu(input); tcp.status == mb::AduStatus::ok) check_pdu(tcp.pdu);
  if (size > mb::limits::max_pdu) return 0;
  // The bytes as a PDU, framed both ways and parsed back.
  std::array<std::uint8_t, mb::limits::max_pdu + 16> frame{};
  const std::size_t rtu_size = mb::build_rtu_adu(frame, 0x11, input);
  const auto rtu = mb::parse_rtu_adu(std::span(frame).first(rtu_size));
  if (size > 0) {
    require(rtu.status == mb::AduStatus::ok && rtu.unit == 0x11 && same(rtu.pdu, input));
  }
  const std::size_t tcp_size = mb::build_tcp_adu(frame, 0xBEEF, 0x22, input);
  const auto tcp = mb::parse_tcp_adu(std::span(frame).first(tcp_size));
  if (size > 0) {
    require(tcp.status == mb::AduStatus::ok && tcp.unit == 0x22 && tcp.transaction == 0xBEEF &&
            same(tcp.pdu, input));
  }
  check_pdu(input);
  return 0;
}
