// The usb-hid driver's description (drivers/driver_description.hpp): its
// typed parameters, each key converted once into UsbHidConfig, and the
// factory of its hooks.
#include <charconv>
#include <cmath>
#include <stdexcept>

#include "drivers/driver_description.hpp"
#include "drivers/usb_hid/report_codec.hpp"
#include "drivers/usb_hid/usb_hid_config.hpp"
#include "drivers/usb_hid/usb_hid_device.hpp"

namespace hapticd::drivers::usb_hid {

namespace {

using P = ParameterSpec;

/// A layout key: its default in the field notation, checked by the codec.
P layout_field(const char* name, const char* help, const std::string& default_text) {
  return P::text(name, std::string(help) + " (OFFSET:TYPE, or none where optional)")
      .defaults_to(default_text);
}
P layout_bit(const char* name, const char* help, const BitField& default_bit) {
  return P::text(name, std::string(help) + " (OFFSET.BIT, or none)").defaults_to(to_string(default_bit));
}

/// A board with several axes (issue 22): how many, and what differs per axis.
std::vector<ParameterSpec> axes_parameters() {
  const auto per_axis = [](const char* name, const char* what, const char* example, const char* fallback) {
    return P::text(name, std::string("axes > 1: each axis' ") + what + ", comma-separated (\"" + example +
                             "\"); unset: " + fallback + " on every axis")
        .defaults_to("");
  };
  return {
      P::integer("axes", "",
                 "axes on the board: 1, or a Cartesian stage of 2 to 6 linear axes whose encoder and "
                 "command fields share one IN and one OUT report")
          .defaults_to(1.0)
          .at_least(1.0)
          .at_most(static_cast<double>(max_axes)),
      per_axis("axis_counts_per_unit", "encoder counts per metre", "20000,50000", "counts_per_unit"),
      per_axis("axis_command_full_scale", "force in N at the largest command", "2,5", "command_full_scale"),
      per_axis("axis_mass", "moving mass in kg, for the stability gate", "0.1,0.3", "mass"),
      per_axis("axis_damping", "viscous damping in N s/m, for the stability gate", "0,2", "damping"),
  };
}

std::vector<ParameterSpec> layout_parameters();

std::vector<ParameterSpec> usb_hid_parameters() {
  const UsbHidConfig c;
  std::vector<ParameterSpec> out = {
      motion_parameter("rotary (rad, N m) or linear (m, N)"),
      mass_parameter("moving inertia or mass, for the stability gate").defaults_to(c.mass),
      damping_parameter("viscous damping to ground, for the stability gate"),
      P::text("vendor_id", "USB vendor ID of the board, \"0x1209\" (`lsusb` lists it)"),
      P::text("product_id", "USB product ID, \"0x0001\""),
      P::text("serial", "serial number string, to choose among several boards (empty: any)").defaults_to(""),
      P::text("path", "bus and port chain, \"1-2.3\" as in sysfs and `lsusb -t` (empty: any)")
          .defaults_to(""),
      P::integer("interface", "", "interface number").defaults_to(0.0).at_least(0).at_most(255),
      P::text("in_endpoint", "interrupt IN endpoint address, \"0x81\" (auto: the first)").defaults_to("auto"),
      P::text("out_endpoint", "interrupt OUT endpoint address, \"0x01\" (auto: the first)")
          .defaults_to("auto"),
      P::number("counts_per_unit", "1/rev | 1/m", "encoder counts per revolution or per metre")
          .defaults_to(c.counts_per_unit)
          .above(0.0),
      P::number("command_full_scale", "N m | N",
                "force or torque at the largest command (+-32767 by default)")
          .defaults_to(c.command_full_scale)
          .above(0.0),
      P::choice("direction", {"normal", "inverted"}, "inverted flips the count and the command")
          .defaults_to("normal"),
      P::integer("deadman_periods", "periods",
                 "the board zeroes its output after this long without a new OUT report")
          .defaults_to(static_cast<double>(c.deadman_periods))
          .at_least(1)
          .at_most(1000),
      P::integer("timeout_periods", "periods",
                 "no new IN report (or the ack lagging) this long latches a fault")
          .defaults_to(static_cast<double>(c.timeout_periods))
          .at_least(2)
          .at_most(1000),
      P::integer("in_transfers", "", "IN transfers kept queued")
          .defaults_to(static_cast<double>(c.in_transfers))
          .at_least(2)
          .at_most(16),
      P::integer("out_transfers", "", "OUT transfers in the pool")
          .defaults_to(static_cast<double>(c.out_transfers))
          .at_least(1)
          .at_most(16),
      P::choice("events", {"loop", "thread"}, "where libusb events are handled (README.md: loop)")
          .defaults_to("loop"),
      P::integer("delay_periods", "periods",
                 "delay the link adds (-1: from the endpoints' polling intervals)")
          .defaults_to(-1.0)
          .at_least(-1)
          .at_most(64),
  };
  for (auto& p : layout_parameters()) out.push_back(std::move(p));
  for (auto& p : axes_parameters()) out.push_back(std::move(p));
  return out;
}

/// The report layout keys (README.md "Reports"), in the order of the reports.
std::vector<ParameterSpec> layout_parameters() {
  const ReportLayout d;
  return {
      P::integer("in_report_size", "bytes", "IN report size")
          .defaults_to(static_cast<double>(d.in.size))
          .at_least(1)
          .at_most(64),
      P::integer("in_report_id", "", "IN report ID in byte 0 (-1: none)")
          .defaults_to(-1.0)
          .at_least(-1)
          .at_most(255),
      layout_field("in_sequence", "the board's IN report counter", to_string(d.in.sequence)),
      layout_field("in_ack", "last OUT sequence the board applied", to_string(d.in.ack)),
      layout_field("in_position",
                   "encoder count; axes > 1: one field per axis, comma-separated, or axis 1's with the "
                   "next axes right after it",
                   to_string(d.in.position[0])),
      layout_bit("in_enabled_bit", "power stage on", d.in.enabled),
      layout_bit("in_fault_bit", "board fault latched", d.in.fault),
      layout_bit("in_watchdog_bit", "dead-man tripped", d.in.watchdog),
      layout_field("in_fault_code", "fault code", to_string(d.in.fault_code)),
      P::integer("out_report_size", "bytes", "OUT report size")
          .defaults_to(static_cast<double>(d.out.size))
          .at_least(1)
          .at_most(64),
      P::integer("out_report_id", "", "OUT report ID in byte 0 (-1: none)")
          .defaults_to(-1.0)
          .at_least(-1)
          .at_most(255),
      layout_field("out_sequence", "OUT report counter", to_string(d.out.sequence)),
      layout_field("out_command",
                   "signed duty or torque; axes > 1: one field per axis, comma-separated, or axis 1's "
                   "with the next axes right after it",
                   to_string(d.out.command[0])),
      layout_bit("out_enable_bit", "power stage on", d.out.enable),
      layout_bit("out_reset_bit", "fault reset request", d.out.reset),
      layout_field("out_deadman", "dead-man timeout in microseconds", to_string(d.out.deadman)),
  };
}

/// A text key parsed once: its notation's errors name the key.
template <class Parse>
auto parsed(const DriverParameters& p, const char* key, Parse parse) {
  const std::string& text = p.text(key);
  try {
    return parse(text);
  } catch (const std::invalid_argument& e) {
    throw ParameterError(key, std::string("device.usb-hid.") + key + ": " + e.what());
  }
}

std::uint8_t in_endpoint(std::string_view text) { return parse_endpoint_address(text, true); }
std::uint8_t out_endpoint(std::string_view text) { return parse_endpoint_address(text, false); }

std::string_view trimmed(std::string_view text) {
  while (!text.empty() && text.front() == ' ') text.remove_prefix(1);
  while (!text.empty() && text.back() == ' ') text.remove_suffix(1);
  return text;
}

std::vector<std::string_view> comma_items(std::string_view text) {
  std::vector<std::string_view> items;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t end = std::min(text.find(',', begin), text.size());
    items.push_back(trimmed(text.substr(begin, end - begin)));
    begin = end + 1;
  }
  return items;
}

/// in_position / out_command: one field (axis 1, the next axes right after
/// it) or one per axis.
AxisFields axis_fields(const DriverParameters& p, const char* key, std::size_t axes) {
  const std::vector<std::string_view> items = comma_items(p.text(key));
  if (items.size() != 1 && items.size() != axes)
    throw ParameterError(key, std::string("device.usb-hid.") + key + " has " + std::to_string(items.size()) +
                                  " fields for axes = " + std::to_string(axes) +
                                  "; accepted: one field (axis 1, the next axes right after it) or " +
                                  std::to_string(axes) + " comma-separated fields, one per axis");
  AxisFields fields{};
  for (std::size_t k = 0; k < items.size(); ++k)
    fields[k] = parsed(p, key, [&](std::string_view) { return parse_integer_field(items[k]); });
  return items.size() == 1 ? consecutive_fields(fields[0], axes) : fields;
}

/// What a per-axis key accepts: numbers in [low, high] (above low when
/// low_exclusive), in `unit`.
struct AxisRange {
  double low = 0.0;
  bool low_exclusive = false;
  double high = 0.0;
  const char* unit = "";
};

/// axis_mass and the other per-axis numbers: `axes` comma-separated numbers
/// in the key's range; unset: `fallback` on every axis.
std::vector<double> axis_numbers(const DriverParameters& p, const char* key, std::size_t axes,
                                 double fallback, const AxisRange& range) {
  if (!p.given(key)) return std::vector<double>(axes, fallback);
  const std::string& text = p.text(key);
  const std::vector<std::string_view> items = comma_items(text);
  std::vector<double> out;
  for (const std::string_view item : items) {
    double v = 0.0;
    const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), v);
    const bool above = range.low_exclusive ? v > range.low : v >= range.low;
    if (item.empty() || ec != std::errc{} || end != item.data() + item.size() || !std::isfinite(v) ||
        !above || v > range.high)
      break;
    out.push_back(v);
  }
  if (out.size() != axes || items.size() != axes)
    throw ParameterError(key, std::string("device.usb-hid.") + key + " = \"" + text +
                                  "\" is not accepted; accepted: " + std::to_string(axes) +
                                  " comma-separated numbers in " + (range.low_exclusive ? "(" : "[") +
                                  to_text(ParameterValue(range.low)) + ", " +
                                  to_text(ParameterValue(range.high)) + "] " + range.unit + ", one per axis");
  return out;
}

