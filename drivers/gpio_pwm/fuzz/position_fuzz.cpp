// libFuzzer target: the gpio-pwm position path on what the kernel could
// hand it: line edges and sampled levels for the quadrature decoder, raw
// counts of a Generic Counter with any ceiling, and the text of a sysfs
// attribute. Input: 8 bytes of ceiling, then 9-byte records (a tag and 8
// bytes). Must hold: nothing crashes; the decoder never moves more counts
// than the transitions it saw; an unwrapped counter moves by at most half
// its range per read; a parsed sysfs value formats back to the same text
// that parses back to the same value.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string_view>

#include "drivers/gpio_pwm/counter_unwrap.hpp"
#include "drivers/gpio_pwm/quadrature_decoder.hpp"
#include "drivers/gpio_pwm/sysfs_value.hpp"

namespace {

namespace gp = hapticd::drivers::gpio_pwm;

void require(bool holds) {
  if (!holds) __builtin_trap();
}

std::uint64_t u64_at(const std::uint8_t* p) {
  std::uint64_t v = 0;
  std::memcpy(&v, p, sizeof v);
  return v;
}

void check_sysfs_text(std::string_view text) {
  const auto value = gp::parse_sysfs_u64(text);
  if (!value) return;
  std::array<char, gp::sysfs_u64_text_size> out{};
  const std::size_t n = gp::format_sysfs_u64(*value, out);
  require(n > 0);
  const std::string_view formatted(out.data(), n);
  require(formatted.back() == '\n' && gp::parse_sysfs_u64(formatted) == value);
}

// |counts moved| <= transitions seen, so the count never runs away.
void check_decoder(const gp::QuadratureDecoder& d, std::uint64_t steps) {
  const std::int64_t c = d.count();
  require(static_cast<std::uint64_t>(c < 0 ? -c : c) <= steps);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  check_sysfs_text(std::string_view(reinterpret_cast<const char*>(data), size));
  if (size < 8) return 0;
  const std::uint64_t ceiling = std::max<std::uint64_t>(u64_at(data), 1);
  gp::CounterUnwrap counter(ceiling, 0);
  gp::QuadratureDecoder decoder(static_cast<gp::QuadratureState>(data[0] & 3U), (data[0] & 4U) != 0);
  std::uint64_t steps = 0;
  for (std::size_t i = 8; i + 9 <= size; i += 9) {
    const std::uint8_t tag = data[i];
    const std::uint64_t value = u64_at(data + i + 1);
    switch (tag % 3) {
      case 0:
        decoder.sample(static_cast<gp::QuadratureState>(value & 3U));
        ++steps;
        break;
      case 1:
        decoder.edge((value & 1U) ? gp::QuadratureLine::b : gp::QuadratureLine::a, (value & 2U) != 0);
        ++steps;
        break;
      default: {
        const std::int64_t before = counter.position();
        if (counter.update(value)) {
          const std::int64_t moved = counter.position() - before;
          const std::uint64_t magnitude =
              moved < 0 ? 0 - static_cast<std::uint64_t>(moved) : static_cast<std::uint64_t>(moved);
          require(magnitude <= ceiling / 2 + 1);
        }
      }
    }
    check_decoder(decoder, steps);
  }
  return 0;
}
