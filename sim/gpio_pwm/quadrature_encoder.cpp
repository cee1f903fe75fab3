#include "sim/gpio_pwm/quadrature_encoder.hpp"

#include <array>

namespace hapticd::drivers::gpio_pwm::sim {
namespace {

// The phases counting up, A leading B by a quarter cycle: index = count mod 4.
constexpr std::array<EncoderPhase, 4> cycle{EncoderPhase{false, false}, EncoderPhase{true, false},
                                            EncoderPhase{true, true}, EncoderPhase{false, true}};

}  // namespace

QuadratureEncoder::QuadratureEncoder(std::int64_t count) noexcept : count_(count) {}

EncoderPhase QuadratureEncoder::state_of(std::int64_t count) noexcept {
  const std::int64_t phase = ((count % 4) + 4) % 4;
  return cycle[static_cast<std::size_t>(phase)];
}

bool QuadratureEncoder::level(EncoderLine line) const noexcept {
  const EncoderPhase s = state();
  return line == EncoderLine::a ? s.a : s.b;
}

void QuadratureEncoder::move_to(std::int64_t target, std::uint64_t from_ns, std::uint64_t to_ns,
                                std::vector<EncoderEdge>& out) {
  const std::int64_t steps = target - count_;
  if (steps == 0) return;
  const std::uint64_t n = static_cast<std::uint64_t>(steps > 0 ? steps : -steps);
  const std::uint64_t span = to_ns > from_ns ? to_ns - from_ns : 0;
  const std::int64_t direction = steps > 0 ? 1 : -1;
  for (std::uint64_t k = 1; k <= n; ++k) {
    const EncoderPhase before = state();
    count_ += direction;
    const EncoderPhase after = state();
    // Exactly one line differs between neighbouring phases of the cycle.
    const bool a_changed = before.a != after.a;
    EncoderEdge edge;
    edge.line = a_changed ? EncoderLine::a : EncoderLine::b;
    edge.level = a_changed ? after.a : after.b;
    // Integer spread, exact at k = n; ties only when span < n (more counts
    // than nanoseconds), which a decoder then sees as simultaneous.
    // span * k / n without overflow: span = q n + r, so span k / n = q k + r k / n (r k < n^2).
    edge.timestamp_ns = from_ns + (span / n) * k + (span % n) * k / n;
    out.push_back(edge);
  }
}

}  // namespace hapticd::drivers::gpio_pwm::sim
