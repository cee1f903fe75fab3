#include "daemon/control/dispatcher.hpp"

#include <array>
#include <stdexcept>

namespace hapticd::daemon::control {

using nlohmann::json;

namespace {
Dispatcher::Reply error_reply(const json& id, const RpcError& e) { return {rpc::make_error(id, e), true}; }

/// The members of a JSON-RPC 2.0 request; any other is refused, as a
/// misspelt "params" would otherwise run the method with none.
constexpr std::array<std::string_view, 4> envelope_members{"jsonrpc", "id", "method", "params"};

/// The line as a request object, or the error to answer (with "id": null:
/// nothing in the line can be trusted to be its id).
std::optional<RpcError> parse_request(std::string_view line, json& request) {
  if (rpc::nests_deeper_than(line, rpc::max_nesting_depth)) {
    // Refused unparsed: a deeper tree could not be copied, dumped or
    // compared without unbounded recursion.
    const auto limit = std::to_string(rpc::max_nesting_depth);
    return RpcError(rpc::code::invalid_request,
                    "the request nests arrays and objects more than " + limit +
                        " levels deep (the request object is level 1); the limit is " + limit,
                    json{{"limit", rpc::max_nesting_depth}});
  }
  rpc::ParsedMessage parsed;
  try {
    parsed = rpc::parse_message(line);
  } catch (const json::exception& e) {
    // parse_error, and also out_of_range for numbers like 1e999: both are
    // lines that are not JSON we can represent.
    return RpcError(rpc::code::parse_error, std::string("parse error: ") + e.what());
  }
  if (parsed.duplicate) {
    const std::string name = rpc::quoted_name(*parsed.duplicate);
    return RpcError(rpc::code::invalid_request,
                    "member " + name +
                        " appears twice in one object; a request names each member once (it is refused, not "
                        "read as its last one)",
                    json{{"member", *parsed.duplicate}});
  }
  if (parsed.value.is_array())
    return RpcError(rpc::code::invalid_request, "batch requests are not supported");
  if (!parsed.value.is_object())
    return RpcError(rpc::code::invalid_request, "a request must be a JSON object");
  request = std::move(parsed.value);
  return std::nullopt;
}

std::optional<RpcError> id_error(const json& id) {
  if (!id.is_null() && !id.is_string() && !id.is_number())
    return RpcError(rpc::code::invalid_request, "\"id\" must be a string, a number or null");
  if (id.is_number_float()) {
    // nlohmann::json holds a fraction, an exponent or an integer beyond 64
    // bits as a double: -9223372036854775809 would come back as
    // -9.223372036854776e+18, not the id the client sent.
    return RpcError(rpc::code::invalid_request,
                    "a numeric \"id\" is echoed exactly only as an integer from "
                    "-9223372036854775808 to 18446744073709551615; send a string for anything else");
  }
  return std::nullopt;
}

/// The envelope's members other than id: names, "jsonrpc", "method", "params".
std::optional<RpcError> envelope_error(const json& request) {
  for (const auto& [key, value] : request.items()) {
    bool known = false;
    for (const auto name : envelope_members) known = known || key == name;
    if (!known) {
      return RpcError(rpc::code::invalid_request,
                      "unknown request member " + rpc::quoted_name(key) +
                          "; a request has jsonrpc, id, method and params",
                      json{{"member", key}});
    }
  }
  auto version = request.find("jsonrpc");
  if (version == request.end() || !version->is_string() || *version != rpc::version)
    return RpcError(rpc::code::invalid_request, "\"jsonrpc\" must be \"2.0\"");
  auto method = request.find("method");
  if (method == request.end() || !method->is_string())
    return RpcError(rpc::code::invalid_request, "\"method\" must be a string");
  if (auto p = request.find("params"); p != request.end() && !p->is_null() && !p->is_object())
    return RpcError(rpc::code::invalid_params, "\"params\" must be an object (parameters by name)");
  return std::nullopt;
}
}  // namespace

std::string_view trim_request_line(std::string_view line) {
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
    line.remove_suffix(1);
  if (line.find_first_not_of(" \t") == std::string_view::npos) return {};
  return line;
}

void Dispatcher::add(const std::string& name, Handler handler, Access access, rpc::ParamMembers members,
                     bool acts_whatever_params) {
  if (!handler) throw std::logic_error("register_method('" + name + "') without a handler");
  if (!methods_.emplace(name, Method{std::move(handler), access, std::move(members), acts_whatever_params})
           .second) {
    throw std::logic_error("method '" + name + "' registered twice");
  }
}

std::vector<std::string> Dispatcher::names() const {
  std::vector<std::string> out;
  for (const auto& [name, method] : methods_) out.push_back(name);
  return out;
}

std::optional<Dispatcher::Reply> Dispatcher::handle(std::string_view line, const PeerInfo& peer,
                                                    const WriteAccess& access,
                                                    const BuiltIn& built_in) const {
  json request;
  if (auto refused = parse_request(line, request)) return error_reply(nullptr, *refused);
  const bool is_notification = !request.contains("id");
  json id = is_notification ? json(nullptr) : request["id"];
  if (auto refused = id_error(id)) return error_reply(nullptr, *refused);
  if (auto refused = envelope_error(request)) return error_reply(id, *refused);
  json params = json::object();
  if (auto p = request.find("params"); p != request.end() && !p->is_null()) params = std::move(*p);

  json result;
  try {
    result = call(request["method"].get<std::string>(), params, peer, access, built_in);
  } catch (const RpcError& e) {
    if (is_notification) return std::nullopt;
    return error_reply(id, e);
  } catch (const json::exception& e) {
    if (is_notification) return std::nullopt;
    return error_reply(id, RpcError(rpc::code::invalid_params, std::string("invalid params: ") + e.what()));
  } catch (const std::exception& e) {
    if (is_notification) return std::nullopt;
    return error_reply(id, RpcError(rpc::code::internal_error, e.what()));
  }
  if (is_notification) return std::nullopt;
  return Reply{rpc::make_result(id, std::move(result)), false};
}

json Dispatcher::call(const std::string& name, const json& params, const PeerInfo& peer,
                      const WriteAccess& access, const BuiltIn& built_in) const {
  if (built_in) {
    if (auto result = built_in(name, params)) return std::move(*result);
  }
  auto it = methods_.find(name);
  if (it == methods_.end()) {
    throw RpcError(rpc::code::method_not_found, "method '" + name + "' not found", json{{"method", name}});
  }
  const Method& method = it->second;
  if (method.access == Access::write && !peer.can_write) {
    throw access.refusal(name, peer);
  }
  if (!method.acts_whatever_params) {
    rpc::check_params(name, params, method.members);
    return method.handler(params, peer);
  }
  json result = method.handler(params, peer);
  try {
    rpc::check_params(name, params, method.members);
  } catch (const RpcError& e) {
    json data = e.data().is_object() ? e.data() : json::object();
    data["result"] = result;
    throw RpcError(e.code(), name + " took effect (it acts whatever its params); but " + e.what(), data);
  }
  return result;
}

}  // namespace hapticd::daemon::control
