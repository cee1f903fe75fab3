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

}  // namespace hapticd::drivers::usb_hid
