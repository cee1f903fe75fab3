#include "sim/modbus/amplifier.hpp"

#include <array>
#include <cmath>

namespace hapticd::drivers::modbus::sim {

namespace reg = amplifier_register;

namespace {

constexpr std::uint16_t bit(unsigned n) noexcept { return static_cast<std::uint16_t>(1u << n); }

}  // namespace

Amplifier::Amplifier(AmplifierSettings settings, AmplifierPlant& plant)
    : settings_(settings), plant_(plant) {}

void Amplifier::bind(std::span<std::uint16_t> holding, std::span<std::uint16_t> input,
                     std::span<std::uint8_t> coils) {
  holding_ = holding;
  input_ = input;
  coils_ = coils;
  refresh_state_registers();
  publish();
}

std::uint16_t* Amplifier::holding(std::uint16_t address) noexcept {
  return address < holding_.size() ? &holding_[address] : nullptr;
}

std::span<std::uint16_t> Amplifier::state_table() noexcept {
  return settings_.state_table == StateTable::holding ? holding_ : input_;
}

void Amplifier::inject(Injection what, int count, std::uint8_t exception_code, int delay_ms) noexcept {
  injection_code_.store(exception_code, std::memory_order_relaxed);
  injection_delay_ms_.store(delay_ms, std::memory_order_relaxed);
  injection_left_.store(count, std::memory_order_relaxed);
  injection_.store(what, std::memory_order_release);
}

void Amplifier::inject_fault(std::uint16_t bits) noexcept {
  pending_fault_.fetch_or(bits, std::memory_order_acq_rel);
}

AmplifierState Amplifier::state() const noexcept {
  AmplifierState s;
  s.enabled = pub_enabled_.load(std::memory_order_acquire);
  s.watchdog_armed = pub_armed_.load(std::memory_order_relaxed);
  s.fault = pub_fault_.load(std::memory_order_relaxed);
  s.applied_torque = pub_applied_.load(std::memory_order_relaxed);
  s.torque_counts = pub_counts_.load(std::memory_order_relaxed);
  s.steps = pub_steps_.load(std::memory_order_relaxed);
  s.requests = pub_requests_.load(std::memory_order_relaxed);
  s.watchdog_trips = pub_trips_.load(std::memory_order_relaxed);
  s.resets = pub_resets_.load(std::memory_order_relaxed);
  s.trip_silence_s = pub_trip_silence_.load(std::memory_order_relaxed);
  s.watchdog_register = pub_watchdog_value_.load(std::memory_order_relaxed);
  s.alive_jumps = pub_alive_jumps_.load(std::memory_order_relaxed);
  s.time_s = pub_time_.load(std::memory_order_relaxed);
  s.refreshed_s = pub_refreshed_.load(std::memory_order_relaxed);
  return s;
}

void Amplifier::publish() noexcept {
  pub_armed_.store(watchdog_armed_, std::memory_order_relaxed);
  pub_fault_.store(fault_, std::memory_order_relaxed);
  pub_counts_.store(torque_counts_, std::memory_order_relaxed);
  pub_applied_.store(applied_, std::memory_order_relaxed);
  pub_steps_.store(steps_, std::memory_order_relaxed);
  pub_requests_.store(requests_, std::memory_order_relaxed);
  pub_trips_.store(trips_, std::memory_order_relaxed);
  pub_resets_.store(resets_, std::memory_order_relaxed);
  pub_trip_silence_.store(trip_silence_s_, std::memory_order_relaxed);
  pub_watchdog_value_.store(watchdog_value_, std::memory_order_relaxed);
  pub_alive_jumps_.store(alive_jumps_, std::memory_order_relaxed);
  pub_refreshed_.store(refreshed_s_, std::memory_order_relaxed);
  pub_time_.store(now_s_, std::memory_order_relaxed);
  pub_enabled_.store(enabled_, std::memory_order_release);
}

void Amplifier::set_enable(bool on, double now_s) noexcept {
  // An amplifier in fault keeps its power stage off until a reset.
  const bool was = enabled_;
  enabled_ = on && fault_ == 0;
  if (settings_.alive_counter_s > 0.0 && enabled_ != was) {
    // The alive counter is watched while the power stage is on.
    watchdog_armed_ = enabled_;
    restart_watchdog(settings_.alive_counter_s, now_s);
  }
}

void Amplifier::restart_watchdog(double period_s, double now_s) noexcept {
  watchdog_period_s_ = period_s;
  watchdog_deadline_s_ = now_s + period_s;
  refreshed_s_ = now_s;
}

void Amplifier::on_alive_count(std::uint16_t value, double now_s) noexcept {
  if (watchdog_armed_) {
    if (value == watchdog_value_) {
      trip_watchdog(now_s);  // the value did not change: hapticd's cycle is not alive
    } else {
      if (value != static_cast<std::uint16_t>(watchdog_value_ + 1)) ++alive_jumps_;
      restart_watchdog(watchdog_period_s_, now_s);
    }
  }
  watchdog_value_ = value;
}

void Amplifier::trip_watchdog(double now_s) noexcept {
  trip_silence_s_ = now_s - (watchdog_deadline_s_ - watchdog_period_s_);
  fault_ = static_cast<std::uint16_t>(fault_ | bit(fault_bit::watchdog));
  enabled_ = false;
  watchdog_armed_ = false;
  applied_ = 0.0;
  ++trips_;
}

void Amplifier::tick(double now_s) noexcept {
  now_s_ = now_s;
  if (watchdog_armed_ && now_s > watchdog_deadline_s_) {
    trip_watchdog(now_s);
    refresh_state_registers();
  }
  if (const std::uint16_t bits = pending_fault_.exchange(0, std::memory_order_acq_rel)) {
    fault_ = static_cast<std::uint16_t>(fault_ | bits);
    enabled_ = false;
    applied_ = 0.0;
    refresh_state_registers();
  }
  publish();
}

void Amplifier::apply_write(std::uint16_t address, std::uint16_t value, double now_s) noexcept {
  if (std::uint16_t* r = holding(address)) *r = value;
  switch (address) {
    case reg::torque:
      torque_counts_ = static_cast<std::int16_t>(value);
      break;
    case reg::watchdog:
      if (settings_.alive_counter_s > 0.0) {
        on_alive_count(value, now_s);
      } else {
        watchdog_value_ = value;
        watchdog_armed_ = value != 0;
        restart_watchdog(value * 1e-3, now_s);  // ms
      }
      break;
    case reg::reset:
      if (value == reset_command) {
        fault_ = 0;
        ++resets_;
      }
      break;
    case reg::control:
      if (settings_.enable_by == EnableBy::control_word)
        set_enable((value & bit(control_bit::enable)) != 0, now_s);
      break;
    default:
      break;
  }
}

bool Amplifier::take_injection(Decision& decision) noexcept {
  const Injection what = injection_.load(std::memory_order_acquire);
  if (what == Injection::none) return false;
  if (injection_left_.fetch_sub(1, std::memory_order_relaxed) <= 1)
    injection_.store(Injection::none, std::memory_order_relaxed);
  switch (what) {
    case Injection::exception:
      decision.kind = Decision::Kind::exception;
      decision.exception_code = injection_code_.load(std::memory_order_relaxed);
      return true;
    case Injection::timeout:
      decision.kind = Decision::Kind::silence;
      return true;
    case Injection::drop:
      decision.kind = Decision::Kind::drop;
      return true;
    case Injection::crc_error:
      decision.kind = Decision::Kind::corrupt_crc;  // applied, the reply is corrupted
      return false;
    case Injection::late:
      decision.delay_ms = injection_delay_ms_.load(std::memory_order_relaxed);  // applied, answered late
      return false;
    case Injection::none:
      break;
  }
  return false;
}

std::uint8_t Amplifier::address_exception(const Request& r) const noexcept {
  const std::size_t read_table = r.function == function::read_input ? input_.size() : holding_.size();
  if (r.reads() && std::size_t{r.read_address} + r.read_quantity > read_table)
    return exception::illegal_data_address;
  const std::size_t write_table = r.function == function::write_coil ? coils_.size() : holding_.size();
  if (r.write_quantity > 0 && std::size_t{r.write_address} + r.write_quantity > write_table)
    return exception::illegal_data_address;
  return exception::none;
}

Decision Amplifier::on_request(std::span<const std::uint8_t> pdu, double now_s) noexcept {
  ++requests_;
  tick(now_s);
  Decision decision;
  Request request;
  std::uint8_t refused = exception::none;
  if (!take_injection(decision)) {
    refused = decode_request(pdu, request);
    if (refused == exception::none && request.function == function::read_write_registers &&
        !settings_.function_23)
      refused = exception::illegal_function;
    if (refused == exception::none) refused = address_exception(request);
    if (refused == exception::none) apply(request, now_s);
  }
  if (refused != exception::none) {
    decision.kind = Decision::Kind::exception;
    decision.exception_code = refused;
  }
  publish();
  return decision;
}

void Amplifier::apply(const Request& request, double now_s) noexcept {
  if (settings_.watchdog_any_frame && watchdog_armed_) restart_watchdog(watchdog_period_s_, now_s);
  // Time passes between two command writes: the plant advances one period
  // under the torque applied since the last one, then the new command
  // takes effect and the reply reports the position now. So the position a
  // reply carries was sampled before the command in the same request acts
  // on the plant, as on a real amplifier (one period from sample to
  // actuation: the driver's delay_periods = 1).
  if (request.writes_registers() && request.write_address <= reg::torque &&
      reg::torque < request.write_address + request.write_quantity) {
    plant_.step(applied_);
    ++steps_;
  }
  if (request.function == function::write_coil) {
    const bool on = request.values[0] == 0xFF00;
    coils_[request.write_address] = on ? 1 : 0;
    if (settings_.enable_by == EnableBy::coil && request.write_address == enable_coil) set_enable(on, now_s);
  } else if (request.writes_registers()) {
    for (std::size_t i = 0; i < request.write_quantity; ++i)
      apply_write(static_cast<std::uint16_t>(request.write_address + i), request.values[i], now_s);
  }
  applied_ = enabled_ && fault_ == 0 ? torque_counts_ * settings_.torque_per_count : 0.0;
  refresh_state_registers();
}

void Amplifier::refresh_state_registers() noexcept {
  const std::span<std::uint16_t> table = state_table();
  if (table.size() <= reg::fault) return;
  double position = 0.0;
  plant_.sense(position);
  // The 32-bit count wraps, offset included (position-jump).
  const auto counts = static_cast<std::int32_t>(static_cast<std::uint32_t>(
      static_cast<std::uint64_t>(std::llround(position / settings_.position_per_count)) +
      static_cast<std::uint64_t>(position_offset_counts_.load(std::memory_order_relaxed))));
  const auto velocity =
      static_cast<std::int32_t>(std::llround(plant_.velocity() / settings_.position_per_count));
  const RegisterPair p = to_registers(counts, settings_.word_order);
  const RegisterPair v = to_registers(velocity, settings_.word_order);
  table[reg::position] = p.first;
  table[reg::position + 1] = p.second;
  table[reg::velocity] = v.first;
  table[reg::velocity + 1] = v.second;
  std::uint16_t status = 0;
  if (enabled_) status |= bit(status_bit::enabled);
  if (fault_ != 0) status |= bit(status_bit::fault);
  table[reg::status] = status;
  table[reg::fault] = fault_;
}

std::size_t Amplifier::build_reply(std::span<const std::uint8_t> pdu,
                                   std::span<std::uint8_t> out) const noexcept {
  Request r;
  if (decode_request(pdu, r) != exception::none || address_exception(r) != exception::none) return 0;
  std::array<std::uint16_t, 0x7D> values{};
  const std::span<const std::uint16_t> table = r.function == function::read_input ? input_ : holding_;
  for (std::size_t i = 0; i < r.read_quantity; ++i) values[i] = table[r.read_address + i];
  const std::span<const std::uint16_t> read(values.data(), r.read_quantity);
  switch (r.function) {
    case function::read_holding:
    case function::read_input:
    case function::read_write_registers:
      return encode_read_reply(r.function, read, out);
    case function::write_registers:
      return encode_write_registers_reply(r.write_address, r.write_quantity, out);
    case function::write_coil:
    case function::write_register:
      return encode_echo_reply(pdu, out);  // AP 6.5, 6.6: the request echoed
    default:
      return 0;
  }
}

}  // namespace hapticd::drivers::modbus::sim
