#pragma once
/// \file
/// A kernel counter's count (Generic Counter interface,
/// /sys/bus/counter/devices/counterX/countY/count) is unsigned and wraps:
/// past `ceiling` it continues at 0 (and below 0 at `ceiling`). This turns
/// the raw counts read each period into a signed, unbounded position in
/// counts, assuming the count moves by less than half the range between two
/// reads (at 1 kHz and a 32-bit ceiling: 2^31 counts per ms). Pure.

#include <cstdint>

namespace hapticd::drivers::gpio_pwm {

class CounterUnwrap {
 public:
  /// `ceiling`: the largest raw count; the range has ceiling + 1 values
  /// (UINT64_MAX: the full 64-bit range). `first_raw`: the count read at
  /// configure; it becomes position `first_raw` (not 0), so a counter that
  /// never wraps reads its own count.
  CounterUnwrap(std::uint64_t ceiling, std::uint64_t first_raw) noexcept;

  /// The position after a new raw count. A raw count above the ceiling (a
  /// counter whose ceiling was changed behind our back) returns false and
  /// leaves the position unchanged; so does a move that would take the
  /// position outside int64.
  bool update(std::uint64_t raw) noexcept;
  std::int64_t position() const noexcept { return position_; }
  std::uint64_t last_raw() const noexcept { return last_; }

 private:
  std::uint64_t ceiling_;
  std::uint64_t last_;
  std::int64_t position_;
};

}  // namespace hapticd::drivers::gpio_pwm
