#pragma once
/// \file
/// The canopen driver's hooks: one CiA 402 drive in cyclic synchronous
/// torque over SocketCAN (or the unix: seam of the simulated drive). It owns
/// the socket; configure() runs the setup (drive_setup.hpp), read() and
/// write() the per-period exchange (cyclic_exchange.hpp), the commissioning
/// methods device.sdo.read / device.sdo.write the SDO client
/// (sdo_client.hpp). The framework's Device holds the lifecycle and its
/// order, turns exceptions into DeviceErrors and counts read and write
/// errors and faults. See README.md.
///
/// Threads. configure(), enable(), disable(), close() run when the RT loop
/// does not. read()/write() belong to the RT loop (or, before it runs and
/// after it stopped, to the thread calling them); they never allocate, lock
/// or log, and make at most max_frames_per_period recv(2) and 4 send(2)
/// calls, all non-blocking. clear_fault() and the commissioning SDO access
/// run on the control thread while the loop runs: clear_fault() hands a
/// request to the loop through an atomic and waits (bounded) for the result;
/// SDO answers come back through an SPSC ring the loop fills; a torque unit
/// read back goes to the loop through another. The loop publishes the
/// exchange's state under a seqlock (exchange_status.hpp).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "drivers/canopen/301/bus_budget.hpp"
#include "drivers/canopen/can_socket.hpp"
#include "drivers/canopen/canopen_config.hpp"
#include "drivers/canopen/commissioning.hpp"
#include "drivers/canopen/cyclic_exchange.hpp"
#include "drivers/canopen/drive_setup.hpp"
#include "drivers/canopen/exchange_status.hpp"
#include "drivers/canopen/homing.hpp"
#include "drivers/device_hooks.hpp"
#include "rt/spsc_ring.hpp"

namespace hapticd::drivers::canopen {

inline constexpr int max_frames_per_period = 32;

/// A torque unit handed to the loop: 0x6076 read back and found changed.
struct TorqueUnitChange {
  std::uint32_t before_mnm = 0;
  std::uint32_t after_mnm = 0;      ///< 0: it could not be read back (the scale stays)
  double force_per_permille = 0.0;  ///< the new scale, when after_mnm != 0
  bool fault = false;               ///< latch torque_unit_changed (the drive is enabled)
};

/// 0x6076 read back after a commissioning write, against the unit in use
/// (`before_mnm`): the change to hand to the loop, none when unchanged. An
/// unreadable 0x6076 throws SetupError (key rated_torque) unless
/// `fault_if_changed`; then it is a change with after_mnm = 0 and `problem`.
struct TorqueUnitCheck {
  std::optional<TorqueUnitChange> change;
  std::string problem;  ///< why 0x6076 could not be read back, "" if it was
};
TorqueUnitCheck check_torque_unit(SdoClient& sdo, const CanopenConfig& config, std::uint32_t before_mnm,
                                  bool fault_if_changed);
/// A commissioning write after its rules (commissioning.hpp): what scales or
/// bounds the torque refused while `enabled`, the type, the value fitting it.
/// Throws std::invalid_argument naming what was wrong.
struct CheckedWrite {
  cia301::DataType type;
  std::uint32_t raw = 0;
};
CheckedWrite checked_write(cia301::ObjectAddress address, std::int64_t value,
                           std::optional<cia301::DataType> type, bool enabled);
/// Sends it, then `recheck()` (0x6076 read back) after it, also after an
/// abort: the drive may have taken part of it. Returns the recheck's note;
/// an abort comes back as SdoError with the note, or SetupError when 0x6076
/// is unreadable.
std::string write_and_recheck(SdoClient& sdo, cia301::ObjectAddress address, const CheckedWrite& write,
                              const std::function<std::string()>& recheck);
/// "node 1's 0x6076 motor rated torque is now 2000 mN m (was 1000): hapticd
/// scales <scaled> by it<; held | from now on>".
std::string torque_unit_note(std::uint8_t node, const TorqueUnitChange& change, const std::string& scaled,
                             const std::string& held);

class CanopenDevice final : public DeviceHooks {
 public:
  /// Validates the config (throws ConfigError naming the key).
  explicit CanopenDevice(CanopenConfig config);
  ~CanopenDevice() override;
  CanopenDevice(const CanopenDevice&) = delete;
  CanopenDevice& operator=(const CanopenDevice&) = delete;

  /// Bus budget, socket, drive setup, NMT start, first TPDO; keeps
  /// loop.stop for every wait (configure, enable, clear_fault, SDO). Throws
  /// SetupError (with the config key to blame) or StopRequested.
  void configure(const LoopContext& loop) override;
  /// Reads 0x6076 back (the torque unit follows it), then to Operation
  /// Enabled with zero torque. Throws SetupError.
  void enable() override;
  /// Reads 0x6076 back, the fault reset edge and the enable sequence; returns
  /// what was cleared ("" if nothing). Throws SetupError if the drive stays in
  /// fault, or restarted (its setup may be lost: configure again).
  std::string clear_fault() override;
  void disable() noexcept override;
  /// Undoes the dead-man of a drive it set up (drive_setup.hpp), then
  /// releases the socket. Idempotent.
  void close() noexcept override;

