#pragma once
/// \file
/// `name=value` arguments of hapticctl (load, set, hand, fault inject).

#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace hapticd::client {

/// A malformed name=value argument (no '=', empty name, duplicate name).
class AssignmentError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// The JSON value of a command-line word: a finite number (integer if it has
/// no fraction/exponent and fits in int64) becomes a number, "true"/"false"
/// a boolean, "null" null, anything else (including "", "nan", "inf", "1e999")
/// a string. Quoting a value ('"2"') keeps it a string without the quotes.
nlohmann::json parse_value(std::string_view text);

/// Splits "name=value" at the first '='. Throws AssignmentError.
std::pair<std::string, nlohmann::json> parse_assignment(std::string_view word);

/// {"name": value, ...}. Throws AssignmentError on a malformed word or a
/// name given twice.
nlohmann::json parse_assignments(const std::vector<std::string>& words);

}  // namespace hapticd::client
