#include "drivers/usb_hid/usb_hid_device.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "drivers/usb_hid/link_budget.hpp"

namespace hapticd::drivers::usb_hid {

namespace {

SessionLimits limits_for(const UsbHidConfig& config, double period_s) {
  SessionLimits limits;
  limits.timeout_periods = config.timeout_periods;
  limits.period_s = period_s;
  return limits;
}

/// False on the timeout, or as soon as `stop` is requested.
template <class Done>
bool wait_until(double timeout_s, Done done, const StopToken& stop = {}) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() >= give_up || stop.stop_requested()) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return true;
}

void store(std::atomic<std::uint64_t>& a, std::uint64_t v) noexcept { a.store(v, std::memory_order_relaxed); }

}  // namespace

UsbHidDevice::UsbHidDevice(const UsbHidConfig& config)
    : config_(config), session_(config.layout, limits_for(config, 1e-3)) {}

UsbHidDevice::~UsbHidDevice() { close(); }

// ---- non-RT lifecycle -------------------------------------------------------

void UsbHidDevice::configure(const LoopContext& loop) {
  stop_ = loop.stop;
  period_s_ = loop.period_s;
  config_.validate(period_s_);
  deadman_us_ = config_.layout.out.deadman.present() ? config_.deadman_us(period_s_) : 0;
  session_ = HostSession(config_.layout, limits_for(config_, period_s_));
  open_board();
  // A tripped dead-man is what a previous hapticd leaves: enable() resets it.
  if (exchange_read() == IoResult::fault && session_.fault().reason != LinkFault::board_watchdog)
    throw DeviceError("the board (" + board_.description +
                      ") is in fault at start-up: " + session_.describe(session_.fault()));
}

void UsbHidDevice::open_board() {
  TransportOptions options;
  options.events = config_.events;
  options.in_transfers = config_.in_transfers;
  options.out_transfers = config_.out_transfers;
  options.out_size = config_.layout.out.size;
  try {
    transport_ =
        std::make_unique<UsbTransport>(options, config_.selector.vendor_id, config_.selector.product_id);
    board_ = transport_->open(config_.selector);
  } catch (const TransportError& e) {
    transport_.reset();
    throw DeviceError(e.what(), e.key());
  }
  reopen_checks();
  set_description();
}

/// After open(): the endpoints carry the period, the IN transfers are queued
/// and the board answers. Closes and throws DeviceError otherwise.
void UsbHidDevice::reopen_checks() {
  const std::string in = check_endpoint(board_.in, period_s_, config_.layout.in.size);
  const std::string out = check_endpoint(board_.out, period_s_, config_.layout.out.size);
  if (!in.empty() || !out.empty()) {
    transport_->close();
    throw DeviceError(in.empty() ? out : in);
  }
  transport_->start();
  const double wait_s = std::max(0.5, 50.0 * period_s_);
  if (!transport_->wait_for_in(wait_s, stop_)) {
    transport_->stop();
    transport_->close();
    throw_if_stopped(stop_, "usb-hid: waiting for the first IN report of " + board_.description);
    throw DeviceError("no IN report from the board (" + board_.description + ") within " +
                      format_duration(wait_s) + " after it was claimed");
  }
}

void UsbHidDevice::enable() {
  if (session_.faulted()) {
    // A tripped dead-man is what a previous hapticd leaves when it dies.
    session_.begin_reset();
    if (!run_reset_handshake(std::max(20, 4 * config_.timeout_periods)) || session_.faulted()) {
      throw_if_stopped(stop_, "usb-hid: resetting the board's fault before enabling");
      throw DeviceError("the board (" + board_.description +
                        ") did not clear its fault: " + session_.describe(session_.fault()));
    }
  }
  enabled_.store(true, std::memory_order_release);
}

bool UsbHidDevice::run_reset_handshake(int periods) {
  const auto period = std::chrono::duration<double>(period_s_);
  for (int p = 0; p < periods && !stop_.stop_requested(); ++p) {
    exchange_write(0.0);
    std::this_thread::sleep_for(period);
    exchange_read();
    if (session_.reset_done()) return !session_.faulted();
  }
  return false;
}

