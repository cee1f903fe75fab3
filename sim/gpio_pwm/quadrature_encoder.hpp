#pragma once
/// \file
/// The two output lines of an incremental encoder: a count change becomes
/// the sequence of edges a real A/B encoder produces (A leads B for a
/// positive change: 00 -> 10 -> 11 -> 01 -> 00), each edge with its own
/// timestamp spread evenly over the interval in which the count moved.
/// No system calls.

#include <cstdint>
#include <vector>

#include "drivers/gpio_pwm/quadrature_decoder.hpp"

namespace hapticd::drivers::gpio_pwm::sim {

struct EncoderEdge {
  QuadratureLine line = QuadratureLine::a;
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
  QuadratureState state() const noexcept { return state_of(count_); }
  bool level(QuadratureLine line) const noexcept;
  /// The state of the lines at a count (count 0 = 00).
  static QuadratureState state_of(std::int64_t count) noexcept;

 private:
  std::int64_t count_;
};

}  // namespace hapticd::drivers::gpio_pwm::sim
