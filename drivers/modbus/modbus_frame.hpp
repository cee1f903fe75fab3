#pragma once
/// \file
/// Modbus frames built and parsed by hand, byte by byte, from the published
/// layouts: the PDUs of the Modbus Application Protocol Specification V1.1b3
/// (6.3 read holding registers, 6.4 read input registers, 6.5 write single
/// coil, 6.6 write single register, 6.12 write multiple registers, 6.17
/// read/write multiple registers, 7 exception responses), the RTU ADU of
/// Modbus over Serial Line V1.02 (2.5.1: address, PDU, CRC-16 low byte
/// first; 6.2.2 the CRC) and the TCP ADU of Modbus Messaging on TCP/IP V1.0b
/// (3.1.3: the 7-byte MBAP header). Pure code: no system calls, no
/// allocation; every builder writes into the caller's buffer and returns the
/// bytes written (0 when the request is out of the spec's range or the
/// buffer is too small).
///
/// libmodbus does the RTU framing on the wire; over TCP the link frames the
/// transactions with these (libmodbus 3.1.6 cannot pair a reply with its
/// request by transaction id, modbus_link.hpp). They also let the tests
/// check libmodbus's frames against the standard and size the RTU budget.
/// The simulated amplifier does not use them: it reads and writes the wire
/// with its own decoder (sim/modbus/amplifier_wire.hpp), so a misreading
/// of the standard here fails against it.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace hapticd::drivers::modbus {

namespace function_code {
inline constexpr std::uint8_t read_holding_registers = 0x03;
inline constexpr std::uint8_t read_input_registers = 0x04;
inline constexpr std::uint8_t write_single_coil = 0x05;
inline constexpr std::uint8_t write_single_register = 0x06;
inline constexpr std::uint8_t write_multiple_registers = 0x10;
inline constexpr std::uint8_t write_and_read_registers = 0x17;
inline constexpr std::uint8_t exception_flag = 0x80;
}  // namespace function_code

/// Quantity limits (V1.1b3 6.3, 6.12, 6.17).
namespace limits {
inline constexpr int read_registers = 125;        // 0x7D
inline constexpr int write_registers = 123;       // 0x7B
inline constexpr int write_and_read_read = 125;   // 0x7D
inline constexpr int write_and_read_write = 121;  // 0x79
inline constexpr std::size_t max_pdu = 253;       // 256 - address - CRC (serial line)
inline constexpr std::size_t max_rtu_adu = 256;
inline constexpr std::size_t max_tcp_adu = 260;  // 7-byte MBAP + 253
}  // namespace limits

/// Exception codes (V1.1b3, 7).
namespace exception_code {
inline constexpr std::uint8_t illegal_function = 0x01;
inline constexpr std::uint8_t illegal_data_address = 0x02;
inline constexpr std::uint8_t illegal_data_value = 0x03;
inline constexpr std::uint8_t server_device_failure = 0x04;
inline constexpr std::uint8_t acknowledge = 0x05;
inline constexpr std::uint8_t server_device_busy = 0x06;
inline constexpr std::uint8_t memory_parity_error = 0x08;
inline constexpr std::uint8_t gateway_path_unavailable = 0x0A;
inline constexpr std::uint8_t gateway_target_failed = 0x0B;
}  // namespace exception_code

/// "illegal data address", ...; "unknown exception" for a code the spec does not define.
std::string_view exception_name(std::uint8_t code) noexcept;
/// Acknowledge (05) and server busy (06) say "try again later"; the others
/// say the request was refused.
bool exception_is_transient(std::uint8_t code) noexcept;

/// CRC-16/MODBUS (polynomial 0xA001 reflected, initial 0xFFFF), Modbus over
/// Serial Line 6.2.2. Sent low byte first.
std::uint16_t crc16(std::span<const std::uint8_t> bytes) noexcept;

// ---- PDU builders (function code first) ----

std::size_t build_read_registers_request(std::span<std::uint8_t> out, std::uint8_t function,
                                         std::uint16_t address, std::uint16_t count) noexcept;
std::size_t build_read_registers_response(std::span<std::uint8_t> out, std::uint8_t function,
                                          std::span<const std::uint16_t> values) noexcept;
std::size_t build_write_single_coil_request(std::span<std::uint8_t> out, std::uint16_t address,
                                            bool on) noexcept;  // the response echoes the request
