// Fuzz target: the control protocol's parser and dispatcher. The input is
// what a client writes on the socket; it is cut into lines as the server
// does (daemon/control/connection) and each line goes through the real
// Dispatcher (envelope checks, ids, access, errors), with handlers that do
// what the daemon's scene methods do with params: parameters_from_json and
// the stability gate (plan_on_device) on the loopback wheel and the linear
// loopback, then the reply JSON. What must hold for every line: no crash,
// no exception out of handle(), and a reply that is one JSON-RPC 2.0
// object (result xor error, an integer code and a message) that survives
// rpc::to_line and parses back.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>

#include <nlohmann/json.hpp>

#include "daemon/config/config.hpp"
#include "daemon/control/dispatcher.hpp"
#include "daemon/device_factory.hpp"
#include "daemon/planner.hpp"
#include "rpc/jsonrpc.hpp"
#include "rpc/params.hpp"

namespace {

using nlohmann::json;
namespace control = hapticd::daemon::control;
namespace hd = hapticd::daemon;

struct Fixture {
  control::Dispatcher dispatcher;
  std::unique_ptr<control::WriteAccess> access;
  hd::DeviceModel rotary;
  hd::DeviceModel linear;

  static hd::DeviceModel model_of(const std::string& device_toml) {
    auto config = hd::config::parse_config(device_toml, "fuzz.toml");
    auto built = hd::build_device(config);
    built.device->configure(hapticd::drivers::LoopContext{config.loop.period_s});
    return hd::make_device_model(*built.device, config.loop.period_s);
  }

  Fixture()
      : access(std::make_unique<control::WriteAccess>("")),
        rotary(model_of("[device]\ndriver = \"loopback\"\n")),
        linear(model_of(
            "[device]\ndriver = \"loopback\"\n[device.loopback]\nmotion = \"linear\"\nmass = 0.1\n")) {
    auto plan = [this](const json& params, bool linear_device) {
      if (!params.contains("scene") || !params["scene"].is_string())
        throw control::RpcError(hapticd::rpc::code::invalid_params, "needs \"scene\"");
      hapticd::world::ParameterSet requested;
      try {
        requested = hd::parameters_from_json(params.value("params", json::object()));
      } catch (const std::invalid_argument& e) {
        throw control::RpcError(hapticd::rpc::code::invalid_params, e.what());
      }
      const bool force = params.value("force", false);
      const auto& model = linear_device ? linear : rotary;
      auto outcome = hd::plan_on_device(params["scene"].get<std::string>(), requested, model, force);
      if (auto* refusal = std::get_if<hd::PlanRefusal>(&outcome)) {
        throw control::RpcError(
            refusal->invalid ? hapticd::rpc::code::invalid_params : hapticd::rpc::code::refused,
            hd::refusal_text(*refusal, hd::force_over_rpc), refusal->data);
      }
      const auto& planned = std::get<hd::PlannedScene>(outcome);
      return json{{"scene", planned.plan.scene},
                  {"parameters", hd::to_json(planned.plan.parameters, planned.plan.scene)},
                  {"units", hd::parameter_units(planned.plan.scene, model.motion())},
                  {"stability", hd::to_json(planned.stability)},
                  {"forced", planned.forced}};
    };
    // The daemon's scene.load members, checked before the handler as there.
    const hapticd::rpc::ParamMembers scene_members{{"scene", hapticd::rpc::ParamType::string},
                                                   {"params", hapticd::rpc::ParamType::object},
                                                   {"force", hapticd::rpc::ParamType::boolean}};
    dispatcher.add(
        "scene.load", [plan](const json& p, const control::PeerInfo&) { return plan(p, false); },
        control::Access::write, scene_members);
    dispatcher.add(
        "wall.load", [plan](const json& p, const control::PeerInfo&) { return plan(p, true); },
        control::Access::write, scene_members);
    dispatcher.add("echo", [](const json& p, const control::PeerInfo&) { return p; }, control::Access::read,
                   {{"a", hapticd::rpc::ParamType::any}, {"names", hapticd::rpc::ParamType::any}});
    dispatcher.add("typed",
                   [](const json& p, const control::PeerInfo&) { return json(p.at("x").get<double>() * 2); },
                   control::Access::read, {{"x", hapticd::rpc::ParamType::any}});
    // Like the loopback's fault.inject: typed members, an integer range.
    dispatcher.add("fault.inject",
                   [](const json& p, const control::PeerInfo&) {
                     return json(hapticd::rpc::integer_in("fault.inject", p, "amount", -1, 1000, "periods"));
                   },
                   control::Access::write,
                   {{"kind", hapticd::rpc::ParamType::string}, {"amount", hapticd::rpc::ParamType::integer}});
    // Like estop: acts whatever its params, the refusal after.
    dispatcher.add(
        "estop",
        [](const json&, const control::PeerInfo&) {
          return json{{"fault", "estop"}};
        },
        control::Access::read, {}, true);
  }
};

void check_reply(const json& message) {
  const std::string line = hapticd::rpc::to_line(message);  // must not throw
  if (line.empty() || line.back() != '\n' || line.find('\n') != line.size() - 1) __builtin_trap();
  const json back = json::parse(line);  // what the client reads must parse
  if (!back.is_object() || back.value("jsonrpc", "") != "2.0" || !back.contains("id")) __builtin_trap();
  if (back.contains("result") == back.contains("error")) __builtin_trap();
  if (back.contains("error")) {
    const json& e = back["error"];
    if (!e.is_object() || !e.contains("code") || !e["code"].is_number_integer() || !e.contains("message") ||
        !e["message"].is_string())
      __builtin_trap();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Fixture fixture;
  static const control::Dispatcher::BuiltIn built_in = [](const std::string& method,
                                                          const json& params) -> std::optional<json> {
    if (method != "stream") return std::nullopt;
    // The server's own stream method reads these members.
    const auto rate = params.find("rate_hz");
    if (rate == params.end() || !rate->is_number())
      throw control::RpcError(hapticd::rpc::code::invalid_params, "rate_hz");
    return json{{"rate_hz", rate->get<double>()}};
  };
  std::string_view text(reinterpret_cast<const char*>(data), size);
  // Alternate the caller's access with the input, so both paths are fuzzed.
  control::PeerInfo peer;
  peer.can_write = size % 2 == 0;
  while (!text.empty()) {
    const auto nl = text.find('\n');
    const std::string_view raw = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
    const std::string_view line = control::trim_request_line(raw);
    if (line.empty()) continue;
    const auto reply = fixture.dispatcher.handle(line, peer, *fixture.access, built_in);
    if (reply) check_reply(reply->message);
  }
  return 0;
}
