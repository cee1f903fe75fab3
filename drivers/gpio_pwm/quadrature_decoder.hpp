#pragma once
/// \file
/// x4 quadrature decoding of two lines A and B. Pure: no system calls.
///
/// The state is the pair of levels (A, B). With A leading B (the forward
/// direction) the states go 00 -> 10 -> 11 -> 01 -> 00; each step is one
/// count. Of the 16 (from, to) transitions, 4 keep the state, 4 count +1,
/// 4 count -1 and 4 change both lines at once: impossible for a quadrature
/// signal sampled fast enough, so they are counted as errors and the
/// position is left unchanged (which of the two lines moved first is lost).
///
/// From line events (the GPIO character device reports one line per event
/// queue, uAPI v1): each event gives the new level of one line. An A and a
/// B event with the same timestamp are one transition in which both lines
/// changed. An event that reports the level its line already has means the
/// opposite edge in between was lost (the kernel queue of 16 events per
/// line overflowed, or the line bounced faster than its interrupt thread
/// read it: uAPI v1 takes the level when the thread runs): counted as a
/// lost edge.

#include <cstdint>
#include <span>

namespace hapticd::drivers::gpio_pwm {

/// Levels of A and B: bit 1 = A, bit 0 = B.
using QuadratureState = std::uint8_t;
constexpr QuadratureState quadrature_state(bool a, bool b) noexcept {
  return static_cast<QuadratureState>((a ? 2U : 0U) | (b ? 1U : 0U));
}

enum class Transition : std::uint8_t { none, forward, backward, invalid };

/// The 16-entry table: what going from `from` to `to` means (A leads B = forward).
Transition classify_transition(QuadratureState from, QuadratureState to) noexcept;

enum class QuadratureLine : std::uint8_t { a, b };

/// One edge as the kernel reports it.
struct EdgeEvent {
  std::uint64_t timestamp_ns = 0;
  bool rising = false;  ///< the line's level after the edge
};

/// Kernel line-event queue depth per line (GPIO uAPI v1: a 16-entry kfifo
/// per requested line, drivers/gpio/gpiolib-cdev.c).
inline constexpr unsigned kernel_event_queue_depth = 16;

/// The highest count rate (counts/s, x4) decodable without loss when the
/// decoding thread may be kept from reading for `worst_read_gap_s`: each
/// line carries one edge per two counts, so a line's queue fills after
/// 2 x 16 counts.
constexpr double max_count_rate(double worst_read_gap_s) noexcept {
  return 2.0 * kernel_event_queue_depth / worst_read_gap_s;
}

class QuadratureDecoder {
 public:
  explicit QuadratureDecoder(QuadratureState initial = 0, bool reverse = false) noexcept
      : state_(initial & 3U), reverse_(reverse) {}

  /// A sampled state. Returns what it was; updates count and errors.
  Transition sample(QuadratureState next) noexcept;
  /// One edge of one line.
  Transition edge(QuadratureLine line, bool level) noexcept;
  /// The events read from A's and B's queues in one go, each in its own
  /// time order: merged by timestamp; equal timestamps are one sample.
  void edges(std::span<const EdgeEvent> a, std::span<const EdgeEvent> b) noexcept;

  std::int64_t count() const noexcept { return count_; }
  QuadratureState state() const noexcept { return state_; }
  std::uint64_t invalid_transitions() const noexcept { return invalid_; }
  std::uint64_t lost_edges() const noexcept { return lost_; }
  std::uint64_t edges_seen() const noexcept { return edges_; }
  /// Restart from a measured state (e.g. after the lines were re-read).
  void reset(QuadratureState state, std::int64_t count) noexcept;

 private:
  QuadratureState state_;
  bool reverse_;
  std::int64_t count_ = 0;
  std::uint64_t invalid_ = 0;
  std::uint64_t lost_ = 0;
  std::uint64_t edges_ = 0;
};

}  // namespace hapticd::drivers::gpio_pwm
