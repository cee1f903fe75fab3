#pragma once
/// \file
/// The one file of the driver that makes system calls: a libmodbus 3.1.6
/// client context (TCP or RTU) and the transactions the driver uses.
///
/// Thread rule: libmodbus contexts are not thread-safe. A ModbusLink is used
/// by one thread at a time; the device hands ownership between the RT thread
/// and the control thread explicitly (modbus_device.hpp).
///
/// RT rule: the transaction calls (write_and_read, write_registers,
/// read_registers, write_register, write_coil) allocate nothing (libmodbus
/// builds frames on its stack), print nothing (debug off) and return within
/// the response timeout plus a non-blocking send and, after a failure, a
/// non-blocking flush: with the byte timeout off, libmodbus 3.1.6 passes one
/// timeval to every select() of a response and Linux decrements it, so the
/// response timeout bounds the whole response. MODBUS_ERROR_RECOVERY_NONE:
/// libmodbus never sleeps or reconnects on its own.

#include <atomic>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>

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
  bad_frame,  ///< a response that does not answer the request (length, function, slave, transaction id)
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

 private:
  bool ready() noexcept;  ///< open, and any late reply of a failed transaction dropped
  LinkResult finish(int rc, std::uint8_t function) noexcept;
  void apply_timeouts();

  LinkSettings settings_;
  modbus_t* ctx_ = nullptr;
  bool open_ = false;
  bool flush_before_next_ = false;
  LinkCounters counters_;
};

}  // namespace hapticd::drivers::modbus