void UsbHidDevice::disable() noexcept {
  const bool was_enabled = enabled_.exchange(false, std::memory_order_acq_rel);
  if (!was_enabled || transport_ == nullptr || !transport_->is_open()) return;
  // One report with the output off; let it go out. The IN transfers keep
  // running: read() stays valid until close(), and enable() may follow.
  exchange_write(0.0);
  for (int p = 0; p < 3; ++p) {
    std::this_thread::sleep_for(std::chrono::duration<double>(period_s_));
    exchange_read();
  }
}

void UsbHidDevice::close() noexcept {
  if (transport_ == nullptr) return;
  transport_->stop();
  transport_->close();
  transport_.reset();
}

// ---- RT ---------------------------------------------------------------------

// The RT side announces itself (in_rt_) before it looks at the park request,
// and the control side requests before it looks at in_rt_: with sequentially
// consistent stores and loads at least one of them sees the other (Dekker),
// so the RT side never touches the transport while the control side has it.
template <class Exchange>
IoResult UsbHidDevice::rt_call(Exchange exchange) noexcept {
  in_rt_.store(true, std::memory_order_seq_cst);
  const IoResult result = park_requested_.load(std::memory_order_seq_cst) ? IoResult::fault : exchange();
  in_rt_.store(false, std::memory_order_release);
  return result;
}

IoResult UsbHidDevice::read(Reading& out) noexcept {
  rt_calls_.fetch_add(1, std::memory_order_relaxed);
  return rt_call([&]() noexcept {
    const IoResult result = exchange_read();
    if (result == IoResult::ok) out.position = positions_[0];
    return result;
  });
}

IoResult UsbHidDevice::write(double force) noexcept {
  return rt_call([&]() noexcept { return exchange_write(force); });
}

IoResult UsbHidDevice::read_axes(std::span<Reading> out) noexcept {
  rt_calls_.fetch_add(1, std::memory_order_relaxed);
  if (out.size() != config_.axis_count()) return IoResult::error;
  return rt_call([&]() noexcept {
    const IoResult result = exchange_read();
    if (result == IoResult::ok)
      for (std::size_t k = 0; k < out.size(); ++k) out[k].position = positions_[k];
    return result;
  });
}

IoResult UsbHidDevice::write_axes(std::span<const double> forces) noexcept {
  if (forces.size() != config_.axis_count()) return IoResult::error;
  return rt_call([&]() noexcept { return exchange_write(forces); });
}

IoResult UsbHidDevice::exchange_read() noexcept {
  transport_->poll();
  InCompletion in;
  while (transport_->pop_in(in)) session_.on_in(in.outcome, {in.bytes, in.length}, board_.in.address);
  TransferOutcome outcome;
  while (transport_->pop_out(outcome)) session_.on_out(outcome, board_.out.address);
  InReport latest;
  const IoResult result = session_.end_read(latest);
  if (result == IoResult::ok)
    for (std::size_t k = 0; k < config_.axis_count(); ++k)
      positions_[k] = static_cast<double>(latest.position_counts[k]) * config_.position_per_count(k);
  publish();
  return result;
}

IoResult UsbHidDevice::exchange_write(std::span<const double> forces) noexcept {
  const std::size_t axes = config_.axis_count();
  for (std::size_t k = 0; k < axes; ++k) {
    const double force = k < forces.size() ? forces[k] : 0.0;
    commands_[k] = command_counts(config_.inverted ? -force : force, config_.command_full_scale_of(k),
                                  config_.layout.out.command[k]);
  }
  const std::size_t n = session_.make_out(std::span<const std::int64_t>(commands_.data(), axes),
                                          enabled_.load(std::memory_order_relaxed), deadman_us_, out_buffer_);
  switch (transport_->submit_out({out_buffer_, n})) {
    case SubmitResult::queued:
      break;
    case SubmitResult::busy:
      session_.latch(LinkFault::out_queue_full, static_cast<std::uint32_t>(config_.out_transfers));
      break;
    case SubmitResult::no_device:
      session_.latch(LinkFault::unplugged, 0);
      break;
    case SubmitResult::error:
      publish();
      return IoResult::error;
  }
  publish();
  return session_.faulted() ? IoResult::fault : IoResult::ok;
}

