#include "sim/gpio_pwm/kernel_sysfs_text.hpp"

#include <cerrno>
#include <climits>

namespace hapticd::drivers::gpio_pwm::sim {
namespace {

char lower(char c) noexcept { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; }
bool is_hex(char c) noexcept { return (c >= '0' && c <= '9') || (lower(c) >= 'a' && lower(c) <= 'f'); }

/// _parse_integer_fixup_radix().
std::size_t fixup_radix(std::string_view s, unsigned& base) noexcept {
  if (base == 0) {
    if (!s.empty() && s[0] == '0') {
      base = s.size() > 2 && lower(s[1]) == 'x' && is_hex(s[2]) ? 16 : 8;
    } else {
      base = 10;
    }
  }
  if (base == 16 && s.size() >= 2 && s[0] == '0' && lower(s[1]) == 'x') return 2;
  return 0;
}

unsigned digit_value(char c) noexcept {
  if (c >= '0' && c <= '9') return static_cast<unsigned>(c - '0');
  if (lower(c) >= 'a' && lower(c) <= 'f') return static_cast<unsigned>(lower(c) - 'a' + 10);
  return 16;  // not a digit of any base used here
}

/// _kstrtoull() after the sign.
int parse_unsigned(std::string_view s, unsigned base, std::uint64_t& value) noexcept {
  std::size_t i = fixup_radix(s, base);
  std::uint64_t v = 0;
  std::size_t digits = 0;
  bool overflow = false;
  for (; i < s.size(); ++i, ++digits) {
    const unsigned d = digit_value(s[i]);
    if (d >= base) break;
    if (v > (UINT64_MAX - d) / base) overflow = true;
    v = v * base + d;
  }
  if (digits == 0) return EINVAL;
  if (overflow) return ERANGE;
  if (i < s.size() && s[i] == '\n') ++i;
  if (i != s.size()) return EINVAL;
  value = v;
  return 0;
}

}  // namespace

int kernel_kstrtoull(std::string_view text, unsigned base, std::uint64_t& value) noexcept {
  if (!text.empty() && text[0] == '+') text.remove_prefix(1);
  return parse_unsigned(text, base, value);
}

int kernel_kstrtouint(std::string_view text, unsigned base, unsigned& value) noexcept {
  std::uint64_t v = 0;
  if (const int error = kernel_kstrtoull(text, base, v); error != 0) return error;
  if (v > UINT_MAX) return ERANGE;
  value = static_cast<unsigned>(v);
  return 0;
}

int kernel_kstrtoint(std::string_view text, unsigned base, int& value) noexcept {
  std::uint64_t magnitude = 0;
  if (!text.empty() && text[0] == '-') {
    if (const int error = parse_unsigned(text.substr(1), base, magnitude); error != 0) return error;
    if (magnitude > static_cast<std::uint64_t>(INT_MAX) + 1) return ERANGE;
    value = static_cast<int>(-static_cast<std::int64_t>(magnitude));
    return 0;
  }
  if (const int error = kernel_kstrtoull(text, base, magnitude); error != 0) return error;
  if (magnitude > static_cast<std::uint64_t>(INT_MAX)) return ERANGE;
  value = static_cast<int>(magnitude);
  return 0;
}

bool kernel_sysfs_streq(std::string_view written, std::string_view word) noexcept {
  if (written.ends_with('\n')) written.remove_suffix(1);
  if (word.ends_with('\n')) word.remove_suffix(1);
  return written == word;
}

std::size_t kernel_print_llu(std::uint64_t value, char* out, std::size_t size) noexcept {
  if (size < 21) return 0;
  char digits[20];
  std::size_t n = 0;
  do {
    digits[n++] = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value != 0);
  for (std::size_t i = 0; i < n; ++i) out[i] = digits[n - 1 - i];
  out[n] = '\n';
  return n + 1;
}

}  // namespace hapticd::drivers::gpio_pwm::sim
