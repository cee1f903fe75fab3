#include "drivers/modbus/modbus_device.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <thread>
#include <vector>

#include "drivers/modbus/modbus_frame.hpp"
#include "drivers/modbus/rtu_timing.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::modbus {

namespace {

using Clock = std::chrono::steady_clock;

// How long the control thread waits for the RT thread to leave a
// transaction (a few response timeouts at most), and for the power stage.
constexpr auto control_wait = std::chrono::seconds(1);
constexpr auto enable_wait = std::chrono::milliseconds(500);
constexpr auto poll_interval = std::chrono::milliseconds(2);
// The keep-alive's and the configure-time measurement's pace: the period,
// at most this (so an amplifier watchdog of tens of ms is fed with any period).
constexpr double max_idle_pace_s = 5e-3;

std::string seconds_text(double s) {
  char text[32];
  if (s >= 1.0)
    std::snprintf(text, sizeof text, "%.3g s", s);
  else if (s >= 1e-3)
    std::snprintf(text, sizeof text, "%.3g ms", s * 1e3);
  else
    std::snprintf(text, sizeof text, "%.3g us", s * 1e6);
  return text;
}

LinkSettings link_settings(const ModbusConfig& c) {
  LinkSettings s;
  s.transport = c.transport;
  s.host = c.host;
  s.port = c.port;
  s.device = c.device;
  s.serial = c.serial;
  s.rs485 = c.rs485;
  s.slave_id = c.slave_id;
  s.byte_timeout_s = c.byte_timeout_s;
  s.connect_timeout_s = c.connect_timeout_s;
  s.response_timeout_s = 0.5;  // set from the period at configure
  return s;
}

const char* transaction_text(const ModbusConfig& c) {
  if (c.function_23) return "fc 23";
  return c.map.read_table == ReadTable::holding ? "fc 16 + fc 3" : "fc 16 + fc 4";
}

}  // namespace

ModbusDevice::ModbusDevice(ModbusConfig config) : config_(std::move(config)) {
  const LayoutResult layout = plan_blocks(config_.map);
  if (!layout.error_key.empty()) throw DeviceError("modbus: " + layout.error, layout.error_key);
  layout_ = layout.layout;
  link_ = std::make_unique<ModbusLink>(link_settings(config_));
}

ModbusDevice::~ModbusDevice() { close(); }

// ---- configure: the budget, the link, the amplifier's state, the watchdog ----

