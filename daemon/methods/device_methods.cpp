#include "daemon/service.hpp"

#include "drivers/registry.hpp"

namespace hapticd::daemon {

using control::Access;
using control::PeerInfo;
using nlohmann::json;

// The device: what it is (device.describe) and the methods its driver adds
// (the loopback's hand.set and fault.inject, a CANopen SDO read ...). The
// daemon has no special case for any driver.

void Service::register_device_methods(control::ControlServer& server) {
  server.register_method(
      "device.describe",
      [this](const json&, const PeerInfo&) {
        const auto* driver = drivers::find_driver(options_.config.device.driver);
        const auto status = device_.device->status();
        json counters = json::object();
        for (const auto& c : status.counters) counters[c.name] = c.value;
        return json{{"driver", driver != nullptr ? drivers::to_json(*driver) : json(nullptr)},
                    {"values", device_.parameters},
                    {"state", std::string(drivers::to_string(status.state))},
                    {"fault_reason", status.fault_reason},
                    {"model",
                     {{"description", model_.info.description},
                      {"source", model_.info.source},
                      {"summary", model_.describe()}}},
                    {"counters", counters}};
      },
      Access::read);

  for (auto& method : device_.device->methods()) {
    auto handler = method.handler;
    server.register_method(
        method.name, method.members,
        [this, handler](const json& params, const PeerInfo&) {
          json reply = handler(params);
          if (reply.is_object()) reply["cycle"] = engine_->cycle();  // when it took effect
          return reply;
        },
        method.needs_write ? Access::write : Access::read);
  }
}

}  // namespace hapticd::daemon
