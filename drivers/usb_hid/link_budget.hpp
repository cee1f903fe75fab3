#pragma once
/// \file
/// Can an interrupt endpoint carry one report per control period? Pure
/// arithmetic on the endpoint descriptor (USB 2.0 9.6.6, Table 9-13; USB
/// 3.2 9.6.6 for SuperSpeed), no system calls. README.md "Timing budget"
/// explains the figures.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace hapticd::drivers::usb_hid {

enum class UsbSpeed : std::uint8_t { unknown, low, full, high, super, super_plus };
std::string_view to_string(UsbSpeed speed) noexcept;  ///< "full speed (12 Mbit/s)", ...

/// What the driver reads from an interrupt endpoint descriptor.
struct EndpointInfo {
  std::uint8_t address = 0;             ///< bEndpointAddress (bit 7 = IN)
  std::uint16_t max_packet_size = 0;    ///< wMaxPacketSize bits 0..10
  std::uint8_t extra_transactions = 0;  ///< wMaxPacketSize bits 11..12 (high-bandwidth high speed)
  std::uint8_t b_interval = 0;
  UsbSpeed speed = UsbSpeed::unknown;
};

/// The polling interval the descriptor asks for, in seconds:
/// low speed bInterval ms (10..255),
/// full speed bInterval ms (1..255),
/// high speed and SuperSpeed 2^(bInterval-1) x 125 us (bInterval 1..16).
/// nullopt: bInterval out of range for that speed, or speed unknown.
std::optional<double> interrupt_interval_s(UsbSpeed speed, std::uint8_t b_interval) noexcept;

/// Bytes the endpoint moves per interval (max packet x (1 + extra transactions)).
std::size_t bytes_per_interval(const EndpointInfo& ep) noexcept;

/// "" if the endpoint carries a `report_size`-byte report every `period_s`,
/// else one line with the figures, e.g. "IN endpoint 0x81 is polled every
/// 1 ms (full speed (12 Mbit/s), bInterval 1): a 500 us period needs ...".
std::string check_endpoint(const EndpointInfo& ep, double period_s, std::size_t report_size);

/// Periods of delay the link adds at most: the IN sample can be one IN
/// interval old and the OUT report lands up to one OUT interval after it
/// is queued, so ceil((in + out) / period). The stability gate uses it.
int link_delay_periods(double in_interval_s, double out_interval_s, double period_s) noexcept;

/// "1 ms", "125 us", "2.5 ms": for messages.
std::string format_duration(double seconds);

}  // namespace hapticd::drivers::usb_hid
