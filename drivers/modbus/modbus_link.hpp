#pragma once
/// \file
/// The one file of the driver that makes system calls: a libmodbus 3.1.6
/// client context (TCP or RTU) and the transactions the driver uses.
///
/// Thread rule: libmodbus contexts are not thread-safe. A ModbusLink is used
/// by one thread at a time; the device hands ownership between the RT thread
/// and the control thread explicitly (modbus_device.hpp).
///
/// Pairing a reply with its request. TCP: the MBAP transaction identifier
/// (Modbus Messaging on TCP/IP V1.0b, 3.1.3: "used for transaction
/// pairing"). libmodbus 3.1.6 fails a transaction on a reply with another
/// transaction id (EMBBADDATA, which it also returns for malformed frames)
/// instead of skipping it, and modbus_send_raw_request() always sends id 0,
/// so over TCP the link frames each transaction with the codec
/// (modbus_frame.hpp) on the socket libmodbus connected: a reply to an
/// earlier request that timed out (a late reply) is dropped and counted,
/// and the wait for this request's reply goes on within the same response
/// timeout. RTU frames carry no id: the link flushes the receive queue
/// before every request, so a late reply can be taken for at most the one
/// transaction that follows it (README.md, "Late replies").
///
/// RT rule: the transaction calls (write_and_read, write_registers,
/// read_registers, write_register, write_coil) allocate nothing (fixed
/// buffers here, libmodbus builds RTU frames on its stack), print nothing
/// (debug off) and return within the response timeout plus a non-blocking
/// send and flush. TCP: ppoll() with the time left to the deadline. RTU:
/// with the byte timeout off, libmodbus 3.1.6 passes one timeval to every
/// select() of a response and Linux decrements it, so the response timeout
/// bounds the whole response. MODBUS_ERROR_RECOVERY_NONE: libmodbus never
/// sleeps or reconnects on its own.

#include <array>
#include <atomic>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>

#include "drivers/modbus/modbus_frame.hpp"
#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/rtu_timing.hpp"

typedef struct _modbus modbus_t;  // NOLINT: libmodbus's own forward declaration

namespace hapticd::drivers::modbus {

enum class Transport : std::uint8_t;

/// How one transaction ended. RT-safe: no text; describe() renders it.
enum class LinkOutcome : std::uint8_t {
  ok,
  timeout,    ///< no (complete) response within the response timeout
  crc_error,  ///< RTU response with a wrong CRC
  exception,  ///< an exception response; exception_code says which
  bad_frame,  ///< a response that does not answer the request (length, function, slave), a TCP stream out of
              ///< step
  closed,     ///< TCP connection closed or reset, serial device gone
  io_error,   ///< any other system error (error_number)
};

struct LinkResult {
  LinkOutcome outcome = LinkOutcome::ok;
  std::uint8_t function = 0;        ///< the request's function code
  std::uint8_t exception_code = 0;  ///< with LinkOutcome::exception
  int error_number = 0;             ///< errno as libmodbus left it (0 when ok)
  bool ok() const noexcept { return outcome == LinkOutcome::ok; }
};

/// Maps a libmodbus errno (EMBXILADD, EMBBADCRC, ETIMEDOUT, ECONNRESET ...)
/// to an outcome; `exception_code` is set for an exception. Pure.
LinkOutcome classify_error(int error_number, std::uint8_t& exception_code) noexcept;
/// "timeout", "CRC error", ... (for counters' names and messages).
const char* outcome_name(LinkOutcome outcome) noexcept;
/// One line, non-RT: "exception 0x02 (illegal data address) in reply to function 0x17".
std::string describe(const LinkResult& result);

struct LinkSettings {
  Transport transport{};
  std::string host = "127.0.0.1";
  int port = 502;
  std::string device;
  SerialFormat serial;
  bool rs485 = false;
  int slave_id = 1;
  double response_timeout_s = 0.5e-3;
  double byte_timeout_s = 0.0;
  double connect_timeout_s = 1.0;
};

/// Frames and outcomes since the link was made (relaxed atomics: written by
/// the thread that owns the link, read by any).
struct LinkCounters {
  std::atomic<std::uint64_t> requests{0};   ///< request frames sent
  std::atomic<std::uint64_t> responses{0};  ///< response frames received (incl. exceptions, bad CRC)
  std::atomic<std::uint64_t> timeouts{0};
  std::atomic<std::uint64_t> crc_errors{0};
  std::atomic<std::uint64_t> exceptions{0};
  std::atomic<std::uint64_t> bad_frames{0};
  std::atomic<std::uint64_t> late_replies{0};  ///< TCP: replies to an earlier, timed-out request, dropped
  std::atomic<std::uint64_t> closed{0};
  std::atomic<std::uint64_t> io_errors{0};
  std::atomic<std::uint64_t> reconnects{0};
};

/// open() failures: one line; key() names the [device.modbus] key to blame.
class LinkError : public std::runtime_error {
 public:
  LinkError(const std::string& key, const std::string& message) : std::runtime_error(message), key_(key) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

class ModbusLink {
 public:
  explicit ModbusLink(LinkSettings settings);
  ~ModbusLink();
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  /// Connects (TCP within connect_timeout) or opens the serial device, then
  /// RS-485 mode if asked, error recovery none, the slave id and timeouts.
  /// Throws LinkError.
  void open();
  /// Closes the socket or device; idempotent.
  void close() noexcept;
  /// close() + open() (TCP reconnect, off the RT thread). Throws LinkError.
  void reopen();
  bool is_open() const noexcept { return open_; }
  /// Throws LinkError("response_timeout") on a value libmodbus refuses.
  void set_response_timeout(double seconds);
  double response_timeout_s() const noexcept { return settings_.response_timeout_s; }
  const LinkSettings& settings() const noexcept { return settings_; }
  /// "tcp 127.0.0.1:502 unit 1" or "rtu /dev/ttyUSB0 115200 8E1 slave 1".
  std::string endpoint() const;

