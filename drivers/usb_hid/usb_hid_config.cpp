#include "drivers/usb_hid/usb_hid_config.hpp"

#include <charconv>
#include <cmath>
#include <numbers>

#include "drivers/usb_hid/link_budget.hpp"

namespace hapticd::drivers::usb_hid {

namespace {

int parse_int(std::string_view key, std::string_view text, int minimum, int maximum) {
  int value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size() || value < minimum || value > maximum)
    throw ConfigError(std::string(key), std::string(key) + " = \"" + std::string(text) +
                                            "\" is not accepted; accepted: an integer from " +
                                            std::to_string(minimum) + " to " + std::to_string(maximum));
  return value;
}

double parse_positive(std::string_view key, std::string_view text) {
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(value) || value <= 0.0)
    throw ConfigError(std::string(key), std::string(key) + " = \"" + std::string(text) +
                                            "\" is not accepted; accepted: a finite number > 0");
  return value;
}

std::uint8_t parse_endpoint(std::string_view key, std::string_view text, bool in) {
  if (text == "auto") return 0;
  std::uint16_t value = 0;
  try {
    value = parse_usb_id(text);
  } catch (const std::invalid_argument&) {
    value = 0x100;
  }
  const bool direction_ok = ((value & 0x80U) != 0) == in;
  if (value > 0xFF || (value & 0x70U) != 0 || (value & 0x0FU) == 0 || !direction_ok)
    throw ConfigError(std::string(key),
                      std::string(key) + " = \"" + std::string(text) +
                          "\" is not accepted; accepted: \"auto\" or an " +
                          (in ? "IN endpoint address 0x81..0x8f" : "OUT endpoint address 0x01..0x0f"));
  return static_cast<std::uint8_t>(value);
}

template <class Parse>
auto layout_field(std::string_view key, std::string_view text, Parse parse) {
  try {
    return parse(text);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(std::string(key), std::string(key) + ": " + e.what());
  }
}

}  // namespace

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

double UsbHidConfig::position_per_count() const noexcept {
  const double unit = motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0;
  return (inverted ? -unit : unit) / counts_per_unit;
}

std::uint32_t UsbHidConfig::deadman_us(double period_s) const noexcept {
  return static_cast<std::uint32_t>(std::llround(deadman_periods * period_s * 1e6));
}

void UsbHidConfig::validate(double period_s) const {
  if (selector.vendor_id == 0 && selector.product_id == 0)
    throw ConfigError("vendor_id",
                      "vendor_id and product_id are required: the board's USB IDs (`lsusb` lists them)");
  try {
    usb_hid::validate(layout);
  } catch (const LayoutError& e) {
    throw ConfigError(e.key(), e.what());
  }
  if (layout.out.deadman.present()) {
    const auto largest = static_cast<std::uint64_t>(layout.out.deadman.largest());
    if (deadman_us(period_s) > largest)
      throw ConfigError("deadman_periods", "deadman_periods = " + std::to_string(deadman_periods) + " is " +
                                               format_duration(deadman_periods * period_s) +
                                               " at this period; out_deadman (" +
                                               to_string(layout.out.deadman) + ") holds at most " +
                                               std::to_string(largest) + " us");
  }
}

