#pragma once
/// \file
/// The simulated amplifier's own reading and writing of the wire, from the
/// published specifications, not from the driver's codec (modbus_frame.*):
/// a misreading of the standard on either side then fails the tests
/// instead of passing both ends.
///
/// - Modbus Application Protocol Specification V1.1b3 ("AP"): the request
///   PDUs the amplifier serves, 0x03 read holding registers (6.3), 0x04 read
///   input registers (6.4), 0x05 write single coil (6.5), 0x06 write single
///   register (6.6), 0x10 write multiple registers (6.12), 0x17 read/write
///   multiple registers (6.17); their replies; exception replies (7):
///   function | 0x80, then the code, 01 illegal function, 02 illegal data
///   address, 03 illegal data value, 04 server device failure.
/// - Modbus over Serial Line V1.02 ("SL"): the RTU reply, address + PDU +
///   CRC-16 low byte first (2.5.1, 6.2.2).
/// - Modbus Messaging on TCP/IP V1.0b ("TCP"): the MBAP header of a reply
///   (3.1.3: the transaction and unit ids copied from the request, protocol
///   id 0, length = unit id + PDU).
///
/// Pure code: no allocation, no system call.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace hapticd::drivers::modbus::sim {

namespace function {
inline constexpr std::uint8_t read_holding = 0x03;
inline constexpr std::uint8_t read_input = 0x04;
inline constexpr std::uint8_t write_coil = 0x05;
inline constexpr std::uint8_t write_register = 0x06;
inline constexpr std::uint8_t write_registers = 0x10;
inline constexpr std::uint8_t read_write_registers = 0x17;
inline constexpr std::uint8_t exception_bit = 0x80;
}  // namespace function

namespace exception {
inline constexpr std::uint8_t none = 0x00;
inline constexpr std::uint8_t illegal_function = 0x01;
inline constexpr std::uint8_t illegal_data_address = 0x02;
inline constexpr std::uint8_t illegal_data_value = 0x03;
inline constexpr std::uint8_t server_device_failure = 0x04;
}  // namespace exception

/// The largest PDU (SL 2.5.1: 256 bytes less the address and the CRC).
inline constexpr std::size_t max_pdu_bytes = 253;
/// The largest reply frame: the 7-byte MBAP header and a PDU (TCP 3.1.3).
inline constexpr std::size_t max_reply_bytes = 7 + max_pdu_bytes;

/// One request as AP 6.3-6.17 lay it out. `values` holds the registers to
/// write (0x06: one, 0x10: up to 123, 0x17: up to 121) or, for 0x05, the
/// coil's output value (0xFF00 on, 0x0000 off).
struct Request {
  std::uint8_t function = 0;
  std::uint16_t read_address = 0, read_quantity = 0;    ///< 0x03, 0x04, 0x17
  std::uint16_t write_address = 0, write_quantity = 0;  ///< 0x05, 0x06 (1), 0x10, 0x17
  std::array<std::uint16_t, 123> values{};
  bool reads() const noexcept { return read_quantity > 0; }
  bool writes_registers() const noexcept {
    return function == function::write_register || function == function::write_registers ||
           function == function::read_write_registers;
  }
};

/// Decodes a request PDU. Returns exception::none, or the exception the
/// function's state diagram gives before any address is looked at: 01 for a
/// function the amplifier does not serve, 03 for a quantity out of the
/// function's range, a byte count that is not twice the quantity, a coil
/// value other than FF00/0000, or a PDU of the wrong length.
std::uint8_t decode_request(std::span<const std::uint8_t> pdu, Request& out) noexcept;

// ---- reply PDUs, into `out`; each returns the bytes written ----

/// 0x03, 0x04, 0x17: function, byte count, the registers high byte first.
std::size_t encode_read_reply(std::uint8_t function, std::span<const std::uint16_t> registers,
                              std::span<std::uint8_t> out) noexcept;
/// 0x05, 0x06: the request echoed.
std::size_t encode_echo_reply(std::span<const std::uint8_t> request, std::span<std::uint8_t> out) noexcept;
/// 0x10: function, starting address, quantity.
std::size_t encode_write_registers_reply(std::uint16_t address, std::uint16_t quantity,
                                         std::span<std::uint8_t> out) noexcept;
/// Function | 0x80, the exception code.
std::size_t encode_exception_reply(std::uint8_t function, std::uint8_t code,
                                   std::span<std::uint8_t> out) noexcept;

// ---- reply frames ----

/// CRC-16 of SL 6.2.2 (polynomial 0xA001 reflected, preset 0xFFFF).
std::uint16_t serial_line_crc(std::span<const std::uint8_t> bytes) noexcept;
/// SL 2.5.1: the request's address, the PDU, the CRC low byte first; with
/// `corrupt_crc` the CRC's high byte is inverted (a line fault).
std::size_t frame_rtu_reply(std::uint8_t address, std::span<const std::uint8_t> pdu, bool corrupt_crc,
                            std::span<std::uint8_t> out) noexcept;
/// TCP 3.1.3: the MBAP header of `request_adu` (its first 7 bytes) with the
/// reply's length, then the PDU.
std::size_t frame_tcp_reply(std::span<const std::uint8_t> request_adu, std::span<const std::uint8_t> pdu,
                            std::span<std::uint8_t> out) noexcept;

}  // namespace hapticd::drivers::modbus::sim
