#pragma once
/// \file
/// Small helpers the control-method files share (internal to daemon/).

#include <initializer_list>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rpc/jsonrpc.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::daemon::methods {

/// A member the method does not take is an error, not silently ignored.
inline void reject_unknown_keys(const char* method, const nlohmann::json& params,
                                std::initializer_list<const char*> accepted) {
  for (const auto& [key, value] : params.items()) {
    bool known = false;
    for (const char* a : accepted) known = known || key == a;
    if (known) continue;
    std::string list;
    for (const char* a : accepted) list += (list.empty() ? "" : ", ") + std::string(a);
    throw rpc::RpcError(rpc::code::invalid_params,
                        std::string(method) + ": unknown member '" + key + "'; accepted: " + list);
  }
}

/// The optional "force" member (load an unstable set on purpose).
inline bool get_force(const nlohmann::json& params) {
  if (!params.contains("force")) return false;
  if (!params["force"].is_boolean())
    throw rpc::RpcError(rpc::code::invalid_params, "force must be true or false");
  return params["force"].get<bool>();
}

inline std::vector<std::string> names_of(const std::vector<world::ChannelDescription>& channels) {
  std::vector<std::string> names;
  names.reserve(channels.size());
  for (const auto& c : channels) names.push_back(c.name);
  return names;
}

}  // namespace hapticd::daemon::methods
