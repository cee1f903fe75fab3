#pragma once
/// \file
/// One CANopen drive driven by hapticd: the socket, the setup, the
/// per-period exchange, and the hand-over between the RT loop and the other
/// threads. canopen_device.cpp maps it onto the driver's hooks.
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
#include "drivers/device_hooks.hpp"
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
  std::uint32_t rated_torque_mnm = 0;  ///< the 0x6076 hapticd scales the torque by
};

/// The value of one commissioning access.
struct SdoAccess {
  cia301::ObjectAddress address;
  std::uint32_t raw = 0;
  std::optional<cia301::DataType> type;  ///< known for the standard objects of this subset
  std::int64_t value = 0;                ///< raw interpreted in `type` (raw itself when unknown)
  std::string name;                      ///< the standard name, "" if unknown
  std::string note;  ///< what the write changed for hapticd (a new torque unit), "" if nothing
};

/// A torque unit handed to the loop: 0x6076 read back and found changed.
struct TorqueUnitChange {
  std::uint32_t before_mnm = 0;
  std::uint32_t after_mnm = 0;      ///< 0: it could not be read back (the scale stays)
  double force_per_permille = 0.0;  ///< the new scale, when after_mnm != 0
  bool fault = false;               ///< latch torque_unit_changed (the drive is enabled)
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
  /// Reads 0x6076 back (the torque unit follows it), then to Operation
  /// Enabled with zero torque. Throws SetupError.
  void enable();
  /// Reads 0x6076 back, the fault reset edge and the enable sequence; returns
  /// what was cleared ("" if nothing). Throws SetupError if the drive stays in
  /// fault, or restarted (its setup may be lost: configure again).
  std::string clear_fault();
  void disable() noexcept;
  void close() noexcept;

  IoResult read(Reading& out) noexcept;
  IoResult write(double force) noexcept;

  SessionStatus status() const;
  SdoAccess sdo_read(cia301::ObjectAddress address, std::optional<cia301::DataType> type);
  /// Refused while enabled for the objects of refused_while_enabled(). After
  /// every write 0x6076 is read back: while disabled a new value becomes the
  /// torque unit (SdoAccess::note says so); while enabled it latches a fault
  /// (the torque held at zero) and the unit changes with it. Throws
  /// std::invalid_argument (bad request), SdoError (the drive said no) or
  /// SetupError (0x6076 contradicts rated_torque).
  SdoAccess sdo_write(cia301::ObjectAddress address, std::int64_t value,
                      std::optional<cia301::DataType> type);

  const CanopenConfig& config() const noexcept { return config_; }
  bool configured() const noexcept { return exchange_.has_value(); }
  bool enabled() const noexcept { return enabled_.load(std::memory_order_acquire); }
  double period_s() const noexcept { return period_s_; }
  const SetupResult& setup() const noexcept { return setup_; }
  const cia301::BusBudget& budget() const noexcept { return budget_; }
  /// The 0x6076 (mN m) the torque is scaled by: as read at configure, at
  /// every enable and clear, and after every SDO write.
  std::uint32_t rated_torque_mnm() const noexcept {
    return rated_torque_mnm_.load(std::memory_order_acquire);
  }
  /// The scaling in use (from rated_torque_mnm()).
  Scaling scaling() const { return canopen::scaling(config_, rated_torque_mnm()); }

 private:
  class SocketLink;
  class RingLink;
  struct Cells;

  void publish() noexcept;
  void prime();
  /// Runs read/write(0) periods on this thread until done() or max periods.
  template <class Done>
  bool run_periods(Done&& done, std::uint64_t max_periods);
  /// True when an RT loop is calling read(): its counter moves within a few
  /// periods, and at least `at_least_s`.
  bool loop_running(double at_least_s = 5e-3) const;
  SdoAccess access(cia301::ObjectAddress address, std::uint32_t raw,
                   std::optional<cia301::DataType> type) const;
  /// Reads 0x6076 back over `link` (sdo_mutex_ held); a new unit goes to the
  /// exchange at its next read(), with a fault first when `fault_if_changed`.
  /// Returns a note ("" if unchanged). Throws SetupError.
  std::string recheck_torque_unit(FrameLink& link, bool fault_if_changed);
  void apply_torque_unit() noexcept;  ///< RT: takes what recheck_torque_unit() handed over

  CanopenConfig config_;
  StopToken stop_;
  double period_s_ = 0.0;
  CanSocket socket_;
  SetupResult setup_;
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
  std::atomic<std::uint32_t> rated_torque_mnm_{
      0};  ///< the unit the exchange scales by (or will, at its next read)
  std::unique_ptr<rt::SpscRing<TorqueUnitChange>> unit_changes_;  ///< control thread -> the loop's read()
  std::mutex sdo_mutex_;  // one commissioning transfer at a time (non-RT)
};

}  // namespace hapticd::drivers::canopen
