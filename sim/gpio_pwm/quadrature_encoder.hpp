#pragma once
/// \file
/// The two output lines of an incremental encoder: a count change becomes
/// the sequence of edges a real A/B encoder produces (A leads B for a
/// positive change: 00 -> 10 -> 11 -> 01 -> 00), each edge with its own
/// timestamp spread evenly over the interval in which the count moved.
/// Its own phase table, written from the encoder's published sequence, not
/// the driver's decoder's: a misreading in either then fails instead of
/// passing both ends. No system calls.

#include <cstdint>
#include <vector>

namespace hapticd::drivers::gpio_pwm::sim {

enum class EncoderLine : std::uint8_t { a, b };

/// The levels of the two lines.
struct EncoderPhase {
  bool a = false;
  bool b = false;
  friend bool operator==(const EncoderPhase&, const EncoderPhase&) = default;
};

struct EncoderEdge {
  EncoderLine line = EncoderLine::a;
  bool level = false;
  std::uint64_t timestamp_ns = 0;
  friend bool operator==(const EncoderEdge&, const EncoderEdge&) = default;
};

class QuadratureEncoder {
 public:
  explicit QuadratureEncoder(std::int64_t count = 0) noexcept;

  /// Moves to `target` over (from_ns, to_ns]: one edge per count, the k-th
  /// of n at from_ns + k (to_ns - from_ns) / n. Appends to `out`.
  void move_to(std::int64_t target, std::uint64_t from_ns, std::uint64_t to_ns,
               std::vector<EncoderEdge>& out);

  std::int64_t count() const noexcept { return count_; }
  EncoderPhase state() const noexcept { return state_of(count_); }
  bool level(EncoderLine line) const noexcept;
  /// The levels of the lines at a count (count 0: both low).
  static EncoderPhase state_of(std::int64_t count) noexcept;

 private:
  std::int64_t count_;
};

}  // namespace hapticd::drivers::gpio_pwm::sim
