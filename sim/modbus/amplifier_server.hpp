#pragma once
/// \file
/// The simulated amplifier on the wire: a libmodbus server (modbus_receive,
/// then modbus_reply / modbus_reply_exception from a modbus_mapping_t) in
/// front of an Amplifier, on its own thread.
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

typedef struct _modbus modbus_t;                    // NOLINT: libmodbus's declarations
typedef struct _modbus_mapping_t modbus_mapping_t;  // NOLINT

namespace hapticd::drivers::modbus::sim {

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
  void inject(Injection what, int count = 1,
              std::uint8_t exception_code = exception_code::server_device_failure, int delay_ms = 0);
  /// Connections accepted (TCP) so far.
  std::uint64_t connections() const noexcept { return connections_.load(std::memory_order_relaxed); }

 private:
  AmplifierServer(Amplifier& amplifier, bool rtu);
  void run() noexcept;
  void serve_one(const std::uint8_t* query, int length) noexcept;
  bool accept_client() noexcept;

  Amplifier& amplifier_;
  bool rtu_ = false;
  modbus_t* ctx_ = nullptr;
  modbus_mapping_t* mapping_ = nullptr;
  int listen_fd_ = -1;
  int master_fd_ = -1, slave_fd_ = -1;
  bool client_ = false;
  int port_ = 0;
  std::string slave_path_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> connections_{0};
};

}  // namespace hapticd::drivers::modbus::sim
