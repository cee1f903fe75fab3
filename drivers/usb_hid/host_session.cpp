#include "drivers/usb_hid/host_session.hpp"

#include <cstdio>

#include "drivers/usb_hid/link_budget.hpp"

namespace hapticd::drivers::usb_hid {

HostSession::HostSession(const ReportLayout& layout, const SessionLimits& limits)
    : layout_(layout), limits_(limits) {}

void HostSession::restart() noexcept {
  synced_ = false;
  have_position_ = false;
  periods_without_new_ = 0;
  new_this_period_ = errors_this_period_ = stale_since_new_ = false;
}

void HostSession::on_in(TransferOutcome outcome, std::span<const std::uint8_t> bytes,
                        std::uint8_t endpoint) noexcept {
  switch (outcome) {
    case TransferOutcome::completed:
      break;
    case TransferOutcome::no_device:
      latch(LinkFault::unplugged, 0);
      return;
    case TransferOutcome::stall:
      latch(LinkFault::stalled, endpoint);
      return;
    case TransferOutcome::cancelled:
      return;
    case TransferOutcome::error:
    case TransferOutcome::overflow:
    case TransferOutcome::timed_out:
      ++counters_.transfer_errors;
      errors_this_period_ = true;
      return;
  }
  InReport report;
  switch (decode_in(bytes, layout_.in, report)) {
    case DecodeStatus::short_report:
      ++counters_.short_reports;
      errors_this_period_ = true;
      return;
    case DecodeStatus::wrong_report_id:
      ++counters_.wrong_id_reports;
      errors_this_period_ = true;
      return;
    case DecodeStatus::ok:
      break;
  }
  if (!synced_) {
    synced_ = true;
    // Continue the board's OUT sequence: a restarted host must not look
    // like a lagging one, and its first report must be new to the board.
    if (layout_.in.ack.present()) out_sequence_ = report.ack & layout_.out.sequence.mask();
    if (resetting_) reset_first_sequence_ = next_sequence(out_sequence_, layout_.out.sequence);
    accept(report);
    return;
  }
  const std::int64_t step = sequence_distance(in_sequence_, report.sequence, layout_.in.sequence);
  if (step <= 0) {  // a repeat or an older report: the firmware did not update it
    ++counters_.stale_reports;
    stale_since_new_ = true;
    stale_sequence_ = report.sequence;
    return;
  }
  counters_.missed_reports += static_cast<std::uint64_t>(step - 1);
  accept(report);
}

void HostSession::accept(const InReport& report) noexcept {
  latest_ = report;
  have_position_ = true;
  in_sequence_ = report.sequence;
  new_this_period_ = true;
  stale_since_new_ = false;
  ++counters_.in_reports;
  check_status(report);
}

bool HostSession::reset_acknowledged(const InReport& report) const noexcept {
  if (!layout_.in.ack.present()) return true;
  return sequence_distance(reset_first_sequence_, report.ack, layout_.out.sequence) >= 0;
}

void HostSession::check_status(const InReport& report) noexcept {
  if (resetting_) {
    // Reports the board sent before it saw the reset do not count against
    // it: with an ack field, those acking an older OUT report; without one,
    // the first timeout_periods reports.
    if (layout_.in.ack.present()) {
      if (!reset_acknowledged(report)) return;
    } else if (++reset_reports_ < limits_.timeout_periods) {
      return;
    }
    resetting_ = false;  // this report decides: clean, or the fault again
  }
  if (report.fault) latch(LinkFault::board_fault, report.fault_code);
  if (report.watchdog) latch(LinkFault::board_watchdog, 0);
  if (layout_.in.ack.present()) {
    const std::int64_t lag = sequence_distance(report.ack, out_sequence_, layout_.out.sequence);
    if (lag > 0 && static_cast<std::uint32_t>(lag) > counters_.max_ack_lag)
      counters_.max_ack_lag = static_cast<std::uint32_t>(lag);
    if (lag > limits_.timeout_periods) latch(LinkFault::out_not_applied, static_cast<std::uint32_t>(lag));
  }
}

IoResult HostSession::end_read(InReport& latest) noexcept {
  if (new_this_period_) {
    periods_without_new_ = 0;
  } else {
    ++periods_without_new_;
    if (have_position_) ++counters_.held_periods;
    if (periods_without_new_ >= limits_.timeout_periods) {
      if (stale_since_new_)
        latch(LinkFault::stale_sequence, stale_sequence_);
      else
        latch(LinkFault::in_timeout, static_cast<std::uint32_t>(periods_without_new_));
    }
  }
  const bool fresh = new_this_period_;
  const bool errors = errors_this_period_;
  new_this_period_ = errors_this_period_ = false;
  latest = latest_;
  if (faulted()) return IoResult::fault;
  if (!have_position_ || (!fresh && errors)) return IoResult::error;
  return IoResult::ok;
}

std::size_t HostSession::make_out(std::span<const std::int64_t> commands, bool enable,
                                  std::uint32_t deadman_us, std::span<std::uint8_t> buffer) noexcept {
  out_sequence_ = next_sequence(out_sequence_, layout_.out.sequence);
  OutReport report;
  report.sequence = out_sequence_;
  const bool on = enable && !faulted() && !resetting_;
  for (std::size_t k = 0; k < commands.size() && k < report.command.size(); ++k)
    report.command[k] = on ? commands[k] : 0;
  report.enable = on;
  report.reset = resetting_;
  report.deadman_us = deadman_us;
  ++counters_.out_reports;
  return encode_out(report, layout_.out, buffer);
}

void HostSession::on_out(TransferOutcome outcome, std::uint8_t endpoint) noexcept {
  switch (outcome) {
    case TransferOutcome::completed:
    case TransferOutcome::cancelled:
      return;
    case TransferOutcome::no_device:
      latch(LinkFault::unplugged, 0);
      return;
    case TransferOutcome::stall:
      latch(LinkFault::stalled, endpoint);
      return;
    case TransferOutcome::error:
    case TransferOutcome::overflow:
    case TransferOutcome::timed_out:
      ++counters_.transfer_errors;
      return;
  }
}

void HostSession::latch(LinkFault reason, std::uint32_t detail) noexcept {
  if (faulted()) return;  // the first reason is the one the operator needs
  fault_ = LatchedFault{reason, detail};
  resetting_ = false;
}

LatchedFault HostSession::begin_reset() noexcept {
  const LatchedFault cleared = fault_;
  fault_ = LatchedFault{};
  resetting_ = true;
  reset_first_sequence_ = next_sequence(out_sequence_, layout_.out.sequence);
  reset_reports_ = 0;
  periods_without_new_ = 0;
  stale_since_new_ = false;
  return cleared;
}

std::string HostSession::describe(const LatchedFault& fault) const {
  char text[200];
  const auto periods = [this](std::uint32_t n) {
    return std::to_string(n) + " periods (" + format_duration(n * limits_.period_s) + ")";
  };
  switch (fault.reason) {
    case LinkFault::none:
      return "";
    case LinkFault::board_fault:
      std::snprintf(text, sizeof text, " (code 0x%02x)", static_cast<unsigned>(fault.detail));
      return "board fault: " + fault_code_text(fault.detail) + text;
    case LinkFault::board_watchdog:
      return "board dead-man tripped: it saw no new OUT report in time and zeroed its output";
    case LinkFault::in_timeout:
      return "no IN report from the board for " + periods(fault.detail);
    case LinkFault::stale_sequence:
      return "the board repeats IN report sequence " + std::to_string(fault.detail) + " for " +
             periods(static_cast<std::uint32_t>(limits_.timeout_periods)) +
             " (its firmware stopped updating)";
    case LinkFault::out_not_applied:
      return "the board has not applied an OUT report for " + periods(fault.detail) +
             " (its ack lags the OUT sequence)";
    case LinkFault::unplugged:
      return "USB board unplugged (LIBUSB_ERROR_NO_DEVICE)";
    case LinkFault::stalled:
      std::snprintf(text, sizeof text, "endpoint 0x%02x stalled (halt feature set by the board)",
                    static_cast<unsigned>(fault.detail));
      return text;
    case LinkFault::out_queue_full:
      return "the board accepts no OUT report: all " + std::to_string(fault.detail) +
             " OUT transfers still in flight";
  }
  return "unknown link fault";
}

}  // namespace hapticd::drivers::usb_hid