std::size_t build_write_single_register_request(std::span<std::uint8_t> out, std::uint16_t address,
                                                std::uint16_t value) noexcept;  // echoed too
std::size_t build_write_multiple_request(std::span<std::uint8_t> out, std::uint16_t address,
                                         std::span<const std::uint16_t> values) noexcept;
std::size_t build_write_multiple_response(std::span<std::uint8_t> out, std::uint16_t address,
                                          std::uint16_t count) noexcept;
std::size_t build_write_and_read_request(std::span<std::uint8_t> out, std::uint16_t read_address,
                                         std::uint16_t read_count, std::uint16_t write_address,
                                         std::span<const std::uint16_t> values) noexcept;
std::size_t build_write_and_read_response(std::span<std::uint8_t> out,
                                          std::span<const std::uint16_t> values) noexcept;
std::size_t build_exception_response(std::span<std::uint8_t> out, std::uint8_t function,
                                     std::uint8_t code) noexcept;

// ---- ADU framing ----

/// address, PDU, CRC (low byte first).
std::size_t build_rtu_adu(std::span<std::uint8_t> out, std::uint8_t slave,
                          std::span<const std::uint8_t> pdu) noexcept;
/// MBAP (transaction id, protocol id 0, length = 1 + PDU size, unit id), PDU.
std::size_t build_tcp_adu(std::span<std::uint8_t> out, std::uint16_t transaction, std::uint8_t unit,
                          std::span<const std::uint8_t> pdu) noexcept;

enum class AduStatus : std::uint8_t { ok, too_short, bad_crc, bad_protocol, bad_length };
struct Adu {
  AduStatus status = AduStatus::too_short;
  std::uint8_t unit = 0;              ///< RTU address or MBAP unit id
  std::uint16_t transaction = 0;      ///< TCP only
  std::span<const std::uint8_t> pdu;  ///< into the parsed buffer
};
Adu parse_rtu_adu(std::span<const std::uint8_t> frame) noexcept;
Adu parse_tcp_adu(std::span<const std::uint8_t> frame) noexcept;

/// Modbus TCP stream framing (TCP 3.1.3: the MBAP length counts the unit id
/// and the PDU): the size of the first ADU in `stream`, 0 while it is
/// incomplete. `invalid` when the first 7 bytes cannot start a Modbus ADU
/// (protocol id not 0, length outside 2..254): the stream is out of step.
std::size_t tcp_adu_length(std::span<const std::uint8_t> stream, bool& invalid) noexcept;

// ---- PDU parsing ----

enum class PduStatus : std::uint8_t {
  ok,
  exception,       ///< an exception response; `exception` holds the code
  malformed,       ///< length or byte count inconsistent with the function (V1.1b3 fig. 9: exception 03)
  bad_quantity,    ///< quantity out of the spec's range (exception 03)
  wrong_function,  ///< a response to another function
  unsupported,     ///< a function this driver does not use (exception 01 from a server)
};

/// A register request's fields as a server reads them (the codec's own
/// round trip in its tests and fuzz target).
struct RegisterRequest {
  std::uint8_t function = 0;
  std::uint16_t read_address = 0, read_count = 0;    ///< fc 3, 4, 23
  std::uint16_t write_address = 0, write_count = 0;  ///< fc 5 (count 1), 6 (count 1), 16, 23
  std::span<const std::uint8_t> write_data;  ///< big-endian registers (fc 6, 16, 23) or FF00/0000 (fc 5)
  std::uint16_t write_value(std::size_t i) const noexcept;
};
PduStatus parse_request(std::span<const std::uint8_t> pdu, RegisterRequest& out) noexcept;

/// A register-read response (fc 3, 4 or 23) into `values` (exactly `count` registers expected).
PduStatus parse_read_response(std::span<const std::uint8_t> pdu, std::uint8_t function,
                              std::span<std::uint16_t> values, std::uint8_t& exception) noexcept;
/// A write-multiple response (fc 16) echoing address and count.
PduStatus parse_write_multiple_response(std::span<const std::uint8_t> pdu, std::uint16_t address,
                                        std::uint16_t count, std::uint8_t& exception) noexcept;
/// A write-single response (fc 5, 6): the request echoed (6.5, 6.6).
PduStatus parse_echo_response(std::span<const std::uint8_t> pdu, std::span<const std::uint8_t> request,
                              std::uint8_t& exception) noexcept;

}  // namespace hapticd::drivers::modbus
