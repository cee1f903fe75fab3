#include "daemon/control/dispatcher.hpp"

#include <stdexcept>

namespace hapticd::daemon::control {

using nlohmann::json;

namespace {
Dispatcher::Reply error_reply(const json& id, const RpcError& e) { return {rpc::make_error(id, e), true}; }
}  // namespace

std::string_view trim_request_line(std::string_view line) {
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
    line.remove_suffix(1);
  if (line.find_first_not_of(" \t") == std::string_view::npos) return {};
  return line;
}

void Dispatcher::add(const std::string& name, Handler handler, Access access) {
  if (!handler) throw std::logic_error("register_method('" + name + "') without a handler");
  if (!methods_.emplace(name, Method{std::move(handler), access}).second) {
    throw std::logic_error("method '" + name + "' registered twice");
  }
}

std::optional<Dispatcher::Reply> Dispatcher::handle(std::string_view line, const PeerInfo& peer,
                                                    const WriteAccess& access,
                                                    const BuiltIn& built_in) const {
  if (rpc::nests_deeper_than(line, rpc::max_nesting_depth)) {
    // Refused unparsed: a deeper tree could not be copied, dumped or
    // compared without unbounded recursion.
    const auto limit = std::to_string(rpc::max_nesting_depth);
    return error_reply(nullptr,
                       RpcError(rpc::code::invalid_request,
                                "the request nests arrays and objects more than " + limit +
                                    " levels deep (the request object is level 1); the limit is " + limit,
                                json{{"limit", rpc::max_nesting_depth}}));
  }
  json request;
  try {
    request = json::parse(line);
  } catch (const json::exception& e) {
    // parse_error, and also out_of_range for numbers like 1e999: both are
    // lines that are not JSON we can represent.
    return error_reply(nullptr, RpcError(rpc::code::parse_error, std::string("parse error: ") + e.what()));
  }
  if (request.is_array()) {
    return error_reply(nullptr, RpcError(rpc::code::invalid_request, "batch requests are not supported"));
  }
  if (!request.is_object()) {
    return error_reply(nullptr, RpcError(rpc::code::invalid_request, "a request must be a JSON object"));
  }
  const bool is_notification = !request.contains("id");
  json id = is_notification ? json(nullptr) : request["id"];
  if (!id.is_null() && !id.is_string() && !id.is_number()) {
    return error_reply(nullptr,
                       RpcError(rpc::code::invalid_request, "\"id\" must be a string, a number or null"));
  }
  if (id.is_number_float()) {
    // nlohmann::json holds a fraction, an exponent or an integer beyond 64
    // bits as a double: -9223372036854775809 would come back as
    // -9.223372036854776e+18, not the id the client sent.
    return error_reply(
        nullptr, RpcError(rpc::code::invalid_request,
                          "a numeric \"id\" is echoed exactly only as an integer from "
                          "-9223372036854775808 to 18446744073709551615; send a string for anything else"));
  }
  auto version = request.find("jsonrpc");
  if (version == request.end() || !version->is_string() || *version != rpc::version) {
    return error_reply(id, RpcError(rpc::code::invalid_request, "\"jsonrpc\" must be \"2.0\""));
  }
  auto method = request.find("method");
  if (method == request.end() || !method->is_string()) {
    return error_reply(id, RpcError(rpc::code::invalid_request, "\"method\" must be a string"));
  }
  json params = json::object();
  if (auto p = request.find("params"); p != request.end() && !p->is_null()) {
    if (!p->is_object()) {
      return error_reply(
          id, RpcError(rpc::code::invalid_params, "\"params\" must be an object (parameters by name)"));
    }
    params = std::move(*p);
  }

  json result;
  try {
    result = call(method->get<std::string>(), params, peer, access, built_in);
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
  if (it->second.access == Access::write && !peer.can_write) {
    throw access.refusal(name, peer);
  }
  return it->second.handler(params, peer);
}

}  // namespace hapticd::daemon::control
