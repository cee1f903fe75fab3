#pragma once
/// \file
/// hapticd as a whole: builds the device and the first scene from the
/// config, runs the RT engine, the recorder and the control server, answers
/// the JSON-RPC methods (docs/protocol.md), and shuts down safely on SIGTERM.

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/config/config.hpp"
#include "daemon/control/server.hpp"
#include "daemon/device_factory.hpp"
#include "daemon/engine/engine.hpp"
#include "daemon/planner.hpp"
#include "daemon/recorder/recorder.hpp"
#include "rt/clock.hpp"

namespace hapticd::daemon {

struct ServiceOptions {
  config::DaemonConfig config;
  std::string record_name;  ///< start recording to this file name at launch (empty: no)
};

/// The scene in effect, as the control thread knows it.
struct CurrentScene {
  std::string name;
  world::ParameterSet requested;  ///< what clients asked for (e.g. damping = "auto")
  world::ParameterSet resolved;   ///< complete, as planned
  std::vector<world::ChannelDescription> channels;
  StabilityVerdict stability;
  bool forced = false;
  std::uint64_t effective_cycle = 0;
  std::vector<std::string> notes;
};

class Service {
 public:
  /// Builds the device and plans the configured scene. Throws
  /// config::ConfigError (file, line, key) on anything the config got wrong.
  explicit Service(ServiceOptions options);
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  /// Runs until SIGTERM/SIGINT or the configured duration; returns the exit code.
  /// Call from the main thread with SIGTERM, SIGINT and SIGHUP blocked.
  int run();

  /// One-paragraph description of what would run (hapticd --check-config).
  std::string describe() const;

 private:
  nlohmann::json apply(const PlannedScene& planned, const world::ParameterSet& requested);
  static CurrentScene scene_from(const PlannedScene& planned, const world::ParameterSet& requested);
  std::uint64_t publish(const PlannedScene& planned);  ///< returns the publication's sequence number
  void adopt(CurrentScene next);
  recorder::RecordingHeader header_for(const CurrentScene& scene) const;
  void register_methods(control::ControlServer& server);
  nlohmann::json status() const;
  nlohmann::json stats() const;
  nlohmann::json sample_json(const TelemetrySample& sample, const std::vector<std::string>& wanted) const;
  drivers::loopback::LoopbackDevice& loopback(const char* method) const;
  void shutdown();

  ServiceOptions options_;
  BuiltDevice device_;
  DeviceModel model_;
  PlannedScene initial_;
  world::ParameterSet initial_requested_;
  std::unique_ptr<rt::Clock> clock_;
  std::unique_ptr<engine::Engine> engine_;
  std::unique_ptr<recorder::Recorder> recorder_;
  std::unique_ptr<control::ControlServer> server_;
  const hapticd::daemon::system::RtSetupReport* rt_report_ = nullptr;

  mutable std::mutex scene_mutex_;
  CurrentScene scene_;
  std::vector<std::string> previous_channels_;  ///< names before scene_.effective_cycle

  mutable std::mutex latest_mutex_;
  std::optional<TelemetrySample> latest_;
};

}  // namespace hapticd::daemon