void UsbHidDevice::publish() noexcept {
  const SessionCounters& c = session_.counters();
  store(in_reports_, c.in_reports);
  store(stale_reports_, c.stale_reports);
  store(missed_reports_, c.missed_reports);
  store(short_reports_, c.short_reports + c.wrong_id_reports);
  store(transfer_errors_, c.transfer_errors);
  store(held_periods_, c.held_periods);
  store(out_reports_, c.out_reports);
  max_ack_lag_.store(c.max_ack_lag, std::memory_order_relaxed);
  fault_detail_.store(session_.fault().detail, std::memory_order_relaxed);
  fault_reason_.store(static_cast<std::uint32_t>(session_.fault().reason), std::memory_order_release);
  resetting_.store(!session_.reset_done(), std::memory_order_release);
}

// ---- clear_fault: the hand-over with the RT thread --------------------------

bool UsbHidDevice::park(double timeout_s) {
  park_requested_.store(true, std::memory_order_seq_cst);
  if (wait_until(timeout_s, [this] { return !in_rt_.load(std::memory_order_seq_cst); })) return true;
  park_requested_.store(false, std::memory_order_release);
  return false;
}

void UsbHidDevice::unpark() noexcept { park_requested_.store(false, std::memory_order_release); }

bool UsbHidDevice::rt_loop_running() const {
  const std::uint64_t before = rt_calls_.load(std::memory_order_relaxed);
  const double window_s = std::max(0.02, 5.0 * period_s_);
  return wait_until(window_s, [&] { return rt_calls_.load(std::memory_order_relaxed) != before; });
}

void UsbHidDevice::set_description() {
  const std::lock_guard lock(description_mutex_);
  description_ = board_.description;
}

void UsbHidDevice::drain_completions() noexcept {
  InCompletion in;
  while (transport_->pop_in(in)) {
  }
  TransferOutcome outcome;
  while (transport_->pop_out(outcome)) {
  }
}

void UsbHidDevice::reopen() {
  transport_->stop();
  transport_->close();
  drain_completions();
  if (!transport_->present(config_.selector))
    throw DeviceError("the board (" + board_.description +
                      ") is not on the bus: plug it in, then clear the fault again");
  try {
    board_ = transport_->open(config_.selector);
  } catch (const TransportError& e) {
    throw DeviceError(e.what(), e.key());
  }
  reopen_checks();
  set_description();
  session_.restart();
  reopens_.fetch_add(1, std::memory_order_relaxed);
}

void UsbHidDevice::repair(const LatchedFault& fault) {
  if (fault.reason == LinkFault::unplugged) {
    reopen();
  } else if (fault.reason == LinkFault::stalled) {
    const std::string error = transport_->clear_halt(static_cast<std::uint8_t>(fault.detail));
    if (!error.empty()) throw DeviceError(error);
    drain_completions();
    transport_->start();  // re-queues the IN transfers the stall gave back
  }
}

void UsbHidDevice::await_reset(bool rt_running) {
  if (rt_running) {
    unpark();
    const double answer_s = 0.5 + 4.0 * config_.timeout_periods * period_s_;
    if (!wait_until(
            answer_s, [this] { return !resetting_.load(std::memory_order_acquire); }, stop_)) {
      throw_if_stopped(stop_, "usb-hid: waiting for the board's answer to the fault reset");
      throw DeviceError("the board did not answer the fault reset within " + format_duration(answer_s));
    }
    return;
  }
  // No RT loop calls read()/write() (stopped engine, a test): drive the
  // handshake here, still holding the transport.
  const bool decided = run_reset_handshake(std::max(20, 4 * config_.timeout_periods));
  unpark();
  if (!decided && session_.resetting()) {
    throw_if_stopped(stop_, "usb-hid: resetting the board's fault");
    throw DeviceError("the board did not answer the fault reset");
  }
}

