#include "daemon/device_model.hpp"
#include "daemon/methods/method_support.hpp"
#include "daemon/service.hpp"

namespace hapticd::daemon {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;
using control::Access;
using control::PeerInfo;

// The device model the stability gate uses: read it whole (device.model), or
// replace it with an identified one (device.model.set, `hapticctl identify
// --apply`). Both run on the control thread, the only reader of model_.

json Service::replace_model(DeviceModel next) {
  const CurrentScene scene = current_scene();
  auto outcome = plan_on_device(scene.name, scene.requested, next, scene.forced);
  if (const auto* refusal = std::get_if<PlanRefusal>(&outcome)) {
    throw RpcError(code::refused,
                   "the loaded scene " + scene.name + " would not be stable on this model (" +
                       next.describe() + "): " + refusal->message +
                       "; load a stable scene first, then set the model",
                   refusal->data);
  }
  const auto& planned = std::get<PlannedScene>(outcome);
  model_ = std::move(next);
  {
    std::lock_guard lock(scene_mutex_);
    scene_.stability = planned.stability;
  }
  return json{{"model", to_json(model_)},
              {"scene", {{"name", scene.name}, {"stability", to_json(planned.stability)}}}};
}

void Service::refuse_model_of_one_axis_on_a_stage() const {
  // A model file or an identified model describes one axis; on a stage it
  // would replace every axis' mass and damping, and the scene registry's
  // view of the axes with them (README, "Limitations").
  const int axes = device_.device->axes();
  if (axes == 1) return;
  std::string names;
  for (const auto& name : model_.axis_names) names += (names.empty() ? "" : ", ") + name;
  throw RpcError(code::refused, "device.model.set describes one axis and this device has " +
                                    std::to_string(axes) + " (" + names +
                                    "): each axis' mass and damping come from [device." +
                                    options_.config.device.driver + "] in the config");
}

void Service::register_model_methods(control::ControlServer& server) {
  server.register_method(
      "device.model", [this](const json&, const PeerInfo&) { return to_json(model_); }, Access::read);

  server.register_method(
      "device.model.set", {{"model", rpc::ParamType::object}, {"file", rpc::ParamType::string}},
      [this](const json& params, const PeerInfo&) {
        refuse_model_of_one_axis_on_a_stage();
        if (!params.contains("model")) {
          throw RpcError(code::invalid_params,
                         "device.model.set needs \"model\": {plant, motion, period, ...} (docs/config.md, "
                         "\"Device model files\")");
        }
        const std::string file = params.value("file", std::string());
        const std::string source = file.empty() ? "identified" : "identified: " + file;
        DeviceModel next;
        try {
          const auto info = model_from_keys(keys_from_json(params["model"]), device_.device->model(),
                                            options_.config.loop.period_s, source, {});
          next = make_device_model(info, options_.config.loop.period_s);
        } catch (const std::invalid_argument& e) {
          throw RpcError(code::invalid_params, e.what());
        } catch (const config::ConfigError& e) {
          throw RpcError(code::invalid_params, e.what());
        }
        return replace_model(std::move(next));
      },
      Access::write);
}

}  // namespace hapticd::daemon
