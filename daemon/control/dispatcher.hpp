#pragma once
/// \file
/// From one request line to its reply: parse, check the JSON-RPC envelope,
/// check the caller's access, call the method and map what it throws to an
/// error object (docs/protocol.md, "Messages" and "Error codes").

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/control/peer_credentials.hpp"
#include "daemon/control/server.hpp"
#include "rpc/params.hpp"

namespace hapticd::daemon::control {

/// The line without trailing '\r', spaces and tabs; "" when it is blank.
std::string_view trim_request_line(std::string_view line);

class Dispatcher {
 public:
  /// Adds a method taking `members`: rpc::check_params runs before the
  /// handler, or, for a method that `acts_whatever_params` (estop: a stop is
  /// never refused for its form), after it, the refusal then saying it took
  /// effect. Throws std::logic_error on a duplicate name or a null handler.
  void add(const std::string& name, Handler handler, Access access, rpc::ParamMembers members = {},
           bool acts_whatever_params = false);

  /// Methods the server answers itself (stream, stream.stop): the result, or
  /// nullopt when `method` is not one of them. May throw like a Handler.
  using BuiltIn =
      std::function<std::optional<nlohmann::json>(const std::string& method, const nlohmann::json& params)>;

  struct Reply {
    nlohmann::json message;  ///< a result or an error object, with the request's id
    bool is_error = false;
  };
  /// Handles one non-blank request line from `peer`. Returns the reply to
  /// send; none for a notification (a request without id) that passed the
  /// envelope checks.
  std::optional<Reply> handle(std::string_view line, const PeerInfo& peer, const WriteAccess& access,
                              const BuiltIn& built_in) const;

  /// The registered methods' names, sorted (not the built-in ones).
  std::vector<std::string> names() const;

 private:
  struct Method {
    Handler handler;
    Access access;
    rpc::ParamMembers members;
    bool acts_whatever_params = false;
  };
  nlohmann::json call(const std::string& name, const nlohmann::json& params, const PeerInfo& peer,
                      const WriteAccess& access, const BuiltIn& built_in) const;

  std::map<std::string, Method, std::less<>> methods_;
};

}  // namespace hapticd::daemon::control
