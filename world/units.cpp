#include "world/units.hpp"

#include <charconv>
#include <cmath>
#include <utility>

#include "world/text.hpp"

namespace hapticd::world::units {

std::optional<double> parse_finite(std::string_view text) noexcept {
  while (!text.empty() && text.front() == ' ') text.remove_prefix(1);
  while (!text.empty() && text.back() == ' ') text.remove_suffix(1);
  if (text.empty()) return std::nullopt;
  if (text.front() == '+') text.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

std::optional<double> parse_duration_s(std::string_view text) noexcept {
  double scale = 1.0;
  if (text.ends_with("us")) {
    scale = 1e-6;
    text.remove_suffix(2);
  } else if (text.ends_with("ms")) {
    scale = 1e-3;
    text.remove_suffix(2);
  } else if (text.ends_with("s")) {
    text.remove_suffix(1);
  }
  const auto value = parse_finite(text);
  if (!value) return std::nullopt;
  return *value * scale;
}

std::string format_duration(double seconds) {
  const double magnitude = std::abs(seconds);
  const auto [scale, unit] = magnitude != 0.0 && magnitude < 1e-3  ? std::pair{1e6, "us"}
                             : magnitude != 0.0 && magnitude < 1.0 ? std::pair{1e3, "ms"}
                                                                   : std::pair{1.0, "s"};
  return text::format_significant(seconds * scale, text::precision::converted) + unit;
}

}  // namespace hapticd::world::units
