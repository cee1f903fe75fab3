#include "daemon/service.hpp"

#include "daemon/methods/method_support.hpp"

namespace hapticd::daemon {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;
using control::Access;
using control::PeerInfo;

// The scene catalog, loading a scene and changing its parameters; scene.load
// and param.set share one plan-or-refuse path (Service::plan_and_apply).

void Service::register_scene_methods(control::ControlServer& server) {
  server.register_method(
      "scene.list",
      [this](const json&, const PeerInfo&) {
        json scenes = scene_catalog_json(model_.motion(), model_.info.axis_count());
        std::lock_guard lock(scene_mutex_);
        return json{{"scenes", scenes}, {"current", scene_.name}};
      },
      Access::read);

  server.register_method(
      "scene.load",
      {{"scene", rpc::ParamType::string},
       {"params", rpc::ParamType::object},
       {"force", rpc::ParamType::boolean}},
      [this](const json& params, const PeerInfo&) {
        if (!params.contains("scene") || !params["scene"].is_string()) {
          throw RpcError(code::invalid_params, "scene.load needs \"scene\": one of " + world::scene_names());
        }
        world::ParameterSet requested;
        try {
          requested = parameters_from_json(params.value("params", json::object()));
        } catch (const std::invalid_argument& e) {
          throw RpcError(code::invalid_params, e.what());
        }
        return plan_and_apply(params["scene"].get<std::string>(), requested, methods::get_force(params));
      },
      Access::write);

  server.register_method(
      "param.get", {{"names", rpc::ParamType::array}},
      [this](const json& params, const PeerInfo&) {
        const CurrentScene scene = current_scene();
        json all = to_json(scene.resolved, scene.name);
        json out = json::object();
        if (params.contains("names")) {
          if (!params["names"].is_array())
            throw RpcError(code::invalid_params, "names must be a list of strings");
          for (const auto& n : params["names"]) {
            if (!n.is_string() || !all.contains(n.get<std::string>())) {
              std::string accepted;
              for (const auto& [k, v] : all.items()) accepted += (accepted.empty() ? "" : ", ") + k;
              throw RpcError(code::invalid_params, "scene " + scene.name + " has no parameter " + n.dump() +
                                                       "; accepted: " + accepted);
            }
            out[n.get<std::string>()] = all[n.get<std::string>()];
          }
        } else {
          out = all;
        }
        json units = parameter_units(scene.name, model_.motion());
        json shown_units = json::object();
        for (const auto& [name, value] : out.items()) {
          if (units.contains(name)) shown_units[name] = units[name];
        }
        return json{{"scene", scene.name}, {"parameters", out}, {"units", shown_units}};
      },
      Access::read);

  server.register_method(
      "param.set", {{"params", rpc::ParamType::object}, {"force", rpc::ParamType::boolean}},
      [this](const json& params, const PeerInfo&) {
        world::ParameterSet changes;
        try {
          changes = parameters_from_json(params.value("params", json::object()));
        } catch (const std::invalid_argument& e) {
          throw RpcError(code::invalid_params, e.what());
        }
        if (changes.empty())
          throw RpcError(code::invalid_params, "param.set needs \"params\": {name: value, ...}");
        const CurrentScene scene = current_scene();
        world::ParameterSet requested = scene.requested;
        for (auto& [k, v] : changes) requested[k] = v;
        return plan_and_apply(scene.name, requested, methods::get_force(params));
      },
      Access::write);
}

}  // namespace hapticd::daemon
