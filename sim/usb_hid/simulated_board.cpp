#include "sim/usb_hid/simulated_board.hpp"

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace hapticd::drivers::usb_hid::sim {

SimulatedBoard::SimulatedBoard(const BoardScaling& scaling, BoardPlant& plant, BoardClock clock)
    : SimulatedBoard({BoardAxis{&plant, scaling.position_per_count, scaling.command_full_scale}},
                     scaling.period_s, clock) {}

SimulatedBoard::SimulatedBoard(const std::vector<BoardAxis>& axes, double period_s, BoardClock clock)
    : axes_(axes), period_s_(period_s), clock_(clock), firmware_(axes.size()) {
  if (axes_.empty() || axes_.size() > max_board_axes)
    throw std::invalid_argument("a simulated board has 1 to " + std::to_string(max_board_axes) + " axes");
  for (const BoardAxis& a : axes_)
    if (a.plant == nullptr) throw std::invalid_argument("a simulated board's axis needs its plant");
  power_on();
}

std::uint64_t SimulatedBoard::now_us_locked() const {
  if (clock_ == BoardClock::deterministic) return deterministic_us_;
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - powered_at_)
          .count());
}

void SimulatedBoard::make_report_locked() {
  std::array<std::int64_t, max_board_axes> counts{};
  for (std::size_t k = 0; k < axes_.size(); ++k) {
    double position = 0.0;
    // An encoder read error leaves the count where it was (the board has no
    // better value); the plant simulator's faults show up this way.
    static_cast<void>(axes_[k].plant->sense(position));
    counts[k] =
        static_cast<std::int64_t>(std::llround(position / axes_[k].position_per_count)) + encoder_offsets_[k];
  }
  pending_length_ =
      firmware_.make_in_report(std::span<const std::int64_t>(counts.data(), axes_.size()), pending_);
  if (pending_length_ > 0 && truncate_next_.exchange(false, std::memory_order_acq_rel)) --pending_length_;
}

void SimulatedBoard::on_out_report(std::span<const std::uint8_t> bytes) {
  const std::lock_guard lock(mutex_);
  firmware_.on_tick(now_us_locked());
  if (!firmware_.on_out_report(bytes, now_us_locked())) return;
  for (std::size_t k = 0; k < axes_.size(); ++k) {
    applied_forces_[k] = command_to_force(firmware_.output(k), axes_[k].command_full_scale);
    static_cast<void>(axes_[k].plant->step(applied_forces_[k]));
  }
  ++steps_;
  deterministic_us_ += static_cast<std::uint64_t>(std::llround(period_s_ * 1e6));
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
  firmware_ = BoardFirmware(axes_.size());
  powered_at_ = std::chrono::steady_clock::now();
  applied_forces_.fill(0.0);
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

void SimulatedBoard::offset_encoder(std::size_t axis, std::int64_t counts) {
  const std::lock_guard lock(mutex_);
  if (axis < axes_.size()) encoder_offsets_[axis] += counts;
}

BoardSnapshot SimulatedBoard::snapshot() const {
  const std::lock_guard lock(mutex_);
  BoardSnapshot s;
  s.firmware = firmware_.counters();
  s.output_counts = firmware_.output();
  s.applied_force = applied_forces_[0];
  for (std::size_t k = 0; k < axes_.size(); ++k) s.outputs[k] = firmware_.output(k);
  s.applied_forces = applied_forces_;
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
