#include "drivers/gpio_pwm/quadrature_decoder.hpp"

#include <array>

namespace hapticd::drivers::gpio_pwm {
namespace {

constexpr Transition N = Transition::none;
constexpr Transition F = Transition::forward;
constexpr Transition B = Transition::backward;
constexpr Transition X = Transition::invalid;

// Row: from, column: to; index = (A << 1) | B. Forward: 00 -> 10 -> 11 -> 01 -> 00.
constexpr std::array<std::array<Transition, 4>, 4> table{{
    //         to 00 01 10 11
    /* 00 */ {{N, B, F, X}},
    /* 01 */ {{F, N, X, B}},
    /* 10 */ {{B, X, N, F}},
    /* 11 */ {{X, F, B, N}},
}};

constexpr QuadratureState with_line(QuadratureState state, QuadratureLine line, bool level) noexcept {
  const unsigned bit = line == QuadratureLine::a ? 2U : 1U;
  return static_cast<QuadratureState>(level ? (state | bit) : (state & ~bit & 3U));
}

constexpr bool level_of(QuadratureState state, QuadratureLine line) noexcept {
  return (state & (line == QuadratureLine::a ? 2U : 1U)) != 0;
}

}  // namespace

Transition classify_transition(QuadratureState from, QuadratureState to) noexcept {
  return table[from & 3U][to & 3U];
}

Transition QuadratureDecoder::sample(QuadratureState next) noexcept {
  next &= 3U;
  const Transition t = classify_transition(state_, next);
  switch (t) {
    case Transition::forward:
      count_ += reverse_ ? -1 : 1;
      break;
    case Transition::backward:
      count_ += reverse_ ? 1 : -1;
      break;
    case Transition::invalid:
      ++invalid_;
      break;
    case Transition::none:
      break;
  }
  state_ = next;
  return t;
}

Transition QuadratureDecoder::edge(QuadratureLine line, bool level) noexcept {
  ++edges_;
  if (level_of(state_, line) == level) {
    ++lost_;
    return Transition::none;
  }
  return sample(with_line(state_, line, level));
}

void QuadratureDecoder::edges(std::span<const EdgeEvent> a, std::span<const EdgeEvent> b) noexcept {
  std::size_t i = 0, j = 0;
  while (i < a.size() || j < b.size()) {
    const bool take_a = j == b.size() || (i < a.size() && a[i].timestamp_ns < b[j].timestamp_ns);
    const bool take_b = i == a.size() || (j < b.size() && b[j].timestamp_ns < a[i].timestamp_ns);
    if (take_a) {
      edge(QuadratureLine::a, a[i++].rising);
    } else if (take_b) {
      edge(QuadratureLine::b, b[j++].rising);
    } else {
      // Same timestamp on both lines: one sample in which both may change.
      edges_ += 2;
      const bool a_level = a[i++].rising;
      const bool b_level = b[j++].rising;
      if (level_of(state_, QuadratureLine::a) == a_level) ++lost_;
      if (level_of(state_, QuadratureLine::b) == b_level) ++lost_;
      sample(quadrature_state(a_level, b_level));
    }
  }
}

void QuadratureDecoder::reset(QuadratureState state, std::int64_t count) noexcept {
  state_ = state & 3U;
  count_ = count;
}

}  // namespace hapticd::drivers::gpio_pwm