ReportLayout layout_from(const DriverParameters& p) {
  ReportLayout l;
  l.in.size = static_cast<std::size_t>(p.integer("in_report_size"));
  l.in.report_id = static_cast<int>(p.integer("in_report_id"));
  l.in.sequence = parsed(p, "in_sequence", parse_integer_field);
  l.in.ack = parsed(p, "in_ack", parse_integer_field);
  const auto axes = static_cast<std::size_t>(p.integer("axes"));
  l.in.position = axis_fields(p, "in_position", axes);
  l.in.enabled = parsed(p, "in_enabled_bit", parse_bit_field);
  l.in.fault = parsed(p, "in_fault_bit", parse_bit_field);
  l.in.watchdog = parsed(p, "in_watchdog_bit", parse_bit_field);
  l.in.fault_code = parsed(p, "in_fault_code", parse_integer_field);
  l.out.size = static_cast<std::size_t>(p.integer("out_report_size"));
  l.out.report_id = static_cast<int>(p.integer("out_report_id"));
  l.out.sequence = parsed(p, "out_sequence", parse_integer_field);
  l.out.command = axis_fields(p, "out_command", axes);
  l.out.enable = parsed(p, "out_enable_bit", parse_bit_field);
  l.out.reset = parsed(p, "out_reset_bit", parse_bit_field);
  l.out.deadman = parsed(p, "out_deadman", parse_integer_field);
  try {
    validate(l);
  } catch (const LayoutError& e) {
    throw ParameterError(e.key(), std::string("device.usb-hid.") + e.what());
  }
  return l;
}

