#include "client/assignment.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>

namespace hapticd::client {

namespace {
bool looks_numeric(std::string_view t) {
  // Only plain decimal numbers: from_chars/strtod would also take "inf",
  // "nan" and hex, which are names here, not numbers.
  if (t.empty()) return false;
  std::size_t i = 0;
  if (t[i] == '+' || t[i] == '-') ++i;
  bool digits = false;
  while (i < t.size() && t[i] >= '0' && t[i] <= '9') {
    ++i;
    digits = true;
  }
  if (i < t.size() && t[i] == '.') {
    ++i;
    while (i < t.size() && t[i] >= '0' && t[i] <= '9') {
      ++i;
      digits = true;
    }
  }
  if (!digits) return false;
  if (i < t.size() && (t[i] == 'e' || t[i] == 'E')) {
    ++i;
    if (i < t.size() && (t[i] == '+' || t[i] == '-')) ++i;
    bool exp_digits = false;
    while (i < t.size() && t[i] >= '0' && t[i] <= '9') {
      ++i;
      exp_digits = true;
    }
    if (!exp_digits) return false;
  }
  return i == t.size();
}
}  // namespace

nlohmann::json parse_value(std::string_view text) {
  if (text == "true") return true;
  if (text == "false") return false;
  if (text == "null") return nullptr;
  if (text.size() >= 2 &&
      ((text.front() == '"' && text.back() == '"') || (text.front() == '\'' && text.back() == '\''))) {
    return std::string(text.substr(1, text.size() - 2));
  }
  if (looks_numeric(text)) {
    std::string_view digits = text.front() == '+' ? text.substr(1) : text;
    if (digits.find_first_of(".eE") == std::string_view::npos) {
      std::int64_t integer = 0;
      auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), integer);
      if (ec == std::errc{} && end == digits.data() + digits.size()) return integer;
    }
    std::string copy(text);
    errno = 0;
    char* end = nullptr;
    double value = std::strtod(copy.c_str(), &end);
    if (errno != ERANGE && end == copy.c_str() + copy.size() && std::isfinite(value)) return value;
  }
  return std::string(text);
}

std::pair<std::string, nlohmann::json> parse_assignment(std::string_view word) {
  auto eq = word.find('=');
  if (eq == std::string_view::npos) {
    throw AssignmentError("expected name=value, got '" + std::string(word) + "'");
  }
  std::string_view name = word.substr(0, eq);
  if (name.empty()) throw AssignmentError("missing name before '=' in '" + std::string(word) + "'");
  return {std::string(name), parse_value(word.substr(eq + 1))};
}

nlohmann::json parse_assignments(const std::vector<std::string>& words) {
  nlohmann::json object = nlohmann::json::object();
  for (const auto& word : words) {
    auto [name, value] = parse_assignment(word);
    if (object.contains(name)) throw AssignmentError("'" + name + "' given twice");
    object[name] = std::move(value);
  }
  return object;
}

}  // namespace hapticd::client