void ModbusDevice::check_period(double period_s) {
  const int n = config_.transactions();
  const double budget = config_.link_budget * period_s;
  double timeout = config_.response_timeout_s;
  if (timeout == 0.0) {
    timeout = budget / n;
  } else if (timeout * n > budget * (1.0 + 1e-9)) {
    throw DeviceError("modbus: response_timeout " + seconds_text(timeout) + " x " + std::to_string(n) +
                          " transaction" + (n > 1 ? "s" : "") + " per period exceeds link_budget " +
                          std::to_string(config_.link_budget).substr(0, 4) + " x period " +
                          seconds_text(period_s) + " = " + seconds_text(budget) +
                          ": a silent amplifier would hold the loop past its budget; accepted: up to " +
                          seconds_text(budget / n) + " (or 0 for that default)",
                      "response_timeout");
  }
  budget_ = LinkBudget{};
  budget_.transactions = n;
  budget_.frames_per_period = 2 * n;
  budget_.response_timeout_s = timeout;
  const int w = layout_.write_count, r = layout_.read_count;
  if (config_.transport == Transport::rtu) {
    const CycleTime cycle =
        cycle_time(config_.serial, config_.silence, config_.turnaround_s, config_.function_23, w, r);
    budget_.bytes_per_period = cycle.bytes();
    budget_.computed_cycle_s = cycle.total_s();
    const double silence = cycle.first.silence_s;
    char what[256];
    std::snprintf(
        what, sizeof what,
        "one exchange (%s, %d bytes of %d-bit characters at %d baud, %d x %s silence, %s turnaround) "
        "takes %s",
        transaction_text(config_), cycle.bytes(), character_bits(config_.serial), config_.serial.baud, 2 * n,
        seconds_text(silence).c_str(), seconds_text(config_.turnaround_s).c_str(),
        seconds_text(cycle.total_s()).c_str());
    if (cycle.total_s() > budget) {
      const int lowest = lowest_baud_for(config_.serial, config_.silence, config_.turnaround_s,
                                         config_.function_23, w, r, period_s, config_.link_budget);
      std::string alternatives =
          "; it needs a period of at least " + seconds_text(shortest_period_s(cycle, config_.link_budget));
      if (lowest != 0)
        alternatives += ", or " + std::to_string(lowest) + " baud, or TCP";
      else if (config_.silence == SilenceRule::spec)
        alternatives +=
            ", or TCP: no baud rate carries it with the spec's 1.75 ms silences above 19200 baud (silence = "
            "\"characters\" if the amplifier keeps 3.5 characters)";
      else
        alternatives += ", or TCP";
      throw DeviceError("modbus: " + std::string(what) + "; link_budget " +
                            std::to_string(config_.link_budget).substr(0, 4) + " x period " +
                            seconds_text(period_s) + " = " + seconds_text(budget) + alternatives,
                        "baud");
    }
    for (const TransactionTime* t : {&cycle.first, &cycle.second}) {
      if (t->request_bytes == 0) continue;
      if (t->response_wait_s() > timeout)
        throw DeviceError("modbus: response_timeout " + seconds_text(timeout) + " is shorter than the " +
                              seconds_text(t->response_wait_s()) +
                              " from the end of a request to the end of its reply on the line (" + what + ")",
                          "response_timeout");
    }
    budget_.summary = std::string(what) + ", response timeout " + seconds_text(timeout);
  }
}

void ModbusDevice::configure(const LoopContext& loop) {
  if (!(loop.period_s > 0.0)) throw DeviceError("modbus: the loop period must be > 0 s", "period");
  period_s_ = loop.period_s;
  stop_ = loop.stop;
  link_->set_stop(loop.stop);
  check_period(loop.period_s);
  // The one-off exchanges of configure (and of the control thread) wait
  // up to connect_timeout: only the periodic exchange has a period to fit.
  link_->set_response_timeout(control_timeout_s());
  link_->open();
  link_down_ = false;
  streak_ = 0;
  bool armed = false;
  try {
    AmplifierSample s = read_state("reading the amplifier's state");
    if (s.faulted) {
      if (!config_.reset_on_start || !config_.map.reset)
        throw DeviceError("modbus: the amplifier at " + link_->endpoint() +
                              " is in fault: " + describe_faults(s.fault, config_.map.fault_bits) +
                              ", status " + world::text::format_hex(s.status, 4) +
                              "; clear it at the amplifier, or set reset_on_start = true",
                          "reset_on_start");
      const LinkResult r = link_->write_register(*config_.map.reset, config_.map.reset_value);
      if (!r.ok()) fail("writing the reset register", r, "reset_register");
      s = read_state("reading the amplifier's state after the reset");
      if (s.faulted)
        throw DeviceError("modbus: the amplifier stays in fault after a reset: " +
                          describe_faults(s.fault, config_.map.fault_bits));
    }
    // Measured with the watchdog off: a slow or refused start must not
    // leave an armed watchdog behind to trip (and refuse the next start).
    measure_round_trip();
    link_->set_response_timeout(control_timeout_s());
    // Armed last, then fed at once by the keep-alive until the loop runs.
    // An alive counter starts at watchdog_value; it cannot be disarmed.
    const bool counter = config_.map.watchdog_refresh == WatchdogRefresh::counter;
    alive_count_ = config_.map.watchdog_value;
    if (config_.map.watchdog) {
      const LinkResult r = link_->write_register(*config_.map.watchdog, watchdog_word());
      if (!r.ok()) fail("arming the watchdog", r, "watchdog_register");
      armed = !counter;
    }
    link_->set_response_timeout(budget_.response_timeout_s);
    command_counts_.store(0);
    latched_.store(false);
    rt_active_.store(false);
    start_keepalive();
  } catch (...) {
    if (armed) (void)link_->write_register(*config_.map.watchdog, 0);
    link_->close();  // the framework's close() then finds nothing to switch off
    throw;
  }
}

