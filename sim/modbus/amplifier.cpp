#include "sim/modbus/amplifier.hpp"

#include <array>
#include <cmath>

namespace hapticd::drivers::modbus::sim {

Amplifier::Amplifier(AmplifierSettings settings, AmplifierPlant& plant)
    : settings_(std::move(settings)), plant_(plant) {}

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

std::uint16_t* Amplifier::state_register(std::uint16_t address) noexcept {
  std::span<std::uint16_t> table = settings_.map.read_table == ReadTable::holding ? holding_ : input_;
  return address < table.size() ? &table[address] : nullptr;
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
  pub_enabled_.store(enabled_, std::memory_order_release);
}

void Amplifier::set_enable(bool on, double now_s) noexcept {
  // An amplifier in fault keeps its power stage off until a reset.
  const bool was = enabled_;
  enabled_ = on && fault_ == 0;
  if (settings_.alive_counter_s > 0.0 && enabled_ != was) {
    // The alive counter is watched while the power stage is on.
    watchdog_armed_ = enabled_;
    watchdog_period_s_ = settings_.alive_counter_s;
    watchdog_deadline_s_ = now_s + watchdog_period_s_;
  }
}

void Amplifier::on_alive_count(std::uint16_t value, double now_s) noexcept {
  if (watchdog_armed_) {
    if (value == watchdog_value_) {
      trip_watchdog(now_s);  // the value did not change: hapticd's cycle is not alive
    } else {
      if (value != static_cast<std::uint16_t>(watchdog_value_ + 1)) ++alive_jumps_;
      watchdog_deadline_s_ = now_s + watchdog_period_s_;
    }
  }
  watchdog_value_ = value;
}

void Amplifier::trip_watchdog(double now_s) noexcept {
  trip_silence_s_ = now_s - (watchdog_deadline_s_ - watchdog_period_s_);
  fault_ = static_cast<std::uint16_t>(fault_ | (1u << settings_.watchdog_fault_bit));
  enabled_ = false;
  watchdog_armed_ = false;
  applied_ = 0.0;
  ++trips_;
}

void Amplifier::tick(double now_s) noexcept {
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
  const RegisterMap& m = settings_.map;
  if (std::uint16_t* r = holding(address)) *r = value;
  if (address == m.torque) torque_counts_ = static_cast<std::int16_t>(value);
  if (m.watchdog && address == *m.watchdog) {
    if (settings_.alive_counter_s > 0.0) {
      on_alive_count(value, now_s);
    } else {
      watchdog_value_ = value;
      watchdog_armed_ = value != 0;
      watchdog_period_s_ = value * 1e-3;
      watchdog_deadline_s_ = now_s + watchdog_period_s_;
    }
  }
  if (m.reset && address == *m.reset && value == m.reset_value) {
    fault_ = 0;
    ++resets_;
  }
  if (m.enable == EnableKind::register_bit && address == m.enable_address)
    set_enable(((value >> m.enable_bit) & 1u) != 0, now_s);
}

Decision Amplifier::on_request(std::span<const std::uint8_t> pdu, double now_s) noexcept {
  ++requests_;
  tick(now_s);
  Decision decision;
  if (injection_.load(std::memory_order_acquire) != Injection::none) {
    const Injection what = injection_.load(std::memory_order_relaxed);
    if (injection_left_.fetch_sub(1, std::memory_order_relaxed) <= 1)
      injection_.store(Injection::none, std::memory_order_relaxed);
    switch (what) {
      case Injection::exception:
        decision.kind = Decision::Kind::exception;
        decision.exception_code = injection_code_.load(std::memory_order_relaxed);
        publish();
        return decision;
      case Injection::timeout:
        decision.kind = Decision::Kind::silence;
        publish();
        return decision;
      case Injection::drop:
        decision.kind = Decision::Kind::drop;
        publish();
        return decision;
      case Injection::crc_error:
        decision.kind = Decision::Kind::corrupt_crc;  // applied below, the reply is corrupted
        break;
      case Injection::late:
        decision.delay_ms = injection_delay_ms_.load(std::memory_order_relaxed);  // applied below
        break;
      case Injection::none:
        break;
    }
  }

  RegisterRequest req;
  if (parse_request(pdu, req) != PduStatus::ok) {
    publish();
    return decision;  // libmodbus answers malformed or unknown requests with the standard exception
  }
  if (req.function == function_code::write_and_read_registers && !settings_.function_23) {
    decision.kind = Decision::Kind::exception;
    decision.exception_code = exception_code::illegal_function;
    publish();
    return decision;
  }
  // Out-of-table requests: libmodbus replies illegal data address; apply nothing.
  const bool writes_registers = req.function == function_code::write_single_register ||
                                req.function == function_code::write_multiple_registers ||
                                req.function == function_code::write_and_read_registers;
  if (writes_registers && req.write_address + req.write_count > holding_.size()) {
    publish();
    return decision;
  }
  if (req.function == function_code::write_and_read_registers &&
      req.read_address + req.read_count > holding_.size()) {
    publish();
    return decision;
  }
  if (settings_.map.watchdog_refresh == WatchdogRefresh::any_frame && watchdog_armed_)
    watchdog_deadline_s_ = now_s + watchdog_period_s_;

  // Time passes between two command writes: the plant advances one period
  // under the torque applied since the last one, then the new command
  // takes effect and the reply reports the position now. So the position a
  // reply carries was sampled before the command in the same request acts
  // on the plant, as on a real amplifier (one period from sample to
  // actuation: the driver's delay_periods = 1).
  const bool writes_torque = writes_registers && req.write_address <= settings_.map.torque &&
                             settings_.map.torque < req.write_address + req.write_count;
  if (writes_torque) {
    plant_.step(applied_);
    ++steps_;
  }
  if (req.function == function_code::write_single_coil) {
    if (req.write_address < coils_.size()) {
      const bool on = req.write_value(0) == 0xFF00;
      coils_[req.write_address] = on ? 1 : 0;
      if (settings_.map.enable == EnableKind::coil && req.write_address == settings_.map.enable_address)
        set_enable(on, now_s);
    }
  } else if (writes_registers) {
    for (std::size_t i = 0; i < req.write_count; ++i)
      apply_write(static_cast<std::uint16_t>(req.write_address + i), req.write_value(i), now_s);
  }
  applied_ = enabled_ && fault_ == 0 ? torque_counts_ * settings_.torque_per_count : 0.0;
  refresh_state_registers();
  publish();
  return decision;
}

void Amplifier::refresh_state_registers() noexcept {
  const RegisterMap& m = settings_.map;
  double position = 0.0;
  plant_.sense(position);
  // The 32-bit count wraps, offset included (position-jump).
  const auto counts = static_cast<std::int32_t>(static_cast<std::uint32_t>(
      static_cast<std::uint64_t>(std::llround(position / settings_.position_per_count)) +
      static_cast<std::uint64_t>(position_offset_counts_.load(std::memory_order_relaxed))));
  std::uint16_t* p0 = state_register(m.position);
  std::uint16_t* p1 = state_register(static_cast<std::uint16_t>(m.position + 1));
  if (p0 && p1) split_words(counts, m.word_order, *p0, *p1);
  if (m.velocity) {
    const auto v = static_cast<std::int32_t>(std::llround(plant_.velocity() / settings_.position_per_count));
    std::uint16_t* v0 = state_register(*m.velocity);
    std::uint16_t* v1 = state_register(static_cast<std::uint16_t>(*m.velocity + 1));
    if (v0 && v1) split_words(v, m.word_order, *v0, *v1);
  }
  if (m.status) {
    if (std::uint16_t* s = state_register(*m.status)) {
      std::uint16_t word = 0;
      if (m.status_enabled_bit >= 0 && enabled_)
        word = static_cast<std::uint16_t>(word | (1u << m.status_enabled_bit));
      if (m.status_fault_bit >= 0 && fault_ != 0)
        word = static_cast<std::uint16_t>(word | (1u << m.status_fault_bit));
      *s = word;
    }
  }
  if (m.fault)
    if (std::uint16_t* f = state_register(*m.fault)) *f = fault_;
}

std::size_t Amplifier::build_reply(std::span<const std::uint8_t> pdu,
                                   std::span<std::uint8_t> out) const noexcept {
  RegisterRequest req;
  if (parse_request(pdu, req) != PduStatus::ok) return 0;
  std::array<std::uint16_t, limits::read_registers> values{};
  auto read_from = [&](std::span<const std::uint16_t> table) -> bool {
    if (req.read_address + req.read_count > table.size()) return false;
    for (std::size_t i = 0; i < req.read_count; ++i) values[i] = table[req.read_address + i];
    return true;
  };
  const std::span<const std::uint16_t> read_values(values.data(), req.read_count);
  switch (req.function) {
    case function_code::read_holding_registers:
      return read_from(holding_) ? build_read_registers_response(out, req.function, read_values) : 0;
    case function_code::read_input_registers:
      return read_from(input_) ? build_read_registers_response(out, req.function, read_values) : 0;
    case function_code::write_and_read_registers:
      return read_from(holding_) ? build_write_and_read_response(out, read_values) : 0;
    case function_code::write_multiple_registers:
      return build_write_multiple_response(out, req.write_address, req.write_count);
    case function_code::write_single_register:
    case function_code::write_single_coil:
      if (out.size() < pdu.size()) return 0;
      for (std::size_t i = 0; i < pdu.size(); ++i)
        out[i] = pdu[i];  // 6.5, 6.6: the response echoes the request
      return pdu.size();
    default:
      return 0;
  }
}

}  // namespace hapticd::drivers::modbus::sim
