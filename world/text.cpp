#include "world/text.hpp"

#include <charconv>
#include <cstdio>
#include <system_error>

namespace hapticd::world::text {

namespace {

// 17 significant digits and an exponent, or 1e308 with a few hundred
// decimals (format_fixed): room for either.
constexpr std::size_t buffer_size = 400;

template <class... Format>
std::string to_text(double value, Format... format) {
  char buffer[buffer_size];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value, format...);
  return {buffer, ec == std::errc{} ? end : buffer};
}

}  // namespace

std::string format_number(double value) { return to_text(value); }

std::string format_significant(double value, int digits) {
  return to_text(value, std::chars_format::general, digits);
}

std::string format_fixed(double value, int decimals) {
  return to_text(value, std::chars_format::fixed, decimals);
}

std::string format_quantity(double value, std::string_view unit, int digits) {
  std::string out = format_significant(value, digits);
  if (!unit.empty()) (out += ' ') += unit;
  return out;
}

std::string format_hex(std::uint32_t value, int digits) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%0*X", digits, value);
  return text;
}

std::string errno_text(int error) { return std::generic_category().message(error); }

void append_number(std::string& out, double value) {
  char buffer[32];  // the shortest round trip needs at most 24
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof buffer, value);
  out.append(buffer, ec == std::errc{} ? end : buffer);
}

std::string join(std::span<const std::string> items, std::string_view separator) {
  std::string out;
  for (const auto& item : items) {
    if (!out.empty()) out += separator;
    out += item;
  }
  return out;
}

std::string join(std::initializer_list<std::string_view> items, std::string_view separator) {
  std::string out;
  for (const auto item : items) {
    if (!out.empty()) out += separator;
    out += item;
  }
  return out;
}

std::string markdown_cell(std::string_view text) {
  std::string out;
  for (const char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
  return out;
}

}  // namespace hapticd::world::text
