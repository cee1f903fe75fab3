#include "drivers/modbus/modbus_frame.hpp"

#include <algorithm>

namespace hapticd::drivers::modbus {

namespace {

void put16(std::span<std::uint8_t> out, std::size_t at, std::uint16_t value) noexcept {
  out[at] = static_cast<std::uint8_t>(value >> 8);  // big-endian (V1.1b3 4.2)
  out[at + 1] = static_cast<std::uint8_t>(value & 0xFF);
}

std::uint16_t get16(std::span<const std::uint8_t> in, std::size_t at) noexcept {
  return static_cast<std::uint16_t>((in[at] << 8) | in[at + 1]);
}

void put_registers(std::span<std::uint8_t> out, std::size_t at,
                   std::span<const std::uint16_t> values) noexcept {
  for (std::size_t i = 0; i < values.size(); ++i) put16(out, at + 2 * i, values[i]);
}

bool in_range(std::size_t count, int max) noexcept {
  return count >= 1 && count <= static_cast<std::size_t>(max);
}

}  // namespace

std::string_view exception_name(std::uint8_t code) noexcept {
  switch (code) {
    case exception_code::illegal_function:
      return "illegal function";
    case exception_code::illegal_data_address:
      return "illegal data address";
    case exception_code::illegal_data_value:
      return "illegal data value";
    case exception_code::server_device_failure:
      return "server device failure";
    case exception_code::acknowledge:
      return "acknowledge";
    case exception_code::server_device_busy:
      return "server device busy";
    case exception_code::memory_parity_error:
      return "memory parity error";
    case exception_code::gateway_path_unavailable:
      return "gateway path unavailable";
    case exception_code::gateway_target_failed:
      return "gateway target device failed to respond";
    default:
      return "unknown exception";
  }
}

bool exception_is_transient(std::uint8_t code) noexcept {
  return code == exception_code::acknowledge || code == exception_code::server_device_busy;
}

std::uint16_t crc16(std::span<const std::uint8_t> bytes) noexcept {
  std::uint16_t crc = 0xFFFF;
  for (std::uint8_t b : bytes) {
    crc ^= b;
    for (int bit = 0; bit < 8; ++bit)
      crc = (crc & 1u) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001u) : crc >> 1;
  }
  return crc;
}

std::size_t build_read_registers_request(std::span<std::uint8_t> out, std::uint8_t function,
                                         std::uint16_t address, std::uint16_t count) noexcept {
  if (function != function_code::read_holding_registers && function != function_code::read_input_registers)
    return 0;
  if (!in_range(count, limits::read_registers) || out.size() < 5) return 0;
  out[0] = function;
  put16(out, 1, address);
  put16(out, 3, count);
  return 5;
}

std::size_t build_read_registers_response(std::span<std::uint8_t> out, std::uint8_t function,
                                          std::span<const std::uint16_t> values) noexcept {
  if (!in_range(values.size(), limits::read_registers) || out.size() < 2 + 2 * values.size()) return 0;
  out[0] = function;
  out[1] = static_cast<std::uint8_t>(2 * values.size());
  put_registers(out, 2, values);
  return 2 + 2 * values.size();
}

std::size_t build_write_single_coil_request(std::span<std::uint8_t> out, std::uint16_t address,
                                            bool on) noexcept {
  if (out.size() < 5) return 0;
  out[0] = function_code::write_single_coil;
  put16(out, 1, address);
  put16(out, 3, on ? 0xFF00 : 0x0000);  // 6.5: FF 00 is ON, 00 00 is OFF
  return 5;
}

std::size_t build_write_single_register_request(std::span<std::uint8_t> out, std::uint16_t address,
                                                std::uint16_t value) noexcept {
  if (out.size() < 5) return 0;
  out[0] = function_code::write_single_register;
  put16(out, 1, address);
  put16(out, 3, value);
  return 5;
}

std::size_t build_write_multiple_request(std::span<std::uint8_t> out, std::uint16_t address,
                                         std::span<const std::uint16_t> values) noexcept {
  if (!in_range(values.size(), limits::write_registers) || out.size() < 6 + 2 * values.size()) return 0;
  out[0] = function_code::write_multiple_registers;
  put16(out, 1, address);
  put16(out, 3, static_cast<std::uint16_t>(values.size()));
  out[5] = static_cast<std::uint8_t>(2 * values.size());
  put_registers(out, 6, values);
  return 6 + 2 * values.size();
}

std::size_t build_write_multiple_response(std::span<std::uint8_t> out, std::uint16_t address,
                                          std::uint16_t count) noexcept {
  if (!in_range(count, limits::write_registers) || out.size() < 5) return 0;
  out[0] = function_code::write_multiple_registers;
  put16(out, 1, address);
  put16(out, 3, count);
  return 5;
}

