#include "sim/usb_hid/simulated_board.hpp"

#include <cmath>
#include <cstring>

namespace hapticd::drivers::usb_hid::sim {

SimulatedBoard::SimulatedBoard(const BoardScaling& scaling, BoardPlant& plant, BoardClock clock)
    : scaling_(scaling), plant_(plant), clock_(clock) {
  power_on();
}

std::uint64_t SimulatedBoard::now_us_locked() const {
  if (clock_ == BoardClock::deterministic) return deterministic_us_;
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - powered_at_)
          .count());
}

void SimulatedBoard::make_report_locked() {
  double position = 0.0;
  // An encoder read error leaves the count where it was (the board has no
  // better value); the plant simulator's faults show up this way.
  static_cast<void>(plant_.sense(position));
  const auto counts = static_cast<std::int64_t>(std::llround(position / scaling_.position_per_count));
  pending_length_ = firmware_.make_in_report(counts, pending_);
}

void SimulatedBoard::on_out_report(std::span<const std::uint8_t> bytes) {
  const std::lock_guard lock(mutex_);
  firmware_.on_tick(now_us_locked());
  if (!firmware_.on_out_report(bytes, now_us_locked())) return;
  applied_force_ = command_to_force(firmware_.output(), scaling_.command_full_scale);
  static_cast<void>(plant_.step(applied_force_));
  ++steps_;
  deterministic_us_ += static_cast<std::uint64_t>(std::llround(scaling_.period_s * 1e6));
  make_report_locked();
}

bool SimulatedBoard::take_in_report(std::span<std::uint8_t> buffer, std::size_t& length) {
  const std::lock_guard lock(mutex_);
  if (pending_length_ == 0) return false;
  length = pending_length_ < buffer.size() ? pending_length_ : buffer.size();
  std::memcpy(buffer.data(), pending_, length);
  pending_length_ = 0;
  return true;
}

void SimulatedBoard::refresh_report() {
  const std::lock_guard lock(mutex_);
  make_report_locked();
}

void SimulatedBoard::power_on() {
  const std::lock_guard lock(mutex_);
  firmware_ = BoardFirmware();
  powered_at_ = std::chrono::steady_clock::now();
  applied_force_ = 0.0;
  make_report_locked();
}

void SimulatedBoard::advance_time_us(std::uint64_t us) {
  const std::lock_guard lock(mutex_);
  deterministic_us_ += us;
  firmware_.on_tick(now_us_locked());
}

void SimulatedBoard::tick() {
  const std::lock_guard lock(mutex_);
  firmware_.on_tick(now_us_locked());
}

void SimulatedBoard::raise_fault(FaultCode code, bool cause_present) {
  const std::lock_guard lock(mutex_);
  firmware_.raise_fault(code, cause_present);
}

void SimulatedBoard::clear_cause() {
  const std::lock_guard lock(mutex_);
  firmware_.clear_cause();
}

BoardSnapshot SimulatedBoard::snapshot() const {
  const std::lock_guard lock(mutex_);
  BoardSnapshot s;
  s.firmware = firmware_.counters();
  s.output_counts = firmware_.output();
  s.applied_force = applied_force_;
  s.output_on = firmware_.output_on();
  s.watchdog_tripped = firmware_.watchdog_tripped();
  s.fault_code = firmware_.fault_code();
  s.steps = steps_;
  s.now_us = now_us_locked();
  return s;
}

FrameTicker::FrameTicker(SimulatedBoard& board, std::chrono::microseconds interval)
    : board_(board), interval_(interval), thread_([this] {
        while (!stop_.load(std::memory_order_acquire)) {
          std::this_thread::sleep_for(interval_);
          board_.tick();
        }
      }) {}

FrameTicker::~FrameTicker() {
  stop_.store(true, std::memory_order_release);
  thread_.join();
}

}  // namespace hapticd::drivers::usb_hid::sim