void ModbusDevice::start_keepalive() {
  keepalive_stop_.store(false);
  keepalive_ = std::thread([this] { keepalive_loop(); });
}

void ModbusDevice::stop_keepalive() noexcept {
  keepalive_stop_.store(true);
  if (keepalive_.joinable()) keepalive_.join();
}

void ModbusDevice::keepalive_loop() noexcept {
  const auto pace = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(std::min(period_s_, max_idle_pace_s)));
  auto next = Clock::now();
  while (!keepalive_stop_.load(std::memory_order_relaxed)) {
    next += pace;
    std::this_thread::sleep_until(next);
    if (rt_active_.load(std::memory_order_acquire)) continue;
    int expected = free_owner;
    if (!owner_.compare_exchange_strong(expected, keepalive_owner, std::memory_order_acquire,
                                        std::memory_order_relaxed))
      continue;  // someone else is talking to the amplifier: that feeds the watchdog too
    if (!link_down_ && !rt_active_.load(std::memory_order_acquire)) {
      if (transact(0, watchdog_word()).ok())
        publish_sample(decode_sample(config_.map, layout_, std::span<const std::uint16_t>(read_block_)));
    }
    owner_.store(free_owner, std::memory_order_release);
  }
}

void ModbusDevice::measure_round_trip() {
  // The periodic exchange itself (torque 0), paced at the period: on TCP
  // its round trip decides whether the period is carried; on RTU a few
  // exchanges check that the amplifier answers it (fc 23 support).
  const int samples = config_.transport == Transport::tcp ? config_.rtt_samples : 3;
  // A whole period as the timeout here, so a slow link is measured and
  // refused with its figure rather than timing out.
  link_->set_response_timeout(std::max(period_s_, budget_.response_timeout_s));
  std::vector<double> seconds;
  seconds.reserve(static_cast<std::size_t>(samples));
  auto next = Clock::now();
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(std::min(period_s_, max_idle_pace_s)));
  int failed = 0;
  LinkResult last_failure;
  for (int i = 0; i < samples; ++i) {
    throw_if_stopped(stop_, "modbus: measuring the round trip to " + link_->endpoint());
    std::this_thread::sleep_until(next);
    next += period;
    const LinkResult r = transact(0, 0);  // torque 0, watchdog off (not armed yet)
    // The link's round trip, not this (plain) thread's wait for a CPU after
    // the reply came: last_round_trip_s() (a failure counts as failed).
    seconds.push_back(r.ok() ? transact_round_trip_s_ : period_s_);
    if (!r.ok()) {
      if (r.outcome == LinkOutcome::exception || r.outcome == LinkOutcome::closed ||
          r.outcome == LinkOutcome::io_error)
        fail("the periodic exchange", r);
      ++failed;
      last_failure = r;
    }
  }
  if (failed * 100 > samples) {  // more than 1 %: the p99 round trip is past the timeout
    throw DeviceError("modbus: " + link_->endpoint() + ": " + std::to_string(failed) + " of " +
                          std::to_string(samples) +
                          " periodic exchanges at configure got no valid reply within " +
                          seconds_text(std::max(period_s_, budget_.response_timeout_s)) +
                          " (the last: " + modbus::describe(last_failure) + "); the response timeout is " +
                          seconds_text(budget_.response_timeout_s) +
                          " (link_budget x period / transactions): use a longer period or a faster link",
                      "response_timeout");
  }
  std::sort(seconds.begin(), seconds.end());
  auto at = [&](double p) {
    const auto i = static_cast<std::size_t>(std::ceil(p * static_cast<double>(seconds.size()))) - 1;
    return seconds[std::min(i, seconds.size() - 1)];
  };
  if (config_.transport != Transport::tcp) return;
  budget_.rtt_samples = samples;
  budget_.rtt_p50_s = at(0.50);
  budget_.rtt_p99_s = at(0.99);
  budget_.rtt_max_s = seconds.back();
  budget_.bytes_per_period = 0;
  char what[256];
  std::snprintf(what, sizeof what, "%s round trip to %s:%d over %d exchanges: p50 %s, p99 %s, max %s",
                transaction_text(config_), config_.host.c_str(), config_.port, samples,
                seconds_text(budget_.rtt_p50_s).c_str(), seconds_text(budget_.rtt_p99_s).c_str(),
                seconds_text(budget_.rtt_max_s).c_str());
  budget_.summary = std::string(what) + ", response timeout " + seconds_text(budget_.response_timeout_s);
  if (budget_.rtt_p99_s > budget_.response_timeout_s)
    throw DeviceError("modbus: " + std::string(what) + " exceeds the response timeout " +
                          seconds_text(budget_.response_timeout_s) +
                          " (link_budget x period / transactions): " +
                          "use a longer period, a faster network path, or fewer transactions (function_23)",
                      "response_timeout");
}

