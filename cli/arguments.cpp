#include "cli/arguments.hpp"

#include <cmath>

#include "cli/usage_error.hpp"
#include "world/units.hpp"

namespace hapticd::cli {

namespace {
[[noreturn]] void reject(std::string_view flag, const std::string& text, std::string_view expected) {
  throw UsageError(std::string(flag) + ": '" + text + "' is not accepted; expected " + std::string(expected));
}
std::string with_unit(std::string what, std::string_view unit) {
  if (!unit.empty()) what += " (" + std::string(unit) + ")";
  return what;
}
}  // namespace

double positive_number(std::string_view flag, const std::string& text, std::string_view unit) {
  const auto value = world::units::parse_finite(text);
  if (!value || *value <= 0.0) reject(flag, text, with_unit("a finite number > 0", unit));
  return *value;
}

double non_negative_number(std::string_view flag, const std::string& text, std::string_view unit) {
  const auto value = world::units::parse_finite(text);
  if (!value || *value < 0.0) reject(flag, text, with_unit("a finite number >= 0", unit));
  return *value;
}

double positive_duration(std::string_view flag, const std::string& text) {
  const auto value = world::units::parse_duration_s(text);
  if (!value || *value <= 0.0) reject(flag, text, "a duration > 0 such as 1ms, 250us or 0.001s");
  return *value;
}

double non_negative_duration(std::string_view flag, const std::string& text) {
  const auto value = world::units::parse_duration_s(text);
  if (!value || *value < 0.0) reject(flag, text, "a duration >= 0 such as 0, 2ms, 250us or 0.002s");
  return *value;
}

double duration_within(std::string_view flag, const std::string& text, double min_s, double max_s,
                       std::string_view expected) {
  const auto value = world::units::parse_duration_s(text);
  constexpr double slack = 1e-12;
  if (!value || !(*value >= min_s * (1.0 - slack)) || !(*value <= max_s * (1.0 + slack))) {
    reject(flag, text, expected);
  }
  return *value;
}

int whole_number(std::string_view flag, const std::string& text, int min, int max) {
  const auto value = world::units::parse_finite(text);
  if (!value || *value != std::floor(*value) || *value < min || *value > max) {
    reject(flag, text, "a whole number from " + std::to_string(min) + " to " + std::to_string(max));
  }
  return static_cast<int>(*value);
}

std::optional<double> optional_positive(std::string_view flag, const std::string& text,
                                        std::string_view unit) {
  if (text.empty()) return std::nullopt;
  return positive_number(flag, text, unit);
}

std::optional<double> optional_non_negative(std::string_view flag, const std::string& text,
                                            std::string_view unit) {
  if (text.empty()) return std::nullopt;
  return non_negative_number(flag, text, unit);
}

}  // namespace hapticd::cli
