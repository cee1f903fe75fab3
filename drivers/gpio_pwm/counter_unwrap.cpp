#include "drivers/gpio_pwm/counter_unwrap.hpp"

#include <limits>

namespace hapticd::drivers::gpio_pwm {

CounterUnwrap::CounterUnwrap(std::uint64_t ceiling, std::uint64_t first_raw) noexcept
    : ceiling_(ceiling), last_(first_raw), position_(static_cast<std::int64_t>(first_raw)) {}

bool CounterUnwrap::update(std::uint64_t raw) noexcept {
  if (raw > ceiling_) return false;
  // Forward distance from last_ to raw on a circle of ceiling_ + 1 values.
  std::uint64_t forward = raw - last_;  // wraps modulo 2^64
  if (raw < last_ && ceiling_ != std::numeric_limits<std::uint64_t>::max()) forward += ceiling_ + 1;
  // The range is ceiling_ + 1; a forward distance beyond half of it is a
  // backward move. Halves compared without computing ceiling_ + 1 (which
  // overflows for the full 64-bit range).
  const std::uint64_t half = ceiling_ / 2 + 1;
  std::int64_t delta = 0;
  if (forward < half) {
    delta = static_cast<std::int64_t>(forward);
  } else {
    const std::uint64_t backward = ceiling_ - forward + 1;  // range - forward, in [1, 2^63]
    delta = -static_cast<std::int64_t>(backward - 1) - 1;   // no overflow at 2^63
  }
  // Unbounded in principle, int64 in fact: a position that would leave it
  // (only a 64-bit counter jumping by ~2^63 per read can get there) is a
  // bad read, not a wrap to the other end of the range (fuzzing found it).
  std::int64_t next = 0;
  if (__builtin_add_overflow(position_, delta, &next)) return false;
  if (next == std::numeric_limits<std::int64_t>::min()) return false;  // `reverse` negates it
  position_ = next;
  last_ = raw;
  return true;
}

}  // namespace hapticd::drivers::gpio_pwm