// ---- RT ----

std::uint16_t ModbusDevice::watchdog_word() noexcept {
  if (config_.map.watchdog_refresh != WatchdogRefresh::counter) return config_.map.watchdog_value;
  return alive_count_++;  // unsigned 16 bits: 0xFFFF -> 0
}

LinkResult ModbusDevice::transact(std::int16_t torque, std::uint16_t watchdog) noexcept {
  encode_command(layout_, torque, watchdog, write_block_);
  const std::span<const std::uint16_t> write(write_block_.data(), layout_.write_count);
  const std::span<std::uint16_t> read(read_block_.data(), layout_.read_count);
  if (config_.function_23) {
    const LinkResult r = link_->write_and_read(layout_.write_address, write, layout_.read_address, read);
    transact_round_trip_s_ = link_->last_round_trip_s();
    return r;
  }
  const LinkResult w = link_->write_registers(layout_.write_address, write);
  if (!w.ok()) return w;
  const double first = link_->last_round_trip_s();
  const LinkResult r = link_->read_registers(config_.map.read_table, layout_.read_address, read);
  transact_round_trip_s_ = first + link_->last_round_trip_s();
  return r;
}

void ModbusDevice::publish_sample(const AmplifierSample& s) noexcept {
  sample_version_.write_begin();
  rt::seq_store(s_position_, s.position_counts);
  rt::seq_store(s_velocity_, s.velocity_counts);
  rt::seq_store(s_status_, s.status);
  rt::seq_store(s_fault_, s.fault);
  rt::seq_store(s_enabled_, s.enabled);
  rt::seq_store(s_faulted_, s.faulted);
  rt::seq_store(s_period_, period_);
  sample_version_.write_end();
}

IoResult ModbusDevice::latch(FaultCause cause, const LinkResult& last, const AmplifierSample& s) noexcept {
  if (!latched_.load(std::memory_order_relaxed)) {
    fault_version_.write_begin();
    rt::seq_store(f_cause_, cause);
    rt::seq_store(f_outcome_, last.outcome);
    rt::seq_store(f_function_, last.function);
    rt::seq_store(f_exception_, last.exception_code);
    rt::seq_store(f_errno_, last.error_number);
    rt::seq_store(f_problem_, last.problem);
    rt::seq_store(f_got_, last.got);
    rt::seq_store(f_expected_, last.expected);
    rt::seq_store(f_streak_, streak_);
    rt::seq_store(f_status_, s.status);
    rt::seq_store(f_fault_, s.fault);
    fault_version_.write_end();
    latched_.store(true, std::memory_order_release);
  }
  command_counts_.store(0, std::memory_order_relaxed);
  return IoResult::fault;
}

