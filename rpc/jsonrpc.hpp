#pragma once
/// \file
/// The hapticd control protocol: newline-delimited JSON-RPC 2.0 over a Unix
/// stream socket (see docs/protocol.md). Header-only and shared by the server
/// (daemon/control) and the client library (client/).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_set>
#include <vector>

#include <nlohmann/json.hpp>

namespace hapticd::rpc {

inline constexpr std::string_view version = "2.0";

/// Error codes. The standard ones come from the JSON-RPC 2.0 specification;
/// the application ones (-32000..-32003) are hapticd's. A latched fault is
/// no error code: scene.load and param.set still take effect (the output
/// stays zero until fault.clear), and status reports the fault.
namespace code {
inline constexpr int parse_error = -32700;       ///< the line is not JSON
inline constexpr int invalid_request = -32600;   ///< JSON, but not a request object
inline constexpr int method_not_found = -32601;  ///< no such method
inline constexpr int invalid_params = -32602;    ///< params missing, of the wrong type, or not an object
inline constexpr int internal_error = -32603;    ///< a handler failed unexpectedly
inline constexpr int refused =
    -32000;  ///< the daemon refuses (e.g. unstable parameters); data carries the limit
inline constexpr int not_permitted = -32001;  ///< the peer's credentials do not allow this method
inline constexpr int busy = -32002;           ///< too many clients, or the daemon cannot take the request now
inline constexpr int message_too_large =
    -32003;  ///< a request line exceeded the size limit; the connection closes
}  // namespace code

/// Short name of a code for messages and the CLI ("refused", "parse error", ...).
constexpr std::string_view code_name(int c) noexcept {
  switch (c) {
    case code::parse_error:
      return "parse error";
    case code::invalid_request:
      return "invalid request";
    case code::method_not_found:
      return "method not found";
    case code::invalid_params:
      return "invalid params";
    case code::internal_error:
      return "internal error";
    case code::refused:
      return "refused";
    case code::not_permitted:
      return "not permitted";
    case code::busy:
      return "busy";
    case code::message_too_large:
      return "message too large";
    default:
      return "error";
  }
}

/// A JSON-RPC error object as an exception. Handlers throw it to answer with
/// an error; the client throws it when the daemon answers with one.
class RpcError : public std::runtime_error {
 public:
  RpcError(int error_code, const std::string& message, nlohmann::json data = nullptr)
      : std::runtime_error(message), code_(error_code), data_(std::move(data)) {}

  int code() const noexcept { return code_; }
  /// Extra detail (e.g. {"limit": ...} for refused); null when absent.
  const nlohmann::json& data() const noexcept { return data_; }

  /// {"code":..,"message":..,"data":..} ("data" only when not null).
  nlohmann::json to_json() const {
    nlohmann::json e{{"code", code_}, {"message", what()}};
    if (!data_.is_null()) e["data"] = data_;
    return e;
  }

 private:
  int code_;
  nlohmann::json data_;
};

/// {"jsonrpc":"2.0","id":id,"result":result}
inline nlohmann::json make_result(const nlohmann::json& id, nlohmann::json result) {
  return {{"jsonrpc", version}, {"id", id}, {"result", std::move(result)}};
}

/// {"jsonrpc":"2.0","id":id,"error":{...}}; id is null when the request's id could not be read.
inline nlohmann::json make_error(const nlohmann::json& id, const RpcError& error) {
  return {{"jsonrpc", version}, {"id", id}, {"error", error.to_json()}};
}

/// {"jsonrpc":"2.0","method":method,"params":params}: a notification (no id).
inline nlohmann::json make_notification(std::string_view method, nlohmann::json params) {
  return {{"jsonrpc", version}, {"method", method}, {"params", std::move(params)}};
}

/// One line on the wire: compact JSON (invalid UTF-8 replaced, never throws
/// for that) followed by '\n'.
inline std::string to_line(const nlohmann::json& message) {
  std::string line = message.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  line.push_back('\n');
  return line;
}

/// Deepest nesting of arrays and objects accepted in one message, the
/// message object itself being level 1 (docs/protocol.md, "Limits").
/// nlohmann::json copies, compares and dumps a value by recursing once per
/// level, so a line of 60,000 brackets would overflow the stack: both ends
/// refuse deeper lines before parsing them.
inline constexpr std::size_t max_nesting_depth = 64;

/// True when `text` opens more than `limit` arrays/objects inside one
/// another. Brackets inside strings do not count. One pass, no allocation;
/// exact for valid JSON, and any text it passes holds no deeper nesting.
constexpr bool nests_deeper_than(std::string_view text, std::size_t limit) noexcept {
  std::size_t depth = 0;
  bool in_string = false;
  bool escaped = false;
  for (const char ch : text) {
    if (in_string) {
      if (escaped) {
        escaped = false;
      } else if (ch == '\\') {
        escaped = true;
      } else if (ch == '"') {
        in_string = false;
      }
    } else if (ch == '"') {
      in_string = true;
    } else if (ch == '[' || ch == '{') {
      if (++depth > limit) return true;
    } else if ((ch == ']' || ch == '}') && depth > 0) {
      --depth;
    }
  }
  return false;
}

/// A message parsed, and the first member name found twice in one object
/// (at any depth), if any. nlohmann::json keeps the last of duplicates
/// silently, so {"method":"status","method":"estop"} would run estop: the
/// parser's callback sees every key before that happens.
struct ParsedMessage {
  nlohmann::json value;
  std::optional<std::string> duplicate;
};

/// Parses `text` (throws nlohmann::json::exception when it is not JSON),
/// noting duplicate members. Call after nests_deeper_than(): one set of
/// names per open object.
inline ParsedMessage parse_message(std::string_view text) {
  ParsedMessage out;
  std::vector<std::unordered_set<std::string>> open_objects;
  auto note = [&](int /*depth*/, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
    using event_t = nlohmann::json::parse_event_t;
    if (event == event_t::object_start) {
      open_objects.emplace_back();
    } else if (event == event_t::object_end && !open_objects.empty()) {
      open_objects.pop_back();
    } else if (event == event_t::key && !open_objects.empty()) {
      std::string key = parsed.get<std::string>();
      if (!open_objects.back().insert(key).second && !out.duplicate) out.duplicate = std::move(key);
    }
    return true;
  };
  out.value = nlohmann::json::parse(text, note);
  return out;
}

/// The notification method name of stream telemetry.
inline constexpr std::string_view telemetry_method = "telemetry";

}  // namespace hapticd::rpc
