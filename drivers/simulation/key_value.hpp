#pragma once
/// \file
/// Internal: splits "key=value key=value" text into pairs (non-RT).

#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hapticd::drivers::simulation::detail {

/// Splits on spaces/tabs; every token must be key=value with a non-empty key
/// and value. Throws std::invalid_argument("<what>: ...") otherwise.
inline std::vector<std::pair<std::string, std::string>> split_key_values(std::string_view text,
                                                                         std::string_view what) {
  std::vector<std::pair<std::string, std::string>> pairs;
  std::size_t i = 0;
  while (i < text.size()) {
    while (i < text.size() && (text[i] == ' ' || text[i] == '\t' || text[i] == '\n' || text[i] == ',')) ++i;
    if (i >= text.size()) break;
    std::size_t j = i;
    while (j < text.size() && text[j] != ' ' && text[j] != '\t' && text[j] != '\n' && text[j] != ',') ++j;
    const std::string_view token = text.substr(i, j - i);
    const std::size_t eq = token.find('=');
    if (eq == std::string_view::npos || eq == 0 || eq + 1 == token.size()) {
      throw std::invalid_argument(std::string(what) + ": '" + std::string(token) +
                                  "' is not key=value (e.g. mode=hold)");
    }
    pairs.emplace_back(std::string(token.substr(0, eq)), std::string(token.substr(eq + 1)));
    i = j;
  }
  return pairs;
}

}  // namespace hapticd::drivers::simulation::detail
