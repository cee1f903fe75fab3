#include "sim/usb_hid/board_firmware.hpp"

namespace hapticd::drivers::usb_hid::sim {

bool BoardFirmware::on_out_report(std::span<const std::uint8_t> bytes, std::uint64_t now_us) noexcept {
  BoardCommand report;
  if (!read_out_report(bytes, report, axes_)) {
    ++counters_.bad_reports;
    return false;
  }
  // A report with the sequence number already applied is the host (or a
  // stuck USB stack) repeating itself: it must not keep the output alive.
  if (have_sequence_ && report.sequence == last_sequence_) {
    ++counters_.repeated_reports;
    return false;
  }
  have_sequence_ = true;
  last_sequence_ = report.sequence;
  ++counters_.out_reports;
  const std::uint32_t timeout = report.deadman_us != 0 ? report.deadman_us : default_deadman_us;
  deadline_us_ = now_us + timeout;
  if (report.reset && (watchdog_ || (fault_code_ != 0 && !cause_present_))) {
    watchdog_ = false;
    if (!cause_present_) fault_code_ = 0;
    ++counters_.resets;
  }
  enable_ = report.enable;
  command_ = report.command;
  return true;
}

void BoardFirmware::on_tick(std::uint64_t now_us) noexcept {
  if (output_on() && now_us > deadline_us_) {
    watchdog_ = true;  // latched until a reset report: the host must notice
    ++counters_.watchdog_trips;
  }
}

std::size_t BoardFirmware::make_in_report(std::span<const std::int64_t> encoder_counts,
                                          std::span<std::uint8_t> buffer) noexcept {
  ++in_sequence_;  // u16: wraps as the protocol's sequence does
  BoardStatus report;
  report.sequence = in_sequence_;
  report.ack = have_sequence_ ? last_sequence_ : 0;
  for (std::size_t k = 0; k < axes_ && k < encoder_counts.size(); ++k)  // the 32-bit counter wraps
    report.position[k] = static_cast<std::int32_t>(static_cast<std::uint32_t>(encoder_counts[k]));
  report.enabled = output_on();
  report.fault = fault_code_ != 0;
  report.watchdog = watchdog_;
  report.fault_code = fault_code_ != 0 ? fault_code_
                      : watchdog_      ? static_cast<std::uint8_t>(FaultCode::watchdog)
                                       : std::uint8_t{0};
  ++counters_.in_reports;
  return write_in_report(report, buffer, axes_);
}

void BoardFirmware::raise_fault(FaultCode code, bool cause_present) noexcept {
  fault_code_ = static_cast<std::uint8_t>(code);
  cause_present_ = cause_present;
}

}  // namespace hapticd::drivers::usb_hid::sim