  // ---- transactions (RT-safe, see the file comment) ----
  /// fc 23: writes `values` at write_address, then reads `out.size()` registers at read_address.
  LinkResult write_and_read(std::uint16_t write_address, std::span<const std::uint16_t> values,
                            std::uint16_t read_address, std::span<std::uint16_t> out) noexcept;
  /// fc 16.
  LinkResult write_registers(std::uint16_t address, std::span<const std::uint16_t> values) noexcept;
  /// fc 3 (holding) or fc 4 (input).
  LinkResult read_registers(ReadTable table, std::uint16_t address, std::span<std::uint16_t> out) noexcept;
  /// fc 6.
  LinkResult write_register(std::uint16_t address, std::uint16_t value) noexcept;
  /// fc 5.
  LinkResult write_coil(std::uint16_t address, bool on) noexcept;

  const LinkCounters& counters() const noexcept { return counters_; }
  /// The round trip of the last successful transaction, s. TCP: from just
  /// before the request's send() to the kernel's receive time of the reply
  /// (SO_TIMESTAMPNS), so a thread that waits for a CPU after the reply came
  /// does not count its own wait as the link's (configure measures on a
  /// plain thread, the loop runs SCHED_FIFO). RTU, or without a kernel
  /// timestamp: until the transaction call returned.
  double last_round_trip_s() const noexcept { return last_round_trip_s_; }

 private:
  bool ready() noexcept;  ///< open; RTU: the receive queue flushed
  LinkResult finish(int rc, std::uint8_t function, double started) noexcept;
  LinkResult fail(LinkOutcome outcome, std::uint8_t function, int error_number,
                  std::uint8_t exception_code = 0) noexcept;
  void apply_timeouts();

  // TCP: one transaction framed by the codec. Sends `pdu` with the next
  // transaction id and waits for the reply carrying it (earlier ids are
  // dropped); on ok, reply_pdu() is the reply's PDU.
  LinkResult tcp_exchange(std::span<const std::uint8_t> pdu, std::uint8_t function) noexcept;
  /// A reply PDU checked against its request (parse_read_response ...).
  LinkResult tcp_outcome(PduStatus status, std::uint8_t function, std::uint8_t exception_code) noexcept;
  /// fc 5 and 6: a request whose reply must echo it (V1.1b3 6.5, 6.6).
  LinkResult tcp_echo_exchange(std::span<const std::uint8_t> pdu, std::uint8_t function) noexcept;
  std::span<const std::uint8_t> reply_pdu() const noexcept {
    return std::span<const std::uint8_t>(reply_.data(), reply_size_);
  }
  void drop_received() noexcept;  ///< a TCP stream out of step: nothing buffered can be trusted

  LinkSettings settings_;
  modbus_t* ctx_ = nullptr;
  bool open_ = false;
  LinkCounters counters_;
  // TCP framing state (owner thread only).
  std::uint16_t transaction_ = 0;
  std::array<std::uint8_t, 2 * limits::max_tcp_adu> received_{};  ///< the byte stream not yet framed
  std::size_t received_size_ = 0;
  std::array<std::uint8_t, limits::max_pdu> reply_{};
  std::size_t reply_size_ = 0;
  double last_round_trip_s_ = 0.0;
};

}  // namespace hapticd::drivers::modbus
