#include "drivers/usb_hid/link_budget.hpp"

#include <cmath>
#include <cstdio>

namespace hapticd::drivers::usb_hid {

namespace {
constexpr double frame_s = 1e-3;         // full/low speed frame (USB 2.0 8.4.3.1)
constexpr double microframe_s = 125e-6;  // high speed microframe, SuperSpeed service interval unit

/// The shortest interval a board of this speed can ask for, in words.
std::string fastest(UsbSpeed speed) {
  switch (speed) {
    case UsbSpeed::low:
      return "a low-speed board is polled at most every 10 ms";
    case UsbSpeed::full:
      return "a full-speed board is polled at most every 1 ms (bInterval 1)";
    default:
      return "a high-speed board is polled at most every 125 us (bInterval 1)";
  }
}
}  // namespace

std::string_view to_string(UsbSpeed speed) noexcept {
  switch (speed) {
    case UsbSpeed::low:
      return "low speed (1.5 Mbit/s)";
    case UsbSpeed::full:
      return "full speed (12 Mbit/s)";
    case UsbSpeed::high:
      return "high speed (480 Mbit/s)";
    case UsbSpeed::super:
      return "SuperSpeed (5 Gbit/s)";
    case UsbSpeed::super_plus:
      return "SuperSpeed+ (10 Gbit/s)";
    case UsbSpeed::unknown:
      break;
  }
  return "unknown speed";
}

std::optional<double> interrupt_interval_s(UsbSpeed speed, std::uint8_t b_interval) noexcept {
  switch (speed) {
    case UsbSpeed::low:
      if (b_interval < 10) return std::nullopt;
      return b_interval * frame_s;
    case UsbSpeed::full:
      if (b_interval < 1) return std::nullopt;
      return b_interval * frame_s;
    case UsbSpeed::high:
    case UsbSpeed::super:
    case UsbSpeed::super_plus:
      if (b_interval < 1 || b_interval > 16) return std::nullopt;
      return std::ldexp(microframe_s, b_interval - 1);
    case UsbSpeed::unknown:
      break;
  }
  return std::nullopt;
}

std::size_t bytes_per_interval(const EndpointInfo& ep) noexcept {
  return std::size_t{ep.max_packet_size} * (1U + ep.extra_transactions);
}

std::string format_duration(double seconds) {
  char text[32];
  if (seconds >= 1e-3)
    std::snprintf(text, sizeof text, "%g ms", seconds * 1e3);
  else
    std::snprintf(text, sizeof text, "%g us", seconds * 1e6);
  return text;
}

std::string check_endpoint(const EndpointInfo& ep, double period_s, std::size_t report_size) {
  char address[8];
  std::snprintf(address, sizeof address, "0x%02x", static_cast<unsigned>(ep.address));
  const std::string name = std::string((ep.address & 0x80U) != 0 ? "IN" : "OUT") + " endpoint " + address;
  const std::optional<double> interval = interrupt_interval_s(ep.speed, ep.b_interval);
  if (ep.speed == UsbSpeed::unknown)
    return name + ": the bus speed is unknown, so its polling interval (bInterval " +
           std::to_string(ep.b_interval) + ") cannot be checked against the period";
  if (!interval)
    return name + " has bInterval " + std::to_string(ep.b_interval) + ", which is not valid at " +
           std::string(to_string(ep.speed));
  if (bytes_per_interval(ep) < report_size)
    return name + " carries " + std::to_string(bytes_per_interval(ep)) +
           " bytes per interval (wMaxPacketSize " + std::to_string(ep.max_packet_size) + ", " +
           std::string(to_string(ep.speed)) + "): the report is " + std::to_string(report_size) + " bytes";
  // A tolerance of 1 ns: 0.001 s and 1e-3 * 1 must compare equal.
  if (*interval > period_s + 1e-9)
    return name + " is polled every " + format_duration(*interval) + " (" + std::string(to_string(ep.speed)) +
           ", bInterval " + std::to_string(ep.b_interval) + "): a " + format_duration(period_s) +
           " period needs one report per period; " + fastest(ep.speed);
  return {};
}

int link_delay_periods(double in_interval_s, double out_interval_s, double period_s) noexcept {
  if (!(period_s > 0.0)) return 0;
  return static_cast<int>(std::ceil((in_interval_s + out_interval_s) / period_s - 1e-9));
}

}  // namespace hapticd::drivers::usb_hid