std::string UsbHidDevice::clear_fault() {
  const auto reason = static_cast<LinkFault>(fault_reason_.load(std::memory_order_acquire));
  if (reason == LinkFault::none) return {};
  const bool rt_running = rt_loop_running();
  const double handover_s = 0.2 + 20.0 * period_s_;
  if (!park(handover_s))
    throw DeviceError("the RT loop did not hand the board over within " + format_duration(handover_s) +
                      " (is it running?)");
  const LatchedFault before = session_.fault();
  std::string cleared = session_.describe(before);
  try {
    repair(before);
  } catch (...) {
    unpark();
    throw;
  }
  session_.begin_reset();
  publish();
  await_reset(rt_running);
  const LinkStatus now = link_status();
  if (now.fault.reason != LinkFault::none)
    throw DeviceError("the board is still in fault: " + now.fault_text);
  return cleared;
}

// ---- any non-RT thread ------------------------------------------------------

LinkStatus UsbHidDevice::link_status() const {
  LinkStatus s;
  s.enabled = enabled_.load(std::memory_order_acquire);
  s.fault.reason = static_cast<LinkFault>(fault_reason_.load(std::memory_order_acquire));
  s.fault.detail = fault_detail_.load(std::memory_order_relaxed);
  s.fault_text = session_.describe(s.fault);
  s.session.in_reports = in_reports_.load(std::memory_order_relaxed);
  s.session.stale_reports = stale_reports_.load(std::memory_order_relaxed);
  s.session.missed_reports = missed_reports_.load(std::memory_order_relaxed);
  s.session.short_reports = short_reports_.load(std::memory_order_relaxed);
  s.session.transfer_errors = transfer_errors_.load(std::memory_order_relaxed);
  s.session.held_periods = held_periods_.load(std::memory_order_relaxed);
  s.session.out_reports = out_reports_.load(std::memory_order_relaxed);
  s.session.max_ack_lag = max_ack_lag_.load(std::memory_order_relaxed);
  if (transport_ != nullptr) s.transport = transport_->counters();
  s.reopens = reopens_.load(std::memory_order_relaxed);
  {
    const std::lock_guard lock(description_mutex_);
    s.board = description_;
  }
  return s;
}

DeviceModel UsbHidDevice::model() const {
  DeviceModel m;
  m.motion = config_.motion;
  m.effective_mass = config_.mass;
  m.viscous_damping = config_.damping;
  m.position_resolution = std::abs(config_.position_per_count());
  const auto in = interrupt_interval_s(board_.in.speed, board_.in.b_interval);
  const auto out = interrupt_interval_s(board_.out.speed, board_.out.b_interval);
  m.delay_periods = config_.delay_periods >= 0 ? config_.delay_periods
                    : in && out                ? link_delay_periods(*in, *out, period_s_)
                                               : 0;
  m.source = "config";
  m.description = "usb-hid board " + board_.description;
  if (config_.axes.empty()) return m;
  // A stage: every axis, and the lightest one in the one-axis fields.
  m.description += ", Cartesian stage of " + std::to_string(config_.axes.size()) + " linear axes";
  m.effective_mass = config_.axes[0].mass;
  m.viscous_damping = config_.axes[0].damping;
  for (std::size_t k = 0; k < config_.axes.size(); ++k) {
    const UsbHidAxis& axis = config_.axes[k];
    m.axes.push_back({axis.mass, axis.damping});
    m.position_resolution = std::max(m.position_resolution, std::abs(config_.position_per_count(k)));
    if (axis.mass < m.effective_mass) {
      m.effective_mass = axis.mass;
      m.viscous_damping = axis.damping;
    }
  }
  return m;
}

DeviceHealth UsbHidDevice::health() const {
  const LinkStatus l = link_status();
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
