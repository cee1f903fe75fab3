#pragma once
/// \file
/// The board's side of the protocol, as its firmware must implement it
/// (README.md "What the board's firmware must do"): the dead-man on the OUT
/// sequence number, enable, fault latch and reset, and the IN report. Pure
/// and allocation-free so that it reads like the C a lab flashes (the
/// README's sketch is this logic); the simulated board runs it between the
/// emulated USB endpoints and the shared plant simulator.
///
/// Time is the board's own clock in microseconds (on a real board: the USB
/// start-of-frame counter or a hardware timer), passed in by the caller.
/// The reports are read and written with the board's own decoder
/// (board_reports.hpp, the README's default layout), not the driver's codec.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "sim/usb_hid/board_reports.hpp"

namespace hapticd::drivers::usb_hid::sim {

/// The firmware's dead-man timeout when the OUT layout has no dead-man field
/// or the host sends 0: 20 ms, the longest a hand should feel a stale torque.
inline constexpr std::uint32_t default_deadman_us = 20000;

struct FirmwareCounters {
  std::uint64_t out_reports = 0;       ///< new OUT reports applied
  std::uint64_t repeated_reports = 0;  ///< same sequence as the last one: ignored, no dead-man feed
  std::uint64_t bad_reports = 0;       ///< short or with the wrong report ID: ignored
  std::uint64_t in_reports = 0;        ///< IN reports built
  std::uint64_t watchdog_trips = 0;
  std::uint64_t resets = 0;  ///< reset requests that cleared a fault or a trip
};

class BoardFirmware {
 public:
  /// `axes`: 1 to max_board_axes encoder/command pairs in the reports
  /// (board_reports.hpp); the enable, fault and dead-man are the board's,
  /// for every axis at once.
  explicit BoardFirmware(std::size_t axes = 1) noexcept : axes_(axes) {}

  /// One OUT report arrived at `now_us`. Returns true if it was new (applied).
  bool on_out_report(std::span<const std::uint8_t> bytes, std::uint64_t now_us) noexcept;
  /// Timer tick (every frame on a real board): trips the dead-man when the
  /// output is on and no new OUT report arrived within the timeout.
  void on_tick(std::uint64_t now_us) noexcept;
  /// Builds the next IN report (sequence + 1) with this encoder count.
  /// The count is the board's 32-bit encoder counter (it wraps).
  std::size_t make_in_report(std::int64_t encoder_counts, std::span<std::uint8_t> buffer) noexcept {
    return make_in_report(std::span<const std::int64_t>(&encoder_counts, 1), buffer);
  }
  /// Every axis' count (encoder_counts.size() == axes()).
  std::size_t make_in_report(std::span<const std::int64_t> encoder_counts,
                             std::span<std::uint8_t> buffer) noexcept;

  /// Hardware fault detected (over-current, ...): output off, latched.
  /// `cause_present` keeps a reset from clearing it until clear_cause().
  void raise_fault(FaultCode code, bool cause_present = true) noexcept;
  void clear_cause() noexcept { cause_present_ = false; }

  /// The amplifier's command in counts of the OUT command field (0 when off).
  std::int16_t output(std::size_t axis = 0) const noexcept {
    return output_on() ? command_[axis] : std::int16_t{0};
  }
  std::size_t axes() const noexcept { return axes_; }
  bool output_on() const noexcept { return enable_ && fault_code_ == 0 && !watchdog_; }
  bool watchdog_tripped() const noexcept { return watchdog_; }
  std::uint32_t fault_code() const noexcept { return fault_code_; }
  std::uint32_t last_sequence() const noexcept { return last_sequence_; }
  const FirmwareCounters& counters() const noexcept { return counters_; }

 private:
  std::size_t axes_ = 1;
  FirmwareCounters counters_;
  bool have_sequence_ = false;
  std::uint16_t last_sequence_ = 0;
  std::uint16_t in_sequence_ = 0;
  std::uint64_t deadline_us_ = 0;
  std::array<std::int16_t, max_board_axes> command_{};
  bool enable_ = false;
  bool watchdog_ = false;
  std::uint8_t fault_code_ = 0;
  bool cause_present_ = false;
};

}  // namespace hapticd::drivers::usb_hid::sim
