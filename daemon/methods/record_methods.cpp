#include "daemon/service.hpp"

#include <filesystem>

#include "daemon/methods/method_support.hpp"

namespace hapticd::daemon {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;
using control::Access;
using control::PeerInfo;

namespace {

/// The recording's path for a client on this host: the recorder's own is
/// relative to the daemon's working directory when [recorder] directory is.
std::string full_path(const std::filesystem::path& path) {
  std::error_code ec;
  const auto full = std::filesystem::absolute(path, ec);
  return ec ? path.string() : full.lexically_normal().string();
}

}  // namespace

void Service::register_record_methods(control::ControlServer& server) {
  server.register_method(
      "record.start", {{"path", rpc::ParamType::string}},
      [this](const json& params, const PeerInfo&) {
        const std::string name = params.value("path", std::string());
        const CurrentScene scene = current_scene();
        try {
          const auto path = recorder_->start(name, header_for(scene));
          return json{{"path", path.string()}, {"file", full_path(path)}, {"cycle", engine_->cycle()}};
        } catch (const recorder::RecorderError& e) {
          throw RpcError(code::refused, e.what());
        }
      },
      Access::write);

  server.register_method(
      "record.stop",
      [this](const json&, const PeerInfo&) {
        recorder::RecorderStatus status;
        try {
          status = recorder_->stop();
        } catch (const recorder::RecorderError& e) {
          throw RpcError(code::refused, e.what());
        }
        return json{{"path", status.path.string()},
                    {"file", full_path(status.path)},
                    {"cycle", engine_->cycle()},
                    {"samples", status.samples_written},
                    {"samples_received", status.samples_received},
                    {"sections", status.sections},
                    {"dropped_ring", status.dropped_ring},
                    {"dropped_write", status.dropped_write},
                    {"cycle_gaps", status.cycle_gaps},
                    {"disk_full", status.disk_full},
                    {"resumed", status.resumed},
                    {"complete", status.complete},
                    {"error", status.error}};
      },
      Access::write);
}

}  // namespace hapticd::daemon
