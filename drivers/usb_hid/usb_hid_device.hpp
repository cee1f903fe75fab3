#pragma once
/// \file
/// The usb-hid driver's hooks (DeviceHooks): one UsbTransport and one
/// HostSession, the per-period exchange and the board's side of the
/// lifecycle. The framework's Device holds the lifecycle: no hook checks
/// the order, counts read/write errors or latched faults.
///
/// Threads. read()/write(): the RT thread, no allocation, lock or text.
/// clear_fault(): the control thread, while read()/write() go on: it asks
/// the RT side to park (an atomic request; read()/write() then return fault
/// without touching the transport or the session) and waits until the RT
/// side is out of its current call, does the non-RT work (re-open after an
/// unplug, CLEAR_HALT after a stall), starts the reset handshake, un-parks,
/// and waits (bounded) for the board's answer. With no RT loop running it
/// drives the handshake itself. link_status(), health(): any thread
/// (atomics published by the RT side). The rest: only while the RT thread
/// is not calling read()/write().

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>

#include "drivers/device_hooks.hpp"
#include "drivers/usb_hid/host_session.hpp"
#include "drivers/usb_hid/usb_hid_config.hpp"
#include "drivers/usb_hid/usb_transport.hpp"

namespace hapticd::drivers::usb_hid {

/// What the RT side published, for health() and the tests.
struct LinkStatus {
  bool enabled = false;  ///< OUT reports carry the enable bit
  LatchedFault fault;
  std::string fault_text;  ///< the device's own words, "" if none
  SessionCounters session;
  TransportCounters transport;
  std::uint64_t reopens = 0;  ///< re-opens after an unplug (fault clear)
  std::string board;          ///< OpenedBoard::description
};

class UsbHidDevice final : public DeviceHooks {
 public:
  explicit UsbHidDevice(const UsbHidConfig& config);
  ~UsbHidDevice() override;
  UsbHidDevice(const UsbHidDevice&) = delete;
  UsbHidDevice& operator=(const UsbHidDevice&) = delete;

  /// Opens and claims the board, checks the endpoints against the period,
  /// queues the IN transfers and waits (bounded, giving way to loop.stop)
  /// for the first IN report. read() is valid afterwards.
  void configure(const LoopContext& loop) override;
  /// Arms the output: from the next write() on, OUT reports carry the enable
  /// bit (the board's dead-man runs from the first one). A board whose
  /// dead-man tripped (a previous hapticd died) is reset first.
  void enable() override;
  /// See the file comment. Returns what was cleared in words ("" if nothing);
  /// throws DeviceError if the board stays in fault or cannot be reached.
  std::string clear_fault() override;
  /// One OUT report with the output off (the IN transfers keep running:
  /// read() stays valid, enable() may follow). Idempotent.
  void disable() noexcept override;
  /// Cancels the transfers, releases the interface (the kernel driver gets
  /// it back) and closes. Idempotent.
  void close() noexcept override;

  IoResult read(Reading& out) noexcept override;
  IoResult write(double force) noexcept override;
  /// A board with several axes: every encoder field of one IN report (one
  /// sample instant), every command field of one OUT report. A bad report
  /// (short, wrong ID, a transfer error) is no reading for any axis.
  int axes() const noexcept override { return static_cast<int>(config_.axis_count()); }
  IoResult read_axes(std::span<Reading> out) noexcept override;
  IoResult write_axes(std::span<const double> forces) noexcept override;

  DeviceModel model() const override;
  DeviceHealth health() const override;

  LinkStatus link_status() const;
  const UsbHidConfig& config() const noexcept { return config_; }

 private:
  void open_board();
  void reopen_checks();
  void reopen();
  /// One IN exchange: every axis' position into positions_ when ok.
  IoResult exchange_read() noexcept;
  /// One OUT report with `forces` (axes past its size get 0).
  IoResult exchange_write(std::span<const double> forces) noexcept;
  IoResult exchange_write(double force) noexcept {
    return exchange_write(std::span<const double>(&force, 1));
  }
  /// The park handshake around one RT call (see read()).
  template <class Exchange>
  IoResult rt_call(Exchange exchange) noexcept;
  void publish() noexcept;
  bool park(double timeout_s);
  void unpark() noexcept;
  /// Does an RT loop call read() (watched for max(20 ms, 5 periods))?
  bool rt_loop_running() const;
  /// CLEAR_HALT or re-open, whatever the latched fault needs (parked).
  void repair(const LatchedFault& fault);
  /// Waits for the board's answer to the reset (RT running) or drives the
  /// handshake itself (RT not running); throws DeviceError.
  void await_reset(bool rt_running);
  void drain_completions() noexcept;
  void set_description();
  /// Runs read/write(0) itself for up to `periods` periods (RT not running).
  bool run_reset_handshake(int periods);

  UsbHidConfig config_;
  StopToken stop_;
  double period_s_ = 1e-3;
  std::uint32_t deadman_us_ = 0;
  std::unique_ptr<UsbTransport> transport_;
  HostSession session_;
  OpenedBoard board_;  ///< written only while the RT side is parked or not running
  mutable std::mutex description_mutex_;
  std::string description_;  ///< board_.description for link_status() (any thread)
  std::atomic<bool> enabled_{false};
  std::uint8_t out_buffer_[max_report_size]{};
  std::array<double, max_report_axes> positions_{};       ///< the last good reading, per axis (RT thread)
  std::array<std::int64_t, max_report_axes> commands_{};  ///< this period's command counts (RT thread)

  // RT -> others (relaxed counters, release/acquire on the fault).
  std::atomic<std::uint32_t> fault_reason_{0}, fault_detail_{0};
  std::atomic<std::uint64_t> reopens_{0};
  std::atomic<std::uint64_t> in_reports_{0}, stale_reports_{0}, missed_reports_{0}, short_reports_{0},
      transfer_errors_{0}, held_periods_{0}, out_reports_{0};
  std::atomic<std::uint32_t> max_ack_lag_{0};
  std::atomic<bool> resetting_{false};

  // Control -> RT parking.
  std::atomic<bool> park_requested_{false};
  std::atomic<bool> in_rt_{false};  ///< the RT side is inside read()/write()
  std::atomic<std::uint64_t> rt_calls_{0};
};

}  // namespace hapticd::drivers::usb_hid
