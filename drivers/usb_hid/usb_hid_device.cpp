#include "drivers/usb_hid/usb_hid_device.hpp"

#include <cmath>

#include "drivers/usb_hid/link_budget.hpp"

namespace hapticd::drivers::usb_hid {

UsbHidDevice::UsbHidDevice(const UsbHidConfig& config) : link_(config) {}

UsbHidDevice::~UsbHidDevice() { close(); }

void UsbHidDevice::configure(const LoopContext& loop) {
  link_.set_stop(loop.stop);
  link_.configure(loop.period_s);
}

void UsbHidDevice::enable() { link_.enable(); }

std::string UsbHidDevice::clear_fault() { return link_.clear_fault(); }

void UsbHidDevice::disable() noexcept { link_.disable(); }

void UsbHidDevice::close() noexcept { link_.close(); }

IoResult UsbHidDevice::read(Reading& out) noexcept { return link_.read(out); }

IoResult UsbHidDevice::write(double force) noexcept { return link_.write(force); }

DeviceModel UsbHidDevice::model() const {
  const UsbHidConfig& c = link_.config();
  const OpenedBoard& board = link_.board();
  DeviceModel m;
  m.motion = c.motion;
  m.effective_mass = c.mass;
  m.viscous_damping = c.damping;
  m.position_resolution = std::abs(c.position_per_count());
  const auto in = interrupt_interval_s(board.in.speed, board.in.b_interval);
  const auto out = interrupt_interval_s(board.out.speed, board.out.b_interval);
  m.delay_periods = c.delay_periods >= 0 ? c.delay_periods
                    : in && out          ? link_delay_periods(*in, *out, link_.period_s())
                                         : 0;
  m.source = "config";
  m.description = "usb-hid board " + board.description;
  return m;
}

DeviceHealth UsbHidDevice::health() const {
  const LinkStatus l = link_.status();
  DeviceHealth s;
  s.faulted = l.fault.reason != LinkFault::none;
  s.fault_reason = l.fault_text;
  const TransportCounters& t = l.transport;
  if (t.hotplug_arrivals > 0 && l.fault.reason == LinkFault::unplugged)
    s.last_error = "the board was plugged in again: fault clear re-opens it";
  s.counters = {{"in_reports", l.session.in_reports},
                {"out_reports", l.session.out_reports},
                {"held_periods", l.session.held_periods},
                {"stale_reports", l.session.stale_reports},
                {"missed_reports", l.session.missed_reports},
                {"short_reports", l.session.short_reports},
                {"transfer_errors", l.session.transfer_errors},
                {"max_ack_lag_periods", l.session.max_ack_lag},
                {"hotplug_arrivals", t.hotplug_arrivals},
                {"hotplug_departures", t.hotplug_departures},
                {"reopens", l.reopens},
                {"completion_ring_overflows", t.ring_overflows}};
  return s;
}

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

std::vector<ParameterSpec> usb_hid_parameters() {
  const ReportLayout d;
  const UsbHidConfig c;
  return {
      P::text("vendor_id", "USB vendor ID of the board, \"0x1209\" (`lsusb` lists it)"),
      P::text("product_id", "USB product ID, \"0x0001\""),
      P::text("serial", "serial number string, to choose among several boards (empty: any)").defaults_to(""),
      P::text("path", "bus and port chain, \"1-2.3\" as in sysfs and `lsusb -t` (empty: any)")
          .defaults_to(""),
      P::integer("interface", "", "interface number").defaults_to(0.0).at_least(0).at_most(255),
      P::text("in_endpoint", "interrupt IN endpoint address, \"0x81\" (auto: the first)").defaults_to("auto"),
      P::text("out_endpoint", "interrupt OUT endpoint address, \"0x01\" (auto: the first)")
          .defaults_to("auto"),
      P::choice("motion", {"rotary", "linear"}, "rotary (rad, N m) or linear (m, N)").defaults_to("rotary"),
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
      P::number("mass", "kg m^2 | kg", "moving inertia or mass, for the stability gate")
          .defaults_to(c.mass)
          .above(0.0),
      P::number("damping", "N m s/rad | N s/m", "viscous damping to ground, for the stability gate")
          .defaults_to(c.damping)
          .at_least(0.0),
      P::integer("delay_periods", "periods",
                 "delay the link adds (-1: from the endpoints' polling intervals)")
          .defaults_to(-1.0)
          .at_least(-1)
          .at_most(64),
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
      layout_field("in_position", "encoder count", to_string(d.in.position)),
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
      layout_field("out_command", "signed duty or torque", to_string(d.out.command)),
      layout_bit("out_enable_bit", "power stage on", d.out.enable),
      layout_bit("out_reset_bit", "fault reset request", d.out.reset),
      layout_field("out_deadman", "dead-man timeout in microseconds", to_string(d.out.deadman)),
  };
}

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
