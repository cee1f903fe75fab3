#pragma once
/// \file
/// The RTU timing budget (Modbus over serial line V1.02, 2.5.1 and 2.5.1.1):
/// how long one transaction occupies the line, from the frame sizes, the
/// character time and the silences between frames. Pure arithmetic, no I/O.
///
/// One transaction, master's view:
///   request on the wire | t3.5 silence (end of the request frame) |
///   turnaround (the amplifier's own processing) | response on the wire |
///   t3.5 silence (before the master may send the next request)
///
/// A character is 1 start bit + data bits + parity bit (if any) + stop bits
/// (the spec's RTU character is 11 bits: 8 data, even parity, 1 stop; or no
/// parity and 2 stop bits). t3.5 is 3.5 character times; above 19200 baud
/// the spec recommends a fixed 1.750 ms (and 750 us for t1.5) instead.

#include <cstdint>

namespace hapticd::drivers::modbus {

enum class Parity : std::uint8_t { none, even, odd };

struct SerialFormat {
  int baud = 115200;
  int data_bits = 8;
  Parity parity = Parity::even;
  int stop_bits = 1;
};

/// Which t3.5 the amplifier uses to find the end of a frame.
enum class SilenceRule : std::uint8_t {
  spec,        ///< 3.5 characters up to 19200 baud, a fixed 1.750 ms above (2.5.1.1)
  characters,  ///< 3.5 characters at every baud (many fast amplifiers; see its manual)
};

/// Bits per character on the line: start + data + parity + stop.
int character_bits(const SerialFormat& format) noexcept;
/// Seconds per character: character_bits / baud.
double character_time_s(const SerialFormat& format) noexcept;
/// The inter-frame silence t3.5 in seconds under `rule`.
double frame_silence_s(const SerialFormat& format, SilenceRule rule) noexcept;

/// RTU ADU sizes in bytes (address + PDU + 2 CRC bytes), from the PDU layouts
/// of the Modbus Application Protocol V1.1b3, 6.3, 6.4, 6.12, 6.17 and 7.
namespace rtu_bytes {
constexpr int read_request() noexcept { return 1 + 5 + 2; }  // fc 3 or 4
constexpr int read_response(int registers) noexcept { return 1 + 2 + 2 * registers + 2; }
constexpr int write_multiple_request(int registers) noexcept { return 1 + 6 + 2 * registers + 2; }  // fc 16
constexpr int write_multiple_response() noexcept { return 1 + 5 + 2; }
constexpr int write_and_read_request(int write_registers) noexcept {  // fc 23
  return 1 + 10 + 2 * write_registers + 2;
}
constexpr int write_and_read_response(int read_registers) noexcept { return 1 + 2 + 2 * read_registers + 2; }
constexpr int exception_response() noexcept { return 1 + 2 + 2; }
}  // namespace rtu_bytes

/// One request/response pair on the line.
struct TransactionTime {
  int request_bytes = 0;
  int response_bytes = 0;
  double request_s = 0.0;     ///< request on the wire
  double silence_s = 0.0;     ///< one t3.5 (counted twice: after the request, after the response)
  double turnaround_s = 0.0;  ///< the amplifier's processing time, from the config
  double response_s = 0.0;    ///< response on the wire
  /// From the first request bit until the master may send again.
  double total_s() const noexcept { return request_s + silence_s + turnaround_s + response_s + silence_s; }
  /// From the end of the master's write() until the last response byte: what
  /// the response timeout must cover (the request is still leaving the UART).
  double response_wait_s() const noexcept { return request_s + silence_s + turnaround_s + response_s; }
};

TransactionTime transaction_time(const SerialFormat& format, SilenceRule rule, double turnaround_s,
                                 int request_bytes, int response_bytes) noexcept;

/// The periodic exchange: function 23 (one transaction), or function 16 then
/// function 3/4 (two transactions).
struct CycleTime {
  int transactions = 0;
  TransactionTime first;   ///< fc 23, or fc 16
  TransactionTime second;  ///< fc 3/4 when transactions == 2
  double total_s() const noexcept { return first.total_s() + (transactions == 2 ? second.total_s() : 0.0); }
  int frames() const noexcept { return 2 * transactions; }
  int bytes() const noexcept {
    return first.request_bytes + first.response_bytes +
           (transactions == 2 ? second.request_bytes + second.response_bytes : 0);
  }
};

CycleTime cycle_time(const SerialFormat& format, SilenceRule rule, double turnaround_s, bool function_23,
                     int write_registers, int read_registers) noexcept;

/// Shortest loop period that carries `cycle` when the link may use
/// `link_budget` (0..1] of each period.
double shortest_period_s(const CycleTime& cycle, double link_budget) noexcept;

/// Standard baud rates libmodbus 3.1.6 maps to a termios speed on Linux
/// (an unlisted rate silently becomes 9600 there, so the config refuses it).
bool is_supported_baud(int baud) noexcept;
/// The supported rates, ascending, for error messages and the budget table.
const int* supported_bauds(int& count) noexcept;

/// Lowest supported baud rate whose cycle fits `link_budget * period_s`, or 0
/// when none does (with the spec's fixed 1.75 ms silences no rate carries a
/// period shorter than 2 x 1.75 ms / link_budget).
int lowest_baud_for(const SerialFormat& format, SilenceRule rule, double turnaround_s, bool function_23,
                    int write_registers, int read_registers, double period_s, double link_budget) noexcept;

}  // namespace hapticd::drivers::modbus
