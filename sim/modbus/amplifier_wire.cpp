#include "sim/modbus/amplifier_wire.hpp"

namespace hapticd::drivers::modbus::sim {

namespace {

std::uint16_t big_endian(std::span<const std::uint8_t> pdu, std::size_t at) noexcept {
  return static_cast<std::uint16_t>((pdu[at] << 8) | pdu[at + 1]);
}

void put_big_endian(std::span<std::uint8_t> out, std::size_t at, std::uint16_t value) noexcept {
  out[at] = static_cast<std::uint8_t>(value >> 8);
  out[at + 1] = static_cast<std::uint8_t>(value & 0xFFu);
}

// AP 6.3, 6.4: function, starting address, quantity of registers 1..125 (0x7D).
std::uint8_t decode_read(std::span<const std::uint8_t> pdu, Request& out) noexcept {
  if (pdu.size() != 5) return exception::illegal_data_value;
  out.read_address = big_endian(pdu, 1);
  out.read_quantity = big_endian(pdu, 3);
  if (out.read_quantity < 1 || out.read_quantity > 0x7D) return exception::illegal_data_value;
  return exception::none;
}

// AP 6.5: function, output address, output value FF00 (on) or 0000 (off);
// AP 6.6: function, register address, register value.
std::uint8_t decode_write_single(std::span<const std::uint8_t> pdu, Request& out) noexcept {
  if (pdu.size() != 5) return exception::illegal_data_value;
  out.write_address = big_endian(pdu, 1);
  out.write_quantity = 1;
  out.values[0] = big_endian(pdu, 3);
  if (out.function == function::write_coil && out.values[0] != 0xFF00 && out.values[0] != 0x0000)
    return exception::illegal_data_value;
  return exception::none;
}

// The values of a multiple write: `quantity` registers after a byte count
// that must be 2 x quantity, ending the PDU (AP 6.12, 6.17).
std::uint8_t decode_values(std::span<const std::uint8_t> pdu, std::size_t count_at, std::uint16_t quantity,
                           Request& out) noexcept {
  if (pdu.size() <= count_at || pdu[count_at] != 2u * quantity ||
      pdu.size() != count_at + 1 + std::size_t{2} * quantity)
    return exception::illegal_data_value;
  for (std::size_t i = 0; i < quantity; ++i) out.values[i] = big_endian(pdu, count_at + 1 + 2 * i);
  return exception::none;
}

// AP 6.12: function, starting address, quantity 1..123 (0x7B), byte count, values.
std::uint8_t decode_write_multiple(std::span<const std::uint8_t> pdu, Request& out) noexcept {
  if (pdu.size() < 6) return exception::illegal_data_value;
  out.write_address = big_endian(pdu, 1);
  out.write_quantity = big_endian(pdu, 3);
  if (out.write_quantity < 1 || out.write_quantity > 0x7B) return exception::illegal_data_value;
  return decode_values(pdu, 5, out.write_quantity, out);
}

// AP 6.17: function, read starting address, quantity to read 1..125 (0x7D),
// write starting address, quantity to write 1..121 (0x79), byte count, values.
std::uint8_t decode_read_write(std::span<const std::uint8_t> pdu, Request& out) noexcept {
  if (pdu.size() < 10) return exception::illegal_data_value;
  out.read_address = big_endian(pdu, 1);
  out.read_quantity = big_endian(pdu, 3);
  out.write_address = big_endian(pdu, 5);
  out.write_quantity = big_endian(pdu, 7);
  if (out.read_quantity < 1 || out.read_quantity > 0x7D || out.write_quantity < 1 ||
      out.write_quantity > 0x79)
    return exception::illegal_data_value;
  return decode_values(pdu, 9, out.write_quantity, out);
}

}  // namespace

std::uint8_t decode_request(std::span<const std::uint8_t> pdu, Request& out) noexcept {
  out = Request{};
  if (pdu.empty()) return exception::illegal_function;
  out.function = pdu[0];
  switch (out.function) {
    case function::read_holding:
    case function::read_input:
      return decode_read(pdu, out);
    case function::write_coil:
    case function::write_register:
      return decode_write_single(pdu, out);
    case function::write_registers:
      return decode_write_multiple(pdu, out);
    case function::read_write_registers:
      return decode_read_write(pdu, out);
    default:
      return exception::illegal_function;
  }
}

std::size_t encode_read_reply(std::uint8_t function, std::span<const std::uint16_t> registers,
                              std::span<std::uint8_t> out) noexcept {
  const std::size_t size = 2 + 2 * registers.size();
  if (registers.size() > 0x7D || out.size() < size) return 0;
  out[0] = function;
  out[1] = static_cast<std::uint8_t>(2 * registers.size());
  for (std::size_t i = 0; i < registers.size(); ++i) put_big_endian(out, 2 + 2 * i, registers[i]);
  return size;
}

std::size_t encode_echo_reply(std::span<const std::uint8_t> request, std::span<std::uint8_t> out) noexcept {
  if (out.size() < request.size()) return 0;
  for (std::size_t i = 0; i < request.size(); ++i) out[i] = request[i];
  return request.size();
}

std::size_t encode_write_registers_reply(std::uint16_t address, std::uint16_t quantity,
                                         std::span<std::uint8_t> out) noexcept {
  if (out.size() < 5) return 0;
  out[0] = function::write_registers;
  put_big_endian(out, 1, address);
  put_big_endian(out, 3, quantity);
  return 5;
}

std::size_t encode_exception_reply(std::uint8_t function, std::uint8_t code,
                                   std::span<std::uint8_t> out) noexcept {
  if (out.size() < 2) return 0;
  out[0] = static_cast<std::uint8_t>(function | function::exception_bit);
  out[1] = code;
  return 2;
}

std::uint16_t serial_line_crc(std::span<const std::uint8_t> bytes) noexcept {
  std::uint16_t crc = 0xFFFF;
  for (const std::uint8_t byte : bytes) {
    crc ^= byte;
    for (int bit = 0; bit < 8; ++bit) crc = (crc & 1u) != 0 ? (crc >> 1) ^ 0xA001u : crc >> 1;
  }
  return crc;
}

std::size_t frame_rtu_reply(std::uint8_t address, std::span<const std::uint8_t> pdu, bool corrupt_crc,
                            std::span<std::uint8_t> out) noexcept {
  const std::size_t size = 1 + pdu.size() + 2;
  if (pdu.size() > max_pdu_bytes || out.size() < size) return 0;
  out[0] = address;
  for (std::size_t i = 0; i < pdu.size(); ++i) out[1 + i] = pdu[i];
  const std::uint16_t crc = serial_line_crc(out.first(1 + pdu.size()));
  out[size - 2] = static_cast<std::uint8_t>(crc & 0xFFu);  // low byte first
  out[size - 1] = static_cast<std::uint8_t>(crc >> 8);
  if (corrupt_crc) out[size - 1] ^= 0xFFu;
  return size;
}

std::size_t frame_tcp_reply(std::span<const std::uint8_t> request_adu, std::span<const std::uint8_t> pdu,
                            std::span<std::uint8_t> out) noexcept {
  const std::size_t size = 7 + pdu.size();
  if (request_adu.size() < 7 || pdu.size() > max_pdu_bytes || out.size() < size) return 0;
  out[0] = request_adu[0];  // transaction identifier, copied
  out[1] = request_adu[1];
  put_big_endian(out, 2, 0);  // protocol identifier: Modbus
  put_big_endian(out, 4, static_cast<std::uint16_t>(1 + pdu.size()));
  out[6] = request_adu[6];  // unit identifier, copied
  for (std::size_t i = 0; i < pdu.size(); ++i) out[7 + i] = pdu[i];
  return size;
}

}  // namespace hapticd::drivers::modbus::sim