void set_parameter(UsbHidConfig& c, std::string_view key, std::string_view value) {
  const std::string k(key);
  try {
    if (key == "vendor_id") return void(c.selector.vendor_id = parse_usb_id(value));
    if (key == "product_id") return void(c.selector.product_id = parse_usb_id(value));
  } catch (const std::invalid_argument& e) {
    throw ConfigError(k, k + ": " + e.what());
  }
  if (key == "serial") return void(c.selector.serial = std::string(value));
  if (key == "path") return void(c.selector.path = std::string(value));
  if (key == "interface") return void(c.selector.interface_number = parse_int(key, value, 0, 255));
  if (key == "in_endpoint") return void(c.selector.in_endpoint = parse_endpoint(key, value, true));
  if (key == "out_endpoint") return void(c.selector.out_endpoint = parse_endpoint(key, value, false));
  if (key == "motion") {
    if (value != "rotary" && value != "linear")
      throw ConfigError(k, k + " = \"" + std::string(value) + "\" is not accepted; accepted: rotary, linear");
    return void(c.motion = value == "rotary" ? Motion::rotary : Motion::linear);
  }
  if (key == "counts_per_unit") return void(c.counts_per_unit = parse_positive(key, value));
  if (key == "command_full_scale") return void(c.command_full_scale = parse_positive(key, value));
  if (key == "direction") {
    if (value != "normal" && value != "inverted")
      throw ConfigError(k,
                        k + " = \"" + std::string(value) + "\" is not accepted; accepted: normal, inverted");
    return void(c.inverted = value == "inverted");
  }
  if (key == "deadman_periods") return void(c.deadman_periods = parse_int(key, value, 1, 1000));
  if (key == "timeout_periods") return void(c.timeout_periods = parse_int(key, value, 2, 1000));
  if (key == "in_transfers") return void(c.in_transfers = parse_int(key, value, 2, 16));
  if (key == "out_transfers") return void(c.out_transfers = parse_int(key, value, 1, 16));
  if (key == "events") {
    if (value != "loop" && value != "thread")
      throw ConfigError(k, k + " = \"" + std::string(value) + "\" is not accepted; accepted: loop, thread");
    return void(c.events = value == "loop" ? EventHandling::loop : EventHandling::thread);
  }
  if (key == "mass") return void(c.mass = parse_positive(key, value));
  if (key == "damping") {
    if (value == "0") return void(c.damping = 0.0);
    return void(c.damping = parse_positive(key, value));
  }
  if (key == "delay_periods") return void(c.delay_periods = parse_int(key, value, -1, 64));
  ReportLayout& l = c.layout;
  if (key == "in_report_size")
    return void(l.in.size = static_cast<std::size_t>(parse_int(key, value, 1, 64)));
  if (key == "out_report_size")
    return void(l.out.size = static_cast<std::size_t>(parse_int(key, value, 1, 64)));
  if (key == "in_report_id") return void(l.in.report_id = parse_int(key, value, -1, 255));
  if (key == "out_report_id") return void(l.out.report_id = parse_int(key, value, -1, 255));
  if (key == "in_sequence") return void(l.in.sequence = layout_field(key, value, parse_integer_field));
  if (key == "in_ack") return void(l.in.ack = layout_field(key, value, parse_integer_field));
  if (key == "in_position") return void(l.in.position = layout_field(key, value, parse_integer_field));
  if (key == "in_fault_code") return void(l.in.fault_code = layout_field(key, value, parse_integer_field));
  if (key == "in_enabled_bit") return void(l.in.enabled = layout_field(key, value, parse_bit_field));
  if (key == "in_fault_bit") return void(l.in.fault = layout_field(key, value, parse_bit_field));
  if (key == "in_watchdog_bit") return void(l.in.watchdog = layout_field(key, value, parse_bit_field));
  if (key == "out_sequence") return void(l.out.sequence = layout_field(key, value, parse_integer_field));
  if (key == "out_command") return void(l.out.command = layout_field(key, value, parse_integer_field));
  if (key == "out_deadman") return void(l.out.deadman = layout_field(key, value, parse_integer_field));
  if (key == "out_enable_bit") return void(l.out.enable = layout_field(key, value, parse_bit_field));
  if (key == "out_reset_bit") return void(l.out.reset = layout_field(key, value, parse_bit_field));
  throw ConfigError(k, "unknown usb-hid key \"" + k + "\"");
}

namespace {

template <class Parse>
auto parsed(const DriverParameters& p, const char* key, Parse parse) {
  try {
    return parse(p.text(key));
  } catch (const std::invalid_argument& e) {
    throw ParameterError(key, std::string("device.usb-hid.") + key + ": " + e.what());
  }
}

}  // namespace

UsbHidConfig usb_hid_config_from(const DriverParameters& p) {
  UsbHidConfig c;
  c.selector.vendor_id = parsed(p, "vendor_id", parse_usb_id);
  c.selector.product_id = parsed(p, "product_id", parse_usb_id);
  c.selector.serial = p.text("serial");
  c.selector.path = p.text("path");
  c.selector.interface_number = static_cast<int>(p.integer("interface"));
  // The endpoint, direction and layout texts go through the same checks as
  // set_parameter(), which names the key.
  for (const char* key : {"in_endpoint", "out_endpoint", "direction", "in_sequence", "in_ack", "in_position",
                          "in_enabled_bit", "in_fault_bit", "in_watchdog_bit", "in_fault_code",
                          "out_sequence", "out_command", "out_enable_bit", "out_reset_bit", "out_deadman"}) {
    try {
      set_parameter(c, key, p.text(key));
    } catch (const ConfigError& e) {
      throw ParameterError(e.key(), std::string("device.usb-hid.") + e.what());
    }
  }
  c.motion = p.text("motion") == "linear" ? Motion::linear : Motion::rotary;
  c.counts_per_unit = p.number("counts_per_unit");
  c.command_full_scale = p.number("command_full_scale");
  c.deadman_periods = static_cast<int>(p.integer("deadman_periods"));
  c.timeout_periods = static_cast<int>(p.integer("timeout_periods"));
  c.in_transfers = static_cast<int>(p.integer("in_transfers"));
  c.out_transfers = static_cast<int>(p.integer("out_transfers"));
  c.events = p.text("events") == "thread" ? EventHandling::thread : EventHandling::loop;
  c.mass = p.number("mass");
  c.damping = p.number("damping");
  c.delay_periods = static_cast<int>(p.integer("delay_periods"));
  c.layout.in.size = static_cast<std::size_t>(p.integer("in_report_size"));
  c.layout.in.report_id = static_cast<int>(p.integer("in_report_id"));
  c.layout.out.size = static_cast<std::size_t>(p.integer("out_report_size"));
  c.layout.out.report_id = static_cast<int>(p.integer("out_report_id"));
  try {
    validate(c.layout);
  } catch (const LayoutError& e) {
    throw ParameterError(e.key(), std::string("device.usb-hid.") + e.what());
  }
  return c;
}

}  // namespace hapticd::drivers::usb_hid