IoResult ModbusDevice::exchange(Reading& out) noexcept {
  const bool latched = latched_.load(std::memory_order_acquire);
  if (link_down_) return IoResult::fault;  // latched when it went down; fault clear reconnects
  const bool powered = expect_enabled_.load(std::memory_order_relaxed) && !latched;
  const LinkResult r =
      transact(powered ? command_counts_.load(std::memory_order_relaxed) : std::int16_t{0}, watchdog_word());
  ++period_;
  if (r.ok()) {
    streak_ = 0;
    const AmplifierSample s =
        decode_sample(config_.map, layout_, std::span<const std::uint16_t>(read_block_));
    publish_sample(s);
    if (s.faulted) return latch(FaultCause::amplifier_fault, r, s);
    if (powered && !s.enabled) return latch(FaultCause::amplifier_disabled, r, s);
    if (latched) return IoResult::fault;
    out.position = config_.direction * s.position_counts * config_.position_per_count();
    return IoResult::ok;
  }
  switch (r.outcome) {
    case LinkOutcome::exception:
      if (!exception_is_transient(r.exception_code)) return latch(FaultCause::exception, r, {});
      break;
    case LinkOutcome::closed:
      link_down_ = true;
      return latch(FaultCause::closed, r, {});
    case LinkOutcome::io_error:
      return latch(FaultCause::io_error, r, {});
    default:
      break;
  }
  // Transient: a timeout, a bad CRC, a malformed reply, busy/acknowledge.
  if (++streak_ >= config_.failure_streak) return latch(FaultCause::failure_streak, r, {});
  if (latched) return IoResult::fault;
  return IoResult::error;
}

IoResult ModbusDevice::read(Reading& out) noexcept {
  if (!rt_active_.load(std::memory_order_relaxed)) rt_active_.store(true, std::memory_order_release);
  int expected = free_owner;
  if (!owner_.compare_exchange_strong(expected, rt_owner, std::memory_order_acquire,
                                      std::memory_order_relaxed)) {
    // A keep-alive exchange in flight (first periods only): it ends within
    // the response timeout and starts no other once rt_active_ is set.
    while (expected == keepalive_owner) expected = owner_.load(std::memory_order_acquire);
    expected = free_owner;
    if (!owner_.compare_exchange_strong(expected, rt_owner, std::memory_order_acquire,
                                        std::memory_order_relaxed)) {
      // The control thread holds the context (enable, fault clear, disable).
      busy_.fetch_add(1, std::memory_order_relaxed);
      return latched_.load(std::memory_order_relaxed) ? IoResult::fault : IoResult::error;
    }
  }
  const IoResult result = exchange(out);
  owner_.store(free_owner, std::memory_order_release);
  return result;
}

IoResult ModbusDevice::write(double force) noexcept {
  if (latched_.load(std::memory_order_acquire)) {
    command_counts_.store(0, std::memory_order_relaxed);
    return IoResult::fault;
  }
  if (!std::isfinite(force)) {
    command_counts_.store(0, std::memory_order_relaxed);
    return IoResult::error;
  }
  bool saturated = false;
  const std::int16_t counts = torque_counts(config_.direction * force, config_.torque_per_count, saturated);
  if (saturated) saturations_.fetch_add(1, std::memory_order_relaxed);
  command_counts_.store(counts, std::memory_order_relaxed);
  return IoResult::ok;
}

// ---- control thread ----