/// The per-axis scales and model of a board with several axes (empty for one).
std::vector<UsbHidAxis> stage_axes(const DriverParameters& p) {
  const auto axes = static_cast<std::size_t>(p.integer("axes"));
  const char* keys[] = {"axis_counts_per_unit", "axis_command_full_scale", "axis_mass", "axis_damping"};
  if (axes == 1) {
    for (const char* key : keys)
      if (p.given(key))
        throw ParameterError(key, std::string("device.usb-hid.") + key +
                                      " is for a board with several axes; accepted with axes = 2 to " +
                                      std::to_string(max_axes) + " (one axis: " + std::string(key).substr(5) +
                                      ")");
    return {};
  }
  if (p.given("motion") && p.text("motion") != "linear")
    throw ParameterError("motion", "device.usb-hid.motion = \"" + p.text("motion") +
                                       "\" is not accepted with axes = " + std::to_string(axes) +
                                       "; accepted: \"linear\" (a Cartesian stage of linear axes, m and N)");
  namespace r = world::parameter_range;
  constexpr double max_counts_per_metre = 1e12;  // a picometre encoder, as the loopback's `counts`
  const auto counts = axis_numbers(p, "axis_counts_per_unit", axes, p.number("counts_per_unit"),
                                   {0.0, true, max_counts_per_metre, "counts per metre"});
  const auto scales = axis_numbers(p, "axis_command_full_scale", axes, p.number("command_full_scale"),
                                   {0.0, true, r::max_force, "N"});
  const auto masses =
      axis_numbers(p, "axis_mass", axes, p.number("mass"), {r::min_mass, false, r::max_mass, "kg"});
  const auto dampings =
      axis_numbers(p, "axis_damping", axes, p.number("damping"), {0.0, false, r::max_damping, "N s/m"});
  std::vector<UsbHidAxis> out(axes);
  for (std::size_t k = 0; k < axes; ++k) out[k] = {counts[k], scales[k], masses[k], dampings[k]};
  return out;
}

}  // namespace

