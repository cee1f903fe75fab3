#include "drivers/usb_hid/usb_hid_config.hpp"

#include <charconv>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "drivers/usb_hid/link_budget.hpp"

namespace hapticd::drivers::usb_hid {

std::uint16_t parse_usb_id(std::string_view text) {
  unsigned value = 0;
  const bool hex = text.starts_with("0x") || text.starts_with("0X");
  const std::string_view digits = hex ? text.substr(2) : text;
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value, hex ? 16 : 10);
  if (digits.empty() || ec != std::errc{} || end != digits.data() + digits.size() || value > 0xFFFF)
    throw std::invalid_argument("\"" + std::string(text) +
                                "\" is not a 16-bit USB ID; accepted: 0x0000..0xffff");
  return static_cast<std::uint16_t>(value);
}

std::uint8_t parse_endpoint_address(std::string_view text, bool in) {
  if (text == "auto") return 0;
  std::uint16_t value = 0x100;  // refused below unless the text is an ID
  try {
    value = parse_usb_id(text);
  } catch (const std::invalid_argument&) {
  }
  // USB 2.0 9.6.6 bEndpointAddress: bit 7 the direction, bits 3..0 the
  // number (0 is the control endpoint), bits 6..4 reserved.
  const bool direction_ok = ((value & 0x80U) != 0) == in;
  if (value > 0xFF || (value & 0x70U) != 0 || (value & 0x0FU) == 0 || !direction_ok)
    throw std::invalid_argument("\"" + std::string(text) + "\" is not accepted; accepted: \"auto\" or an " +
                                (in ? "IN endpoint address 0x81..0x8f" : "OUT endpoint address 0x01..0x0f"));
  return static_cast<std::uint8_t>(value);
}

double UsbHidConfig::position_per_count() const noexcept {
  const double unit = motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0;
  return (inverted ? -unit : unit) / counts_per_unit;
}

double UsbHidConfig::position_per_count(std::size_t k) const noexcept {
  if (axes.empty()) return position_per_count();
  return (inverted ? -1.0 : 1.0) / axes[k].counts_per_unit;  // linear: m per count
}

std::uint32_t UsbHidConfig::deadman_us(double period_s) const noexcept {
  return static_cast<std::uint32_t>(std::llround(deadman_periods * period_s * 1e6));
}

void UsbHidConfig::validate(double period_s) const {
  if (selector.vendor_id == 0 && selector.product_id == 0)
    throw DeviceError("vendor_id and product_id are required: the board's USB IDs (`lsusb` lists them)",
                      "vendor_id");
  try {
    usb_hid::validate(layout);
  } catch (const LayoutError& e) {
    throw DeviceError(e.what(), e.key());
  }
  static_assert(max_report_axes == static_cast<std::size_t>(max_axes), "one axis capacity");
  if (layout.axes() != axis_count())
    throw DeviceError("the report layout carries " + std::to_string(layout.axes()) +
                          " axes but axes = " + std::to_string(axis_count()) +
                          "; accepted: one in_position and one out_command per axis",
                      "axes");
  if (layout.out.deadman.present()) {
    const auto largest = static_cast<std::uint64_t>(layout.out.deadman.largest());
    if (deadman_us(period_s) > largest)
      throw DeviceError("deadman_periods = " + std::to_string(deadman_periods) + " is " +
                            format_duration(deadman_periods * period_s) + " at this period; out_deadman (" +
                            to_string(layout.out.deadman) + ") holds at most " + std::to_string(largest) +
                            " us",
                        "deadman_periods");
  }
}

}  // namespace hapticd::drivers::usb_hid