void ModbusDevice::acquire_control(const char* doing) {
  const auto deadline = Clock::now() + control_wait;
  for (;;) {
    int expected = free_owner;
    if (owner_.compare_exchange_weak(expected, control_owner, std::memory_order_acquire,
                                     std::memory_order_relaxed)) {
      set_timeout(control_timeout_s());
      return;
    }
    if (Clock::now() > deadline)
      throw DeviceError(std::string("modbus: ") + doing + ": the RT thread held the link for over 1 s");
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
}

void ModbusDevice::release_control() noexcept {
  set_timeout(budget_.response_timeout_s);
  owner_.store(free_owner, std::memory_order_release);
}

double ModbusDevice::control_timeout_s() const noexcept {
  return std::max(budget_.response_timeout_s, config_.connect_timeout_s);
}

void ModbusDevice::set_timeout(double seconds) noexcept {
  try {
    link_->set_response_timeout(seconds);
  } catch (const DeviceError&) {
    // Both values were accepted at configure; nothing to do here.
  }
}

void ModbusDevice::fail(const std::string& doing, const LinkResult& r, const std::string& key) const {
  if (r.outcome == LinkOutcome::stopped)
    throw StopRequested(abandoned("modbus: " + link_->endpoint() + ": " + doing));
  std::string hint, k = key;
  switch (r.outcome) {
    case LinkOutcome::timeout:
      hint = config_.transport == Transport::tcp ? ": check host, port and slave_id"
                                                 : ": check slave_id, the wiring, baud rate and parity";
      if (k.empty()) k = "slave_id";
      break;
    case LinkOutcome::exception:
      if (r.exception_code == exception_code::illegal_function &&
          r.function == function_code::write_and_read_registers) {
        hint = ": the amplifier does not support function 23; set function_23 = false";
        if (k.empty()) k = "function_23";
      } else if (r.exception_code == exception_code::illegal_data_address) {
        hint = ": the amplifier has no register there; check the register map";
        if (k.empty()) k = "position_register";
      }
      break;
    case LinkOutcome::closed:
      if (k.empty()) k = config_.transport == Transport::tcp ? "host" : "device";
      break;
    default:
      break;
  }
  throw DeviceError("modbus: " + link_->endpoint() + ": " + doing + ": " + modbus::describe(r) + hint, k);
}

AmplifierSample ModbusDevice::read_state(const char* doing, int retries) {
  const std::span<std::uint16_t> block(read_block_.data(), layout_.read_count);
  LinkResult r = link_->read_registers(config_.map.read_table, layout_.read_address, block);
  // An amplifier back from a stall may still answer requests queued before
  // it: let those replies arrive, drop them (the link flushes before the
  // next request after a failure) and ask again.
  for (int i = 0; i < retries && r.outcome == LinkOutcome::bad_frame; ++i) {
    throw_if_stopped(stop_, "modbus: " + std::string(doing));
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    r = link_->read_registers(config_.map.read_table, layout_.read_address, block);
  }
  if (!r.ok()) fail(doing, r);
  const AmplifierSample s = decode_sample(config_.map, layout_, block);
  publish_sample(s);
  return s;
}

void ModbusDevice::write_zero_command(const char* doing) {
  encode_command(layout_, 0, watchdog_word(), write_block_);
  const LinkResult r = link_->write_registers(
      layout_.write_address, std::span<const std::uint16_t>(write_block_.data(), layout_.write_count));
  if (!r.ok()) fail(doing, r, "torque_register");
}

void ModbusDevice::set_power_stage(bool on) {
  const RegisterMap& m = config_.map;
  const char* doing = on ? "switching the power stage on" : "switching the power stage off";
  if (m.enable == EnableKind::coil) {
    const LinkResult r = link_->write_coil(m.enable_address, on);
    if (!r.ok()) fail(doing, r, "enable_address");
  } else if (m.enable == EnableKind::register_bit) {
    std::array<std::uint16_t, 1> word{};
    LinkResult r = link_->read_registers(ReadTable::holding, m.enable_address, word);
    if (!r.ok()) fail(doing, r, "enable_address");
    const auto bit = static_cast<std::uint16_t>(1u << m.enable_bit);
    const auto value = static_cast<std::uint16_t>(on ? (word[0] | bit) : (word[0] & ~bit));
    r = link_->write_register(m.enable_address, value);
    if (!r.ok()) fail(doing, r, "enable_address");
  }
}

void ModbusDevice::wait_enabled(const char* doing) {
  const auto deadline = Clock::now() + enable_wait;
  for (;;) {
    throw_if_stopped(stop_, "modbus: " + std::string(doing));
    const AmplifierSample s = read_state(doing);
    if (s.faulted)
      throw DeviceError("modbus: " + std::string(doing) + ": the amplifier reports a fault: " +
                        describe_faults(s.fault, config_.map.fault_bits) + ", status " +
                        world::text::format_hex(s.status, 4));
    if (s.enabled) return;
    if (Clock::now() > deadline)
      throw DeviceError("modbus: " + std::string(doing) +
                            ": the amplifier did not report its power stage on within " +
                            seconds_text(std::chrono::duration<double>(enable_wait).count()) + " (status " +
                            world::text::format_hex(s.status, 4) + ")",
                        "status_enabled_bit");
    std::this_thread::sleep_for(poll_interval);
  }
}

void ModbusDevice::enable() {
  acquire_control("enabling");
  try {
    command_counts_.store(0);
    write_zero_command("writing torque 0 before enabling");
    set_power_stage(true);
    wait_enabled("enabling");
    expect_enabled_.store(true);
  } catch (...) {
    release_control();
    throw;
  }
  release_control();
}

std::string ModbusDevice::clear_fault() {
  acquire_control("clearing the fault");
  std::string cleared;
  try {
    const bool was_latched = latched_.load();
    if (was_latched) cleared = describe(fault_record());
    auto add = [&](const std::string& what) { cleared += (cleared.empty() ? "" : "; ") + what; };
    // A closed connection, or a TCP one that stopped answering (its state
    // is unknown: replies may be queued), is made anew.
    const bool stalled_tcp = config_.transport == Transport::tcp && was_latched &&
                             fault_record().cause == FaultCause::failure_streak;
    if (link_down_ || stalled_tcp) {
      link_->reopen();
      link_down_ = false;
      add("reconnected to " + link_->endpoint());
    }
    AmplifierSample s = read_state("clearing the fault", 3);
    if (s.faulted) {
      if (!config_.map.reset)
        throw DeviceError("modbus: the amplifier is in fault (" +
                              describe_faults(s.fault, config_.map.fault_bits) +
                              ") and there is no reset_register to clear it",
                          "reset_register");
      const LinkResult r = link_->write_register(*config_.map.reset, config_.map.reset_value);
      if (!r.ok()) fail("writing the reset register", r, "reset_register");
      add("amplifier reset from " + describe_faults(s.fault, config_.map.fault_bits));
    }
    streak_ = 0;
    command_counts_.store(0);
    write_zero_command("writing torque 0 after the reset");
    if (expect_enabled_.load()) {
      set_power_stage(true);
      wait_enabled("enabling after the reset");
    } else {
      s = read_state("reading the amplifier after the reset");
      if (s.faulted)
        throw DeviceError("modbus: the amplifier stays in fault after a reset: " +
                          describe_faults(s.fault, config_.map.fault_bits));
    }
    fault_version_.write_begin();
    rt::seq_store(f_cause_, FaultCause::none);
    fault_version_.write_end();
    latched_.store(false, std::memory_order_release);
  } catch (...) {
    release_control();
    throw;
  }
  release_control();
  return cleared;
}

void ModbusDevice::disable() noexcept {
  try {
    acquire_control("disabling");
  } catch (...) {
    return;  // the RT thread is gone from here by contract; nothing more can be done
  }
  expect_enabled_.store(false);
  command_counts_.store(0);
  rt_active_.store(false,
                   std::memory_order_release);  // the loop has stopped: the keep-alive feeds the watchdog
  // Each step on its own: after a stop every exchange has one slice, and a
  // torque 0 answered late must not keep the power stage on.
  bool off = false;
  if (!link_down_ && link_->is_open()) {
    try {
      write_zero_command("writing torque 0");
    } catch (...) {
    }
    try {
      set_power_stage(false);
      off = true;
    } catch (...) {
      // The amplifier's watchdog takes over when the link is dead.
    }
  }
  power_off_confirmed_ = off;
  release_control();
}

void ModbusDevice::close() noexcept {
  // Configured but never enabled, the power stage is still confirmed off
  // (and the watchdog disarmed below) only by the same steps as disable().
  disable();
  stop_keepalive();
  try {
    acquire_control("closing");
  } catch (...) {
    return;
  }
  // A clean exit disarms the watchdog, so the amplifier does not report a
  // watchdog fault for an orderly stop; not while the power stage may be on.
  if (!link_down_ && power_off_confirmed_ && config_.map.watchdog &&
      config_.map.watchdog_refresh != WatchdogRefresh::counter)
    (void)link_->write_register(*config_.map.watchdog, 0);
  link_->close();
  link_down_ = false;
  power_off_confirmed_ = false;  // a second close() has nothing to disarm
  release_control();
}

// ---- any thread ----

ModbusDevice::FaultRecord ModbusDevice::fault_record() const {
  FaultRecord f;
  fault_version_.read([&] {
    f.cause = rt::seq_load(f_cause_);
    f.last.outcome = rt::seq_load(f_outcome_);
    f.last.function = rt::seq_load(f_function_);
    f.last.exception_code = rt::seq_load(f_exception_);
    f.last.error_number = rt::seq_load(f_errno_);
    f.last.problem = rt::seq_load(f_problem_);
    f.last.got = rt::seq_load(f_got_);
    f.last.expected = rt::seq_load(f_expected_);
    f.streak = rt::seq_load(f_streak_);
    f.status = rt::seq_load(f_status_);
    f.fault_word = rt::seq_load(f_fault_);
  });
  return f;
}

std::string ModbusDevice::describe(const FaultRecord& f) const {
  switch (f.cause) {
    case FaultCause::none:
      return "";
    case FaultCause::exception:
    case FaultCause::closed:
    case FaultCause::io_error:
      return modbus::describe(f.last);
    case FaultCause::failure_streak:
      return std::to_string(f.streak) +
             " failed transactions in a row, the last: " + modbus::describe(f.last);
    case FaultCause::amplifier_fault:
      return "amplifier fault: " + describe_faults(f.fault_word, config_.map.fault_bits) + ", status " +
             world::text::format_hex(f.status, 4);
    case FaultCause::amplifier_disabled:
      return "the amplifier switched its power stage off by itself (status " +
             world::text::format_hex(f.status, 4) + ")";
  }
  return "";
}

DeviceModel ModbusDevice::model() const {
  DeviceModel m;
  m.motion = config_.motion;
  m.effective_mass = config_.mass;
  m.viscous_damping = config_.damping;
  m.position_resolution = config_.position_per_count();
  // read() sends the command write() stored in the previous period: one
  // period from the position sample to the torque it produces.
  m.delay_periods = 1;
  m.source = "config";
  m.description = "modbus " + link_->endpoint() + ", " + transaction_text(config_) + " per period";
  return m;
}

DeviceHealth ModbusDevice::health() const {
  DeviceHealth s;
  s.faulted = latched_.load();
  if (s.faulted) s.fault_reason = describe(fault_record());
  const LinkCounters& c = link_->counters();
  s.counters = {{"requests", c.requests.load()},
                {"responses", c.responses.load()},
                {"timeouts", c.timeouts.load()},
                {"crc_errors", c.crc_errors.load()},
                {"exceptions", c.exceptions.load()},
                {"malformed_replies", c.bad_frames.load()},
                {"late_replies", c.late_replies.load()},
                {"wrong_unit_replies", c.wrong_unit.load()},
                {"connections_closed", c.closed.load()},
                {"io_errors", c.io_errors.load()},
                {"reconnects", c.reconnects.load()},
                {"torque_saturations", saturations_.load()},
                {"link_busy", busy_.load()}};
  return s;
}

LinkBudget ModbusDevice::budget() const { return budget_; }

ModbusSample ModbusDevice::sample() const {
  ModbusSample out;
  sample_version_.read([&] {
    out.raw.position_counts = rt::seq_load(s_position_);
    out.raw.velocity_counts = rt::seq_load(s_velocity_);
    out.raw.status = rt::seq_load(s_status_);
    out.raw.fault = rt::seq_load(s_fault_);
    out.raw.enabled = rt::seq_load(s_enabled_);
    out.raw.faulted = rt::seq_load(s_faulted_);
    out.period = rt::seq_load(s_period_);
  });
  out.position = config_.direction * out.raw.position_counts * config_.position_per_count();
  out.velocity = config_.direction * out.raw.velocity_counts * config_.position_per_count();
  return out;
}

}  // namespace hapticd::drivers::modbus
