#pragma once
/// \file
/// The host side of the board protocol, period by period (README.md
/// "Errors and faults"): which IN report is new, which is stale, when the
/// link has timed out, what a status bit or a transfer outcome means, and
/// the OUT report's sequence number. Pure: no libusb, no system call, no
/// allocation, no text on the RT path (a fault is a code plus a number;
/// describe() makes the words off the RT path). One thread (the RT thread)
/// drives it.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "drivers/device_hooks.hpp"
#include "drivers/usb_hid/report_codec.hpp"

namespace hapticd::drivers::usb_hid {

/// How one transfer ended, in the transport's terms (libusb_transfer_status
/// without libusb: usb_transport.cpp maps it).
enum class TransferOutcome : std::uint8_t {
  completed,
  no_device,  ///< unplugged (LIBUSB_TRANSFER_NO_DEVICE / LIBUSB_ERROR_NO_DEVICE)
  stall,      ///< endpoint halted (LIBUSB_TRANSFER_STALL): needs CLEAR_FEATURE(ENDPOINT_HALT)
  error,      ///< CRC, bit-stuffing, babble... (LIBUSB_TRANSFER_ERROR)
  overflow,   ///< the board sent more than the buffer (LIBUSB_TRANSFER_OVERFLOW)
  timed_out,  ///< LIBUSB_TRANSFER_TIMED_OUT (the driver sets no libusb timeouts; counted as error)
  cancelled,  ///< by the driver itself at stop (ignored)
};

/// Why the link latched a fault. `detail` in LatchedFault says the figure.
enum class LinkFault : std::uint8_t {
  none,
  board_fault,      ///< IN status fault bit; detail = the board's fault code
  board_watchdog,   ///< IN watchdog bit: the board's dead-man zeroed its output
  in_timeout,       ///< no new IN report; detail = periods
  stale_sequence,   ///< only repeated IN reports; detail = the stuck sequence number
  out_not_applied,  ///< the board's ack lags the OUT sequence; detail = periods
  unplugged,        ///< detail = 0
  stalled,          ///< detail = endpoint address
  out_queue_full,   ///< every OUT transfer still in flight; detail = how many
};

struct LatchedFault {
  LinkFault reason = LinkFault::none;
  std::uint32_t detail = 0;
};

struct SessionLimits {
  /// A fault latches when this many periods pass without a new IN report
  /// (or, with an ack field, when the ack lags the OUT sequence this much).
  int timeout_periods = 5;
  double period_s = 1e-3;  ///< for the words only
};

/// Counted since construction (plain integers: the RT thread owns them; the
/// device copies them to atomics for status()).
struct SessionCounters {
  std::uint64_t in_reports = 0;      ///< new IN reports accepted
  std::uint64_t stale_reports = 0;   ///< repeated or older sequence numbers
  std::uint64_t missed_reports = 0;  ///< gaps in the IN sequence (reports the host never saw)
  std::uint64_t short_reports = 0;
  std::uint64_t wrong_id_reports = 0;
  std::uint64_t transfer_errors = 0;  ///< error, overflow, timed out
  std::uint64_t held_periods = 0;     ///< periods without a new report (last position held)
  std::uint64_t out_reports = 0;      ///< OUT reports built
  std::uint32_t max_ack_lag = 0;      ///< largest OUT-to-ack lag seen, periods
};

class HostSession {
 public:
  HostSession(const ReportLayout& layout, const SessionLimits& limits);

  /// Forget the sequence history (after configure or a re-plug): the next IN
  /// report is accepted as new and its ack becomes the OUT sequence base.
  void restart() noexcept;

  // ---- read side, once per period ----
  /// Every IN completion since the last end_read(), in completion order.
  /// `endpoint` (the IN address) is the figure of a stall.
  void on_in(TransferOutcome outcome, std::span<const std::uint8_t> bytes, std::uint8_t endpoint) noexcept;
  /// Closes the period: `latest` is the newest accepted report (or the one
  /// held). ok: valid (new or held); error: no valid value this period
  /// (nothing received yet, or only errors); fault: latched.
  IoResult end_read(InReport& latest) noexcept;

  // ---- write side, once per period ----
  /// Builds the next OUT report (sequence + 1). Enable is forced off while a
  /// fault is latched; reset is set while a reset is in progress.
  /// `commands`: one per axis of the layout (missing axes get 0), all zero
  /// while the output is off.
  std::size_t make_out(std::span<const std::int64_t> commands, bool enable, std::uint32_t deadman_us,
                       std::span<std::uint8_t> buffer) noexcept;
  /// One axis.
  std::size_t make_out(std::int64_t command, bool enable, std::uint32_t deadman_us,
                       std::span<std::uint8_t> buffer) noexcept {
    return make_out(std::span<const std::int64_t>(&command, 1), enable, deadman_us, buffer);
  }
  /// How the last OUT transfer ended (or its submission: no_device / stall).
  void on_out(TransferOutcome outcome, std::uint8_t endpoint) noexcept;

  void latch(LinkFault reason, std::uint32_t detail) noexcept;
  const LatchedFault& fault() const noexcept { return fault_; }
  bool faulted() const noexcept { return fault_.reason != LinkFault::none; }

  /// Starts a fault reset: the latch opens, OUT reports carry the reset bit,
  /// and reports the board sent before it saw the reset (ack older than the
  /// first reset report) are not held against it. Returns the fault cleared.
  LatchedFault begin_reset() noexcept;
  /// True once the reset is decided: the first report the board sent after
  /// it saw a reset report (ack field) or the timeout_periods-th report
  /// (no ack field). If that report still has the fault or watchdog bit,
  /// the fault is latched again.
  bool reset_done() const noexcept { return !resetting_; }
  bool resetting() const noexcept { return resetting_; }

  const SessionCounters& counters() const noexcept { return counters_; }
  bool synced() const noexcept { return synced_; }
  std::uint32_t last_out_sequence() const noexcept { return out_sequence_; }

  /// The fault in words, with the figure (non-RT: allocates).
  std::string describe(const LatchedFault& fault) const;

 private:
  void accept(const InReport& report) noexcept;
  void check_status(const InReport& report) noexcept;
  bool reset_acknowledged(const InReport& report) const noexcept;

  ReportLayout layout_;
  SessionLimits limits_;
  SessionCounters counters_;
  LatchedFault fault_;

  bool synced_ = false;         // an IN report was accepted since restart()
  bool have_position_ = false;  // `latest_` is valid
  InReport latest_;
  std::uint32_t in_sequence_ = 0;
  std::uint32_t out_sequence_ = 0;  // last sent
  int periods_without_new_ = 0;
  bool new_this_period_ = false;
  bool errors_this_period_ = false;
  bool stale_since_new_ = false;
  std::uint32_t stale_sequence_ = 0;

  bool resetting_ = false;
  std::uint32_t reset_first_sequence_ = 0;
  int reset_reports_ = 0;
};

}  // namespace hapticd::drivers::usb_hid