std::size_t build_write_and_read_request(std::span<std::uint8_t> out, std::uint16_t read_address,
                                         std::uint16_t read_count, std::uint16_t write_address,
                                         std::span<const std::uint16_t> values) noexcept {
  if (!in_range(read_count, limits::write_and_read_read) ||
      !in_range(values.size(), limits::write_and_read_write))
    return 0;
  if (out.size() < 10 + 2 * values.size()) return 0;
  // 6.17: read starting address and quantity come first, then the write part.
  out[0] = function_code::write_and_read_registers;
  put16(out, 1, read_address);
  put16(out, 3, read_count);
  put16(out, 5, write_address);
  put16(out, 7, static_cast<std::uint16_t>(values.size()));
  out[9] = static_cast<std::uint8_t>(2 * values.size());
  put_registers(out, 10, values);
  return 10 + 2 * values.size();
}

std::size_t build_write_and_read_response(std::span<std::uint8_t> out,
                                          std::span<const std::uint16_t> values) noexcept {
  if (!in_range(values.size(), limits::write_and_read_read)) return 0;
  return build_read_registers_response(out, function_code::write_and_read_registers, values);
}

std::size_t build_exception_response(std::span<std::uint8_t> out, std::uint8_t function,
                                     std::uint8_t code) noexcept {
  if (out.size() < 2 || function >= function_code::exception_flag) return 0;
  out[0] = static_cast<std::uint8_t>(function | function_code::exception_flag);
  out[1] = code;
  return 2;
}

std::size_t build_rtu_adu(std::span<std::uint8_t> out, std::uint8_t slave,
                          std::span<const std::uint8_t> pdu) noexcept {
  if (pdu.empty() || pdu.size() > limits::max_pdu || out.size() < pdu.size() + 3) return 0;
  out[0] = slave;
  for (std::size_t i = 0; i < pdu.size(); ++i) out[1 + i] = pdu[i];
  const std::uint16_t crc = crc16(out.first(1 + pdu.size()));
  out[1 + pdu.size()] = static_cast<std::uint8_t>(crc & 0xFF);  // low byte first (6.2.2)
  out[2 + pdu.size()] = static_cast<std::uint8_t>(crc >> 8);
  return pdu.size() + 3;
}

std::size_t build_tcp_adu(std::span<std::uint8_t> out, std::uint16_t transaction, std::uint8_t unit,
                          std::span<const std::uint8_t> pdu) noexcept {
  if (pdu.empty() || pdu.size() > limits::max_pdu || out.size() < pdu.size() + 7) return 0;
  put16(out, 0, transaction);
  put16(out, 2, 0);                                           // protocol identifier: 0 = Modbus
  put16(out, 4, static_cast<std::uint16_t>(pdu.size() + 1));  // unit id + PDU
  out[6] = unit;
  for (std::size_t i = 0; i < pdu.size(); ++i) out[7 + i] = pdu[i];
  return pdu.size() + 7;
}

Adu parse_rtu_adu(std::span<const std::uint8_t> frame) noexcept {
  Adu adu;
  if (frame.size() < 4) return adu;  // address, function, 2 CRC bytes
  const std::size_t body = frame.size() - 2;
  const std::uint16_t received = static_cast<std::uint16_t>(frame[body] | (frame[body + 1] << 8));
  adu.unit = frame[0];
  adu.pdu = frame.subspan(1, body - 1);
  adu.status = crc16(frame.first(body)) == received ? AduStatus::ok : AduStatus::bad_crc;
  return adu;
}

Adu parse_tcp_adu(std::span<const std::uint8_t> frame) noexcept {
  Adu adu;
  if (frame.size() < 8) return adu;
  adu.transaction = get16(frame, 0);
  adu.unit = frame[6];
  if (get16(frame, 2) != 0) {
    adu.status = AduStatus::bad_protocol;
    return adu;
  }
  if (get16(frame, 4) != frame.size() - 6) {
    adu.status = AduStatus::bad_length;
    return adu;
  }
  adu.pdu = frame.subspan(7);
  adu.status = AduStatus::ok;
  return adu;
}

std::size_t tcp_adu_length(std::span<const std::uint8_t> stream, bool& invalid) noexcept {
  invalid = false;
  if (stream.size() < 7) return 0;
  const std::uint16_t length = get16(stream, 4);  // unit id + PDU
  if (get16(stream, 2) != 0 || length < 2 || length > limits::max_pdu + 1) {
    invalid = true;
    return 0;
  }
  const std::size_t size = std::size_t{6} + length;
  return stream.size() >= size ? size : 0;
}

std::uint16_t RegisterRequest::write_value(std::size_t i) const noexcept { return get16(write_data, 2 * i); }