  IoResult read(Reading& out) noexcept override;
  IoResult write(double force) noexcept override;

  DeviceModel model() const override;
  DeviceHealth health() const override;
  /// "interface can0, node 1, vendor 0x..., product 0x..., revision 0x..., serial 0x..." (0x1018).
  std::string identity() const override;
  /// The CiA 402 homing the last enable() ran (homing = "cia402").
  std::optional<DeviceHoming> homing() const override { return homing_; }
  /// device.sdo.read and device.sdo.write (canopen_device_sdo.cpp).
  std::vector<DeviceMethod> methods() override;

  // ---- commissioning (the methods, and tests) ----

  SdoAccess sdo_read(cia301::ObjectAddress address, std::optional<cia301::DataType> type);
  /// Refused while enabled for the objects of refused_while_enabled(). After
  /// every write 0x6076 is read back: while disabled a new value becomes the
  /// torque unit (SdoAccess::note says so); while enabled it latches a fault
  /// (the torque held at zero) and the unit changes with it. Throws
  /// std::invalid_argument (bad request), SdoError (the drive said no) or
  /// SetupError (0x6076 contradicts rated_torque).
  SdoAccess sdo_write(cia301::ObjectAddress address, std::int64_t value,
                      std::optional<cia301::DataType> type);

  // ---- observation, from configure() on (any non-RT thread) ----

  /// What the loop published last (all zero before configure()).
  ExchangeStatus exchange_status() const;
  const CanopenConfig& config() const noexcept { return config_; }
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
  std::chrono::microseconds sdo_timeout() const;  ///< the config's, per transfer
  void prime();
  /// Runs read/write(0) periods on this thread until done() or max periods.
  template <class Done>
  bool run_periods(Done&& done, std::uint64_t max_periods);
  /// True when an RT loop is calling read(): its counter moves within a few
  /// periods, and at least `at_least_s`.
  bool loop_running(double at_least_s = 5e-3) const;
  /// Waits (bounded) until the running loop took the fault reset and
  /// published its outcome.
  void await_reset_by_loop() const;
  /// Runs `use` over the SDO link of the socket's owner (frame_links.hpp):
  /// the ring while `loop_owns_socket`, else the socket itself.
  void with_sdo_link(bool loop_owns_socket, const std::function<void(FrameLink&)>& use);
  /// Reads 0x6076 back over `link` (sdo_mutex_ held); a new unit goes to the
  /// exchange at its next read(), with a fault first when `fault_if_changed`.
  /// Returns a note ("" if unchanged). Throws SetupError.
  std::string recheck_torque_unit(FrameLink& link, bool fault_if_changed);
  /// homing = "cia402": the homing objects and mode 6 by SDO, the periods
  /// of the homing run, then mode 10 again. Throws SetupError naming the key
  /// (README.md, "Homing"), or StopRequested.
  void run_homing();
  /// The periods of the homing run (read, step, write), until it ends or a stop.
  void drive_homing(HomingSequence& sequence, double& last_position);
  void apply_torque_unit() noexcept;  ///< RT: takes what recheck_torque_unit() handed over
  void drain_socket() noexcept;       ///< RT: the frames of this period into the exchange

  const CanopenConfig config_;
  StopToken stop_;
  double period_s_ = 0.0;
  CanSocket socket_;
  SetupResult setup_;
  cia301::BusBudget budget_;
  /// From a configure() that set the drive up to close(): what read(),
  /// write() and the commissioning methods work on.
  std::optional<CyclicExchange> exchange_;
  PublishedExchange published_;
  std::unique_ptr<rt::SpscRing<cia301::Frame>> sdo_answers_;      ///< the loop's read() -> SDO client
  std::unique_ptr<rt::SpscRing<TorqueUnitChange>> unit_changes_;  ///< control thread -> the loop's read()
  /// Between enable() and disable(): the loop owns the socket's receive
  /// side (SDO answers come through the ring), and writes that scale or
  /// bound the torque are refused.
  std::atomic<bool> enabled_{false};
  std::atomic<bool> clear_requested_{false};    ///< control thread -> the loop's next read()
  std::atomic<bool> disable_requested_{false};  ///< control thread -> the loop's next read()
  std::atomic<std::uint64_t> reads_{0};         ///< read() calls: is a loop running?
  /// The unit the exchange scales by (or will, at its next read).
  std::atomic<std::uint32_t> rated_torque_mnm_{0};
  std::mutex sdo_mutex_;                // one commissioning transfer at a time (non-RT)
  std::optional<DeviceHoming> homing_;  ///< since the last configure()
};

}  // namespace hapticd::drivers::canopen
