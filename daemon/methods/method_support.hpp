#pragma once
/// \file
/// Small helpers the control-method files share (internal to daemon/).

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rpc/jsonrpc.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::daemon::methods {

// Each method declares its params members with register_method(); the
// Dispatcher refuses any other member, and a wrong type, before the handler
// runs (rpc/params.hpp), so handlers read declared members as their type.

/// The optional "force" member (load an unstable set on purpose; declared boolean).
inline bool get_force(const nlohmann::json& params) { return params.value("force", false); }

inline std::vector<std::string> names_of(const std::vector<world::ChannelDescription>& channels) {
  std::vector<std::string> names;
  names.reserve(channels.size());
  for (const auto& c : channels) names.push_back(c.name);
  return names;
}

}  // namespace hapticd::daemon::methods
