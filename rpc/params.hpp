#pragma once
/// \file
/// The members a method's params object may hold, each with its JSON type,
/// and the one check every method's params go through before its handler
/// runs (the Dispatcher calls check_params). A member not declared is
/// refused, naming it and the accepted ones; a member of the wrong type is
/// refused, naming it and the type expected (docs/protocol.md, "Messages").
/// Header-only, below drivers/ (a driver's own methods declare theirs).

#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "rpc/jsonrpc.hpp"
#include "rpc/param_members.hpp"

namespace hapticd::rpc {

/// Within int64: nlohmann::json holds 2^63 .. 2^64-1 as unsigned, and
/// get<std::int64_t>() would wrap them to negatives.
inline bool fits_int64(const nlohmann::json& value) {
  return !value.is_number_unsigned() ||
         value.get<std::uint64_t>() <= static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());
}

inline bool matches(ParamType type, const nlohmann::json& value) {
  switch (type) {
    case ParamType::string:
      return value.is_string();
    case ParamType::boolean:
      return value.is_boolean();
    case ParamType::integer:
      return value.is_number_integer() && fits_int64(value);
    case ParamType::number:
      return value.is_number();
    case ParamType::object:
      return value.is_object();
    case ParamType::array:
      return value.is_array();
    case ParamType::scalar:
      return value.is_number() || value.is_string() || value.is_boolean();
    case ParamType::integer_or_string:
      return (value.is_number() && fits_int64(value)) || value.is_string();
    case ParamType::any:
      return true;
  }
  return false;
}

/// What a value is, for "..., not a number (5)": its JSON type, and the
/// value itself when short.
inline std::string what_it_is(const nlohmann::json& value) {
  std::string kind;
  switch (value.type()) {
    case nlohmann::json::value_t::null:
      return "null";
    case nlohmann::json::value_t::boolean:
      kind = "a boolean";
      break;
    case nlohmann::json::value_t::string:
      kind = "a string";
      break;
    case nlohmann::json::value_t::object:
      return "an object";
    case nlohmann::json::value_t::array:
      return "an array";
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned:
      kind = "an integer";
      break;
    default:
      kind = "a number";
  }
  const std::string text = value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return text.size() <= 40 ? kind + " (" + text + ")" : kind;
}

/// 'name' for messages: the name as JSON would escape it (a newline as \n,
/// a quote as \"), in single quotes, so a message stays one line.
inline std::string quoted_name(const std::string& name) {
  const std::string text =
      nlohmann::json(name).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return "'" + text.substr(1, text.size() - 2) + "'";
}

/// "kind, amount" or "" for none.
inline std::string member_list(const ParamMembers& members) {
  std::string list;
  for (const auto& m : members) list += (list.empty() ? "" : ", ") + m.name;
  return list;
}

/// Throws RpcError(invalid_params) for the first member of `params` (an
/// object) that `members` does not declare, or whose value is not of its
/// type: "record.start: member 'path' must be a string, not an integer (5)".
inline void check_params(std::string_view method, const nlohmann::json& params, const ParamMembers& members) {
  const std::string who(method);
  for (const auto& [key, value] : params.items()) {
    const ParamMember* declared = nullptr;
    for (const auto& m : members) {
      if (m.name == key) declared = &m;
    }
    if (declared == nullptr) {
      const std::string quoted = quoted_name(key);
      throw RpcError(code::invalid_params,
                     members.empty()
                         ? who + ": unknown member " + quoted + "; " + who + " accepts no members"
                         : who + ": unknown member " + quoted + "; accepted: " + member_list(members),
                     nlohmann::json{{"member", key}});
    }
    if (!matches(declared->type, value)) {
      throw RpcError(code::invalid_params,
                     who + ": member " + quoted_name(key) + " must be " +
                         std::string(describe(declared->type)) + ", not " + what_it_is(value),
                     nlohmann::json{{"member", key}});
    }
  }
}

/// The integer member `name` (checked as ParamType::integer) within
/// [minimum, maximum], or -32602 naming the member, the range and `unit`.
inline std::int64_t integer_in(std::string_view method, const nlohmann::json& params, const std::string& name,
                               std::int64_t minimum, std::int64_t maximum, std::string_view unit) {
  const nlohmann::json& value = params.at(name);
  const bool in_range = value.is_number_integer() && fits_int64(value) &&
                        value.get<std::int64_t>() >= minimum && value.get<std::int64_t>() <= maximum;
  if (!in_range) {
    throw RpcError(code::invalid_params,
                   std::string(method) + ": member " + quoted_name(name) + " must be an integer from " +
                       std::to_string(minimum) + " to " + std::to_string(maximum) + " " + std::string(unit) +
                       ", not " + what_it_is(value),
                   nlohmann::json{{"member", name}, {"minimum", minimum}, {"maximum", maximum}});
  }
  return value.get<std::int64_t>();
}

}  // namespace hapticd::rpc
