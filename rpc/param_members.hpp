#pragma once
/// \file
/// The members a method's params object may hold, each with its JSON type:
/// the declarations alone, without nlohmann/json.hpp, for the headers that
/// only declare methods (drivers/device_hooks.hpp); the check itself is in
/// rpc/params.hpp.

#include <string>
#include <string_view>
#include <vector>

namespace hapticd::rpc {

/// What a member's value must be. integer: a JSON integer that fits a
/// signed 64-bit integer (18446744073709551615 is not -1).
enum class ParamType {
  string,
  boolean,
  integer,
  number,             ///< any finite JSON number
  object,             ///< a JSON object (its members are the handler's to check)
  array,              ///< a JSON array (its items are the handler's to check)
  scalar,             ///< a number, a string or a boolean
  integer_or_string,  ///< an integer as above, a number or a string (read by the handler, e.g. "0x6041")
  any,                ///< any value, null included
};

/// "a string", "true or false", ... for messages.
constexpr std::string_view describe(ParamType type) noexcept {
  switch (type) {
    case ParamType::string:
      return "a string";
    case ParamType::boolean:
      return "true or false";
    case ParamType::integer:
      return "an integer from -9223372036854775808 to 9223372036854775807";
    case ParamType::number:
      return "a number";
    case ParamType::object:
      return "an object";
    case ParamType::array:
      return "an array";
    case ParamType::scalar:
      return "a number, a string, true or false";
    case ParamType::integer_or_string:
      return "a number from -9223372036854775808 to 9223372036854775807 or a string";
    case ParamType::any:
      return "any value";
  }
  return "a value";
}

struct ParamMember {
  std::string name;
  ParamType type;
};

/// The members a method accepts; empty: none.
using ParamMembers = std::vector<ParamMember>;

}  // namespace hapticd::rpc
