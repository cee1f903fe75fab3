#pragma once
/// \file
/// The simulated amplifier on the wire, on its own thread: libmodbus is its
/// transport only (accept, modbus_receive: one request ADU, the RTU CRC and
/// address checked); the Amplifier decides with its own decoder, and the
/// reply is framed by amplifier_wire.hpp (TCP: the request's MBAP ids
/// copied; RTU: address and CRC) and written to the socket or the pty.
///
/// - TCP: listens on host:port (port 0 = a free port, see port()), one
///   client at a time; a dropped or closed connection goes back to accept.
/// - RTU: a pseudo-terminal pair (openpty). The driver opens the slave side
///   (slave_path()) as its serial device; the server attaches a libmodbus RTU
///   context to the master side with modbus_set_socket(). The server keeps
///   its own descriptor of the slave open (raw mode) so the driver may close
///   and reopen it. A pty carries bytes instantly: baud timing is not
///   emulated (the budget is unit-tested against the formula instead).

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "sim/modbus/amplifier.hpp"

typedef struct _modbus modbus_t;  // NOLINT: libmodbus's declaration

namespace hapticd::drivers::modbus::sim {

/// A clock a test advances by hand: the amplifier's watchdog then runs on
/// it instead of the wall clock (AmplifierServer::use_clock), so a test
/// says when time passes rather than sleeping and hoping.
class ManualClock {
 public:
  double now_s() const noexcept { return now_s_.load(std::memory_order_acquire); }
  void advance(double seconds) noexcept {
    double now = now_s_.load(std::memory_order_relaxed);
    while (!now_s_.compare_exchange_weak(now, now + seconds, std::memory_order_acq_rel)) {
    }
  }

 private:
  std::atomic<double> now_s_{1.0};
};

class AmplifierServer {
 public:
  /// Listens on host:port (0: a free port). Throws std::runtime_error.
  static std::unique_ptr<AmplifierServer> tcp(Amplifier& amplifier, const std::string& host = "127.0.0.1",
                                              int port = 0);
  /// Opens a pseudo-terminal pair. Throws std::runtime_error.
  static std::unique_ptr<AmplifierServer> rtu_pty(Amplifier& amplifier);
  ~AmplifierServer();
  AmplifierServer(const AmplifierServer&) = delete;
  AmplifierServer& operator=(const AmplifierServer&) = delete;

  /// The amplifier's time from `clock` instead of the steady clock; before start().
  void use_clock(const ManualClock& clock) noexcept { clock_ = &clock; }
  void start();
  void stop() noexcept;
  /// Runs the server thread SCHED_FIFO at `priority` (after start()): an
  /// amplifier is its own hardware and answers whatever else the host does.
  /// Returns 0, or the errno (EPERM without the privilege).
  int make_realtime(int priority) noexcept;

  int port() const noexcept { return port_; }                             ///< TCP
  const std::string& slave_path() const noexcept { return slave_path_; }  ///< RTU
  bool is_rtu() const noexcept { return rtu_; }

  /// Injects a failure; a CRC error only on RTU (throws std::invalid_argument on TCP: TCP has no CRC).
  void inject(Injection what, int count = 1, std::uint8_t exception_code = exception::server_device_failure,
              int delay_ms = 0);
  /// Connections accepted (TCP) so far.
  std::uint64_t connections() const noexcept { return connections_.load(std::memory_order_relaxed); }
  /// Reply frames written so far (normal, exception and corrupted ones).
  std::uint64_t replies() const noexcept { return replies_.load(std::memory_order_acquire); }
  /// RTU: bytes waiting in the line's receive queue, not yet read by the
  /// driver (TIOCINQ on the server's own descriptor of the pty's slave
  /// side, which shares that queue); -1 over TCP. For tests that wait for a
  /// reply to have arrived rather than sleeping.
  int line_bytes_waiting() const noexcept;

 private:
  AmplifierServer(Amplifier& amplifier, bool rtu);
  void run() noexcept;
  double now_s() const noexcept;
  void serve_one(std::span<const std::uint8_t> adu) noexcept;
  /// Frames `pdu` as the reply to `adu` and writes it to the client.
  void send_reply(std::span<const std::uint8_t> adu, std::span<const std::uint8_t> pdu,
                  bool corrupt_crc) noexcept;
  bool accept_client() noexcept;

  Amplifier& amplifier_;
  bool rtu_ = false;
  const ManualClock* clock_ = nullptr;
  modbus_t* ctx_ = nullptr;
  std::vector<std::uint16_t> holding_, input_;
  std::vector<std::uint8_t> coils_;
  int listen_fd_ = -1;
  int master_fd_ = -1, slave_fd_ = -1;
  bool client_ = false;
  int port_ = 0;
  std::string slave_path_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> connections_{0};
  std::atomic<std::uint64_t> replies_{0};
};

}  // namespace hapticd::drivers::modbus::sim
