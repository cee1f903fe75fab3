#include "sim/gpio_pwm/quadrature_encoder.hpp"

#include <array>

namespace hapticd::drivers::gpio_pwm::sim {
namespace {

// Forward cycle of states: index = count mod 4.
constexpr std::array<QuadratureState, 4> cycle{quadrature_state(false, false), quadrature_state(true, false),
                                               quadrature_state(true, true), quadrature_state(false, true)};

}  // namespace

QuadratureEncoder::QuadratureEncoder(std::int64_t count) noexcept : count_(count) {}

QuadratureState QuadratureEncoder::state_of(std::int64_t count) noexcept {
  const std::int64_t phase = ((count % 4) + 4) % 4;
  return cycle[static_cast<std::size_t>(phase)];
}

bool QuadratureEncoder::level(QuadratureLine line) const noexcept {
  const QuadratureState s = state();
  return (s & (line == QuadratureLine::a ? 2U : 1U)) != 0;
}

void QuadratureEncoder::move_to(std::int64_t target, std::uint64_t from_ns, std::uint64_t to_ns,
                                std::vector<EncoderEdge>& out) {
  const std::int64_t steps = target - count_;
  if (steps == 0) return;
  const std::uint64_t n = static_cast<std::uint64_t>(steps > 0 ? steps : -steps);
  const std::uint64_t span = to_ns > from_ns ? to_ns - from_ns : 0;
  const std::int64_t direction = steps > 0 ? 1 : -1;
  for (std::uint64_t k = 1; k <= n; ++k) {
    const QuadratureState before = state();
    count_ += direction;
    const QuadratureState after = state();
    // Exactly one line differs between neighbouring states of the cycle.
    const bool a_changed = ((before ^ after) & 2U) != 0;
    EncoderEdge edge;
    edge.line = a_changed ? QuadratureLine::a : QuadratureLine::b;
    edge.level = (after & (a_changed ? 2U : 1U)) != 0;
    // Integer spread, exact at k = n; ties only when span < n (more counts
    // than nanoseconds), which a decoder then sees as simultaneous.
    // span * k / n without overflow: span = q n + r, so span k / n = q k + r k / n (r k < n^2).
    edge.timestamp_ns = from_ns + (span / n) * k + (span % n) * k / n;
    out.push_back(edge);
  }
}

}  // namespace hapticd::drivers::gpio_pwm::sim