UsbHidConfig usb_hid_config_from(const DriverParameters& p) {
  UsbHidConfig c;
  c.motion = p.text("motion") == "linear" ? Motion::linear : Motion::rotary;
  c.mass = p.number("mass");
  c.damping = p.number("damping");
  c.selector.vendor_id = parsed(p, "vendor_id", parse_usb_id);
  c.selector.product_id = parsed(p, "product_id", parse_usb_id);
  c.selector.serial = p.text("serial");
  c.selector.path = p.text("path");
  c.selector.interface_number = static_cast<int>(p.integer("interface"));
  c.selector.in_endpoint = parsed(p, "in_endpoint", in_endpoint);
  c.selector.out_endpoint = parsed(p, "out_endpoint", out_endpoint);
  c.counts_per_unit = p.number("counts_per_unit");
  c.command_full_scale = p.number("command_full_scale");
  c.inverted = p.text("direction") == "inverted";
  c.deadman_periods = static_cast<int>(p.integer("deadman_periods"));
  c.timeout_periods = static_cast<int>(p.integer("timeout_periods"));
  c.in_transfers = static_cast<int>(p.integer("in_transfers"));
  c.out_transfers = static_cast<int>(p.integer("out_transfers"));
  c.events = p.text("events") == "thread" ? EventHandling::thread : EventHandling::loop;
  c.delay_periods = static_cast<int>(p.integer("delay_periods"));
  c.layout = layout_from(p);
  c.axes = stage_axes(p);
  if (!c.axes.empty()) c.motion = Motion::linear;
  return c;
}

DriverDescription usb_hid_driver() {
  DriverDescription d;
  d.name = "usb-hid";
  d.summary = "USB encoder/motor board over libusb-1.0 (interrupt IN and OUT reports)";
  d.ready = true;
  d.parameters = usb_hid_parameters();
  d.make = [](const DriverParameters& p) -> std::unique_ptr<DeviceHooks> {
    return std::make_unique<UsbHidDevice>(usb_hid_config_from(p));
  };
  return d;
}

}  // namespace hapticd::drivers::usb_hid
