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
/// timeout. A reply with this transaction id from another unit id is
/// dropped and counted the same way (TCP 3.1.3: the server copies the unit
/// id); a header that does not fit the request (protocol id not 0, a length
/// no reply to it has) puts the stream out of step: a malformed reply.
/// RTU frames carry no id: the link flushes the receive queue before every
/// request, so a late reply can be taken for at most the one transaction
/// that follows it (README.md, "Late replies").
///
/// Stop (drivers/stop_request.hpp). The waits longer than stop_slice -- the
/// TCP connect, and the exchanges off the loop, which wait up to
/// connect_timeout -- are cut into slices and end with LinkOutcome::stopped
/// (open(): StopRequested) when a stop is requested. The TCP connect is the
/// link's own non-blocking connect() for that (libmodbus's blocks for the
/// whole timeout), and so is an RTU exchange with such a timeout: the
/// request through libmodbus, the reply read and checked by the codec. The
/// loop's exchanges (response timeout < one period) are untouched.
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
#include <string>

#include "drivers/device_hooks.hpp"
#include "drivers/modbus/modbus_frame.hpp"
#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/rtu_timing.hpp"
#include "drivers/stop_request.hpp"

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
  stopped,    ///< a stop request ended the wait (exchanges off the loop only)
};

/// What was wrong with a malformed reply, when the link framed it itself.
enum class FrameProblem : std::uint8_t {
  none,
  wrong_unit,   ///< the reply came from unit (slave) `got`, not `expected`
  protocol_id,  ///< MBAP protocol id `got`, not 0 (Modbus)
  length,       ///< MBAP length `got`: no reply to the request has it (`expected`, or 3 for an exception)
};

struct LinkResult {
  LinkOutcome outcome = LinkOutcome::ok;
  std::uint8_t function = 0;                  ///< the request's function code
  std::uint8_t exception_code = 0;            ///< with LinkOutcome::exception
  int error_number = 0;                       ///< errno as libmodbus left it (0 when ok)
  FrameProblem problem = FrameProblem::none;  ///< with bad_frame
  std::uint16_t got = 0, expected = 0;        ///< the figures of `problem`
  bool ok() const noexcept { return outcome == LinkOutcome::ok; }
};

/// Maps a libmodbus errno (EMBXILADD, EMBBADCRC, ETIMEDOUT, ECONNRESET ...)
/// to an outcome; `exception_code` is set for an exception. Pure.
LinkOutcome classify_error(int error_number, std::uint8_t& exception_code) noexcept;
/// "timeout", "CRC error", ... (for counters' names and messages).
const char* outcome_name(LinkOutcome outcome) noexcept;
/// One line, non-RT: "exception 0x02 (illegal data address) in reply to function 0x17".
std::string describe(const LinkResult& result);
/// The MBAP length a reply PDU of `pdu_size` bytes carries (unit id + PDU).
constexpr std::uint16_t mbap_length(std::size_t pdu_size) noexcept {
  return static_cast<std::uint16_t>(pdu_size + 1);
}

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
  std::atomic<std::uint64_t> wrong_unit{
      0};  ///< replies from another unit id (slave), dropped (TCP) or refused
  std::atomic<std::uint64_t> closed{0};
  std::atomic<std::uint64_t> io_errors{0};
  std::atomic<std::uint64_t> reconnects{0};
};

class ModbusLink {
 public:
  explicit ModbusLink(LinkSettings settings);
  ~ModbusLink();
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  /// Connects (TCP within connect_timeout) or opens the serial device, then
  /// RS-485 mode if asked, error recovery none, the slave id and timeouts.
  /// Throws DeviceError naming the [device.modbus] key to blame, or
  /// StopRequested when a stop ends the connect.
  void open();
  /// The stop request the long waits give way to (see the file comment).
  void set_stop(StopToken stop) noexcept { stop_ = std::move(stop); }
  /// Closes the socket or device; idempotent.
  void close() noexcept;
  /// close() + open() (TCP reconnect, off the RT thread). Throws DeviceError.
  void reopen();
  bool is_open() const noexcept { return open_; }
  /// Throws DeviceError (key response_timeout) on a value libmodbus refuses.
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

  void connect_tcp();  ///< non-blocking connect() in slices; throws DeviceError, StopRequested
  /// TCP always; RTU when the response timeout is longer than a slice.
  bool framed_here() const noexcept;
  /// One transaction framed by the codec (TCP or RTU); on ok, reply_pdu()
  /// is the reply's PDU. `reply_size`: the PDU size a normal reply has.
  LinkResult framed_exchange(std::span<const std::uint8_t> pdu, std::uint8_t function,
                             std::size_t reply_size) noexcept;
  // TCP: sends `pdu` with the next transaction id and waits for the reply
  // carrying it (earlier ids and other units are dropped).
  LinkResult tcp_exchange(std::span<const std::uint8_t> pdu, std::uint8_t function,
                          std::size_t reply_size) noexcept;
  /// Frames what tcp_exchange buffered: true when this request's reply was found.
  bool take_tcp_reply(std::uint8_t function, std::size_t reply_size, LinkResult& failure,
                      int& wrong_unit) noexcept;
  // RTU: the request through libmodbus, the reply read in slices and checked by the codec.
  LinkResult rtu_exchange(std::span<const std::uint8_t> pdu, std::uint8_t function,
                          std::size_t reply_size) noexcept;
  /// A reply PDU checked against its request (parse_read_response ...).
  LinkResult pdu_outcome(PduStatus status, std::uint8_t function, std::uint8_t exception_code) noexcept;
  LinkResult frame_problem(FrameProblem problem, std::uint8_t function, std::uint16_t got,
                           std::uint16_t expected) noexcept;
  /// fc 5 and 6: a request whose reply must echo it (V1.1b3 6.5, 6.6).
  LinkResult echo_exchange(std::span<const std::uint8_t> pdu, std::uint8_t function) noexcept;
  std::span<const std::uint8_t> reply_pdu() const noexcept {
    return std::span<const std::uint8_t>(reply_.data(), reply_size_);
  }
  void drop_received() noexcept;  ///< a TCP stream out of step: nothing buffered can be trusted

  LinkSettings settings_;
  StopToken stop_;
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
