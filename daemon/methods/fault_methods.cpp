#include "daemon/service.hpp"

#include "daemon/methods/method_support.hpp"

namespace hapticd::daemon {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;
using control::Access;
using control::PeerInfo;

// Faults: clear (the daemon's latch and the device's own fault) and estop.

void Service::register_fault_methods(control::ControlServer& server) {
  server.register_method(
      "fault.clear",
      [this](const json&, const PeerInfo&) {
        // The device first, while the engine's latch still holds the output
        // at zero; then the latch, and the scene restarts at equilibrium.
        std::string device_cleared;
        try {
          device_cleared = device_.device->clear_fault();
        } catch (const drivers::DeviceError& e) {
          throw RpcError(code::refused, std::string("the device is still in fault: ") + e.what());
        } catch (const drivers::StopRequested& e) {
          throw RpcError(code::busy, e.what());  // SIGTERM: the daemon exits, the device is disabled
        }
        const engine::FaultReason before = engine_->fault();
        engine_->clear_fault();
        return json{
            {"cleared", before == engine::FaultReason::none ? json(nullptr)
                                                            : json(std::string(engine::to_string(before)))},
            {"device", device_cleared.empty() ? json(nullptr) : json(device_cleared)},
            {"cycle", engine_->cycle()}};
      },
      Access::write);

  server.register_method(
      "estop",
      [this](const json&, const PeerInfo&) {
        engine_->estop();
        return json{{"fault", std::string(engine::to_string(engine_->fault()))}, {"cycle", engine_->cycle()}};
      },
      // Read access by design (docs/protocol.md): anyone who can connect may
      // stop the device; only writers can clear it (fault.clear). Served
      // before other clients' queued requests, whatever their load, and to
      // a connection over max_clients; it stops whatever its params (a
      // member it does not take is refused after it took effect).
      Access::read, control::Precedence::first);
}

}  // namespace hapticd::daemon
