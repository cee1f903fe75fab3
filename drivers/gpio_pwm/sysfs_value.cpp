#include "drivers/gpio_pwm/sysfs_value.hpp"

#include <charconv>

namespace hapticd::drivers::gpio_pwm {

std::optional<std::uint64_t> parse_sysfs_u64(std::string_view text) noexcept {
  const std::size_t newline = text.find('\n');
  if (newline != std::string_view::npos) text = text.substr(0, newline);
  if (text.empty()) return std::nullopt;
  std::uint64_t value = 0;
  const char* const end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value, 10);
  if (ec != std::errc{} || ptr != end) return std::nullopt;
  return value;
}

std::size_t format_sysfs_u64(std::uint64_t value, std::span<char> out) noexcept {
  if (out.size() < sysfs_u64_text_size) return 0;
  const auto [ptr, ec] = std::to_chars(out.data(), out.data() + out.size() - 1, value, 10);
  if (ec != std::errc{}) return 0;
  *ptr = '\n';
  return static_cast<std::size_t>(ptr - out.data()) + 1;
}

}  // namespace hapticd::drivers::gpio_pwm