PduStatus parse_request(std::span<const std::uint8_t> pdu, RegisterRequest& out) noexcept {
  out = RegisterRequest{};
  if (pdu.empty()) return PduStatus::malformed;
  out.function = pdu[0];
  switch (out.function) {
    case function_code::read_holding_registers:
    case function_code::read_input_registers:
      if (pdu.size() != 5) return PduStatus::malformed;
      out.read_address = get16(pdu, 1);
      out.read_count = get16(pdu, 3);
      return in_range(out.read_count, limits::read_registers) ? PduStatus::ok : PduStatus::bad_quantity;
    case function_code::write_single_coil:
    case function_code::write_single_register:
      if (pdu.size() != 5) return PduStatus::malformed;
      out.write_address = get16(pdu, 1);
      out.write_count = 1;
      out.write_data = pdu.subspan(3, 2);
      if (out.function == function_code::write_single_coil && out.write_value(0) != 0xFF00 &&
          out.write_value(0) != 0x0000)
        return PduStatus::bad_quantity;  // 6.5: any other value is illegal (exception 03)
      return PduStatus::ok;
    case function_code::write_multiple_registers: {
      if (pdu.size() < 6) return PduStatus::malformed;
      out.write_address = get16(pdu, 1);
      out.write_count = get16(pdu, 3);
      const std::size_t bytes = pdu[5];
      if (!in_range(out.write_count, limits::write_registers) || bytes != std::size_t{2} * out.write_count)
        return PduStatus::bad_quantity;
      if (pdu.size() != 6 + bytes) return PduStatus::malformed;
      out.write_data = pdu.subspan(6, bytes);
      return PduStatus::ok;
    }
    case function_code::write_and_read_registers: {
      if (pdu.size() < 10) return PduStatus::malformed;
      out.read_address = get16(pdu, 1);
      out.read_count = get16(pdu, 3);
      out.write_address = get16(pdu, 5);
      out.write_count = get16(pdu, 7);
      const std::size_t bytes = pdu[9];
      if (!in_range(out.read_count, limits::write_and_read_read) ||
          !in_range(out.write_count, limits::write_and_read_write) ||
          bytes != std::size_t{2} * out.write_count)
        return PduStatus::bad_quantity;
      if (pdu.size() != 10 + bytes) return PduStatus::malformed;
      out.write_data = pdu.subspan(10, bytes);
      return PduStatus::ok;
    }
    default:
      return PduStatus::unsupported;
  }
}

PduStatus parse_read_response(std::span<const std::uint8_t> pdu, std::uint8_t function,
                              std::span<std::uint16_t> values, std::uint8_t& exception) noexcept {
  exception = 0;
  if (pdu.size() < 2) return PduStatus::malformed;
  if (pdu[0] == (function | function_code::exception_flag)) {
    if (pdu.size() != 2) return PduStatus::malformed;
    exception = pdu[1];
    return PduStatus::exception;
  }
  if (pdu[0] != function) return PduStatus::wrong_function;
  const std::size_t bytes = pdu[1];
  if (bytes != 2 * values.size() || pdu.size() != 2 + bytes) return PduStatus::malformed;
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = get16(pdu, 2 + 2 * i);
  return PduStatus::ok;
}

PduStatus parse_write_multiple_response(std::span<const std::uint8_t> pdu, std::uint16_t address,
                                        std::uint16_t count, std::uint8_t& exception) noexcept {
  exception = 0;
  if (pdu.size() < 2) return PduStatus::malformed;
  if (pdu[0] == (function_code::write_multiple_registers | function_code::exception_flag)) {
    if (pdu.size() != 2) return PduStatus::malformed;
    exception = pdu[1];
    return PduStatus::exception;
  }
  if (pdu[0] != function_code::write_multiple_registers) return PduStatus::wrong_function;
  if (pdu.size() != 5 || get16(pdu, 1) != address || get16(pdu, 3) != count) return PduStatus::malformed;
  return PduStatus::ok;
}

PduStatus parse_echo_response(std::span<const std::uint8_t> pdu, std::span<const std::uint8_t> request,
                              std::uint8_t& exception) noexcept {
  exception = 0;
  if (pdu.size() < 2 || request.empty()) return PduStatus::malformed;
  if (pdu[0] == (request[0] | function_code::exception_flag)) {
    if (pdu.size() != 2) return PduStatus::malformed;
    exception = pdu[1];
    return PduStatus::exception;
  }
  if (pdu[0] != request[0]) return PduStatus::wrong_function;
  if (!std::equal(pdu.begin(), pdu.end(), request.begin(), request.end())) return PduStatus::malformed;
  return PduStatus::ok;
}

}  // namespace hapticd::drivers::modbus
