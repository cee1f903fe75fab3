#pragma once
/// \file
/// One CANopen drive driven by hapticd: the socket, the setup, the
/// per-period exchange, and the hand-over between the RT loop and the other
/// threads. canopen_device.cpp puts it behind drivers::Device.
///
/// Threads. configure(), enable(), disable(), close() run when the RT loop
/// does not. read()/write() belong to the RT loop (or, before it runs and
/// after it stopped, to the thread calling them); they never allocate, lock
/// or log, and make at most max_frames_per_period recv(2) and 4 send(2)
/// calls, all non-blocking. clear_fault() and the commissioning SDO access run
/// on the control thread while the loop runs: clear_fault() hands a request
/// to the loop through an atomic and waits (bounded) for the result; SDO
/// answers come back through an SPSC ring the loop fills. Status is published
/// by the loop under a seqlock.

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "drivers/canopen/301/bus_budget.hpp"
#include "drivers/canopen/can_socket.hpp"
#include "drivers/canopen/canopen_config.hpp"
#include "drivers/canopen/cyclic_exchange.hpp"
#include "drivers/canopen/drive_setup.hpp"
#include "drivers/device.hpp"
#include "rt/seqlock.hpp"
#include "rt/spsc_ring.hpp"

namespace hapticd::drivers::canopen {

inline constexpr int max_frames_per_period = 32;

struct SessionStatus {
  bool configured = false;
  bool enabled = false;
  bool faulted = false;
  bool resetting = false;
  bool operational = false;
  std::string fault_reason;  ///< the drive's own words, "" if none
  FaultKind fault_kind = FaultKind::none;
  std::uint16_t statusword = 0;
  std::string drive_state;  ///< "Operation Enabled", ...
  std::uint16_t controlword = 0;
  std::int16_t torque_permille = 0;
  CyclicCounters counters;
  std::uint64_t sdo_answers_dropped = 0;
};

/// The value of one commissioning access.
struct SdoAccess {
  cia301::ObjectAddress address;
  std::uint32_t raw = 0;
  std::optional<cia301::DataType> type;  ///< known for the standard objects of this subset
  std::int64_t value = 0;                ///< raw interpreted in `type` (raw itself when unknown)
  std::string name;                      ///< the standard name, "" if unknown
};

class CanopenSession {
 public:
  /// Validates the config (throws ConfigError naming the key).
  explicit CanopenSession(CanopenConfig config);
  ~CanopenSession();
  CanopenSession(const CanopenSession&) = delete;
  CanopenSession& operator=(const CanopenSession&) = delete;

  /// The daemon's stop request: configure, enable, clear_fault and the SDO
  /// transfers give way to it within stop_slice (StopRequested). Before configure().
  void set_stop(StopToken stop) noexcept { stop_ = std::move(stop); }
  /// Bus budget, socket, drive setup, NMT start, first TPDO. Throws
  /// SetupError (with the config key to blame) or ConfigError.
  void configure(double period_s);
  /// To Operation Enabled with zero torque. Throws SetupError.
  void enable();
  /// The fault reset edge and the enable sequence; returns what was cleared
  /// ("" if nothing). Throws SetupError if the drive stays in fault.
  std::string clear_fault();
  void disable() noexcept;
  void close() noexcept;

  IoResult read(Reading& out) noexcept;
  IoResult write(double force) noexcept;

  SessionStatus status() const;
  SdoAccess sdo_read(cia301::ObjectAddress address, std::optional<cia301::DataType> type);
  /// Refused while enabled for the objects of refused_while_enabled(). Throws
  /// std::invalid_argument (bad request) or SdoError (the drive said no).
  SdoAccess sdo_write(cia301::ObjectAddress address, std::int64_t value,
                      std::optional<cia301::DataType> type);

  const CanopenConfig& config() const noexcept { return config_; }
  bool configured() const noexcept { return exchange_.has_value(); }
  bool enabled() const noexcept { return enabled_.load(std::memory_order_acquire); }
  double period_s() const noexcept { return period_s_; }
  const SetupResult& setup() const noexcept { return setup_; }
  const cia301::BusBudget& budget() const noexcept { return budget_; }
  const Scaling& scaling() const noexcept { return scaling_; }

 private:
  class SocketLink;
  class RingLink;
  struct Cells;

  void publish() noexcept;
  void prime();
  /// Runs read/write(0) periods on this thread until done() or max periods.
  template <class Done>
  bool run_periods(Done&& done, std::uint64_t max_periods);
  /// True when an RT loop is calling read(): its counter moves within a few periods.
  bool loop_running() const;
  SdoAccess access(cia301::ObjectAddress address, std::uint32_t raw,
                   std::optional<cia301::DataType> type) const;

  CanopenConfig config_;
  StopToken stop_;
  double period_s_ = 0.0;
  CanSocket socket_;
  SetupResult setup_;
  Scaling scaling_;
  cia301::BusBudget budget_;
  std::optional<CyclicExchange> exchange_;
  std::unique_ptr<rt::SpscRing<cia301::Frame>> sdo_answers_;
  std::unique_ptr<Cells> cells_;
  rt::SeqlockVersion version_;
  std::atomic<bool> enabled_{false};
  std::atomic<bool> clear_requested_{false};
  std::atomic<bool> disable_requested_{false};
  std::atomic<std::uint64_t> reads_{0};
  std::atomic<std::uint64_t> publications_{0};  ///< status publications, one per write()
  std::mutex sdo_mutex_;                        // one commissioning transfer at a time (non-RT)
};

}  // namespace hapticd::drivers::canopen
