#pragma once
/// \file
/// hapticd as a whole: builds and configures the device and plans the first
/// scene from the config, runs the RT engine, the recorder and the control
/// server, answers the JSON-RPC methods (docs/protocol.md; one file per area
/// in daemon/methods/, plus the methods the driver adds), and shuts down
/// safely on SIGTERM: engine stop, device disable and close, recording flush.

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/calibration.hpp"
#include "daemon/config/config.hpp"
#include "daemon/control/server.hpp"
#include "daemon/device_factory.hpp"
#include "daemon/engine/engine.hpp"
#include "daemon/planner.hpp"
#include "daemon/recorder/recorder.hpp"
#include "daemon/task_overlay.hpp"
#include "daemon/telemetry/udp_telemetry.hpp"
#include "rt/clock.hpp"

namespace hapticd::daemon {

struct ServiceOptions {
  config::DaemonConfig config;
  std::string record_name;  ///< start recording to this file name at launch (empty: no)
  /// The daemon's stop (SIGTERM, SIGINT), set by its signal thread; it ends
  /// configure, enable, a fault clear and run(). nullptr: never stops but by
  /// the configured duration.
  const drivers::StopRequest* stop = nullptr;
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
  /// Builds and configures the device (the bus is open from here on) and
  /// plans the configured scene. Throws config::ConfigError (file, line, key)
  /// on anything the config got wrong, drivers::DeviceError when the device
  /// cannot be configured, drivers::StopRequested when the stop came during
  /// configure (the device closed).
  explicit Service(ServiceOptions options);
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  /// Runs until the stop request or the configured duration; returns the exit code.
  int run();

  /// One-paragraph description of what would run (hapticd --check-config).
  std::string describe() const;

 private:
  // run(), step by step.
  void start_engine();
  void start_recorder();
  /// False if the loop could not start (the reason is printed).
  bool start_loop(std::uint64_t initial_seq, CurrentScene first);
  bool start_control();
  // [telemetry] (daemon/methods/telemetry_methods.cpp).
  void check_telemetry_config() const;  ///< throws config::ConfigError
  bool start_telemetry();               ///< false if it cannot start (the reason is printed)
  void stop_telemetry();
  int supervise();
  void shutdown();

  /// The one path from a requested scene to the loop: plan on this device,
  /// refuse (with the limit) or publish and wait until it is in effect.
  nlohmann::json plan_and_apply(const std::string& scene, const world::ParameterSet& requested, bool force);
  nlohmann::json apply(const PlannedScene& planned, const world::ParameterSet& requested);
  /// The scene's channels, after each axis' on a device with several.
  CurrentScene scene_from(const PlannedScene& planned, const world::ParameterSet& requested) const;
  /// A device with several axes: its model describes each, and the axes are
  /// named (model_.axis_names); throws ConfigError or DeviceError otherwise.
  void resolve_axes();
  std::uint64_t publish(const PlannedScene& planned);  ///< returns the publication's sequence number
  void adopt(CurrentScene next);
  CurrentScene current_scene() const;
  recorder::RecordingHeader header_for(const CurrentScene& scene) const;
  std::string device_label() const;

  // The control methods, one area per file in daemon/methods/.
  void register_methods(control::ControlServer& server);
  void register_status_methods(control::ControlServer& server);
  void register_scene_methods(control::ControlServer& server);
  void register_record_methods(control::ControlServer& server);
  void register_fault_methods(control::ControlServer& server);
  void register_device_methods(control::ControlServer& server);
  void register_model_methods(control::ControlServer& server);
  void register_telemetry_methods(control::ControlServer& server);
  void register_calibration_methods(control::ControlServer& server);
  // Calibration (daemon/methods/calibration_methods.cpp).
  /// After enable(), before the loop: homed, restored or none; the engine's
  /// origin preset to it, a homing persisted.
  void start_calibration();
  /// device.zero: the position read in the next cycle becomes the origin.
  nlohmann::json zero_device();
  /// Writes the origin to the state directory when [device] origin =
  /// "persist"; the path, or "" (not kept, or the write failed: said in the
  /// calibration's note).
  std::string persist_origin(Calibration& calibration);
  /// Takes a zero the loop carried out after device.zero stopped waiting.
  void settle_zero() const;
  Calibration calibration() const;
  bool output_held_uncalibrated() const;
  nlohmann::json calibration_json() const;
  nlohmann::json telemetry_json() const;
  nlohmann::json telemetry_counters_json() const;
  /// Makes `next` the gate's device model if the loaded scene stays stable
  /// on it (else refused, naming the scene and its limit); the scene's verdict
  /// is redone on it. Control thread only (model_ is read there).
  nlohmann::json replace_model(DeviceModel next);
  /// device.model.set on a device with several axes: refused, naming them (a model describes one axis).
  void refuse_model_of_one_axis_on_a_stage() const;
  nlohmann::json status() const;
  nlohmann::json fault_detail() const;
  nlohmann::json stats() const;
  nlohmann::json sample_json(const TelemetrySample& sample, const std::vector<std::string>& wanted) const;

  ServiceOptions options_;
  drivers::StopRequest never_;  ///< options_.stop when none was given
  const drivers::StopRequest& stop_;
  BuiltDevice device_;
  DeviceModel model_;
  /// Position plausibility for the engine: [device] max_velocity, or its
  /// default from the device model at start (a model replaced later keeps it).
  engine::PositionStepRule position_rule_;
  PlannedScene initial_;
  world::ParameterSet initial_requested_;
  TaskOverlay overlay_;  ///< [gravity] and [workspace] on several axes (none on one)
  std::unique_ptr<rt::Clock> clock_;
  std::unique_ptr<engine::Engine> engine_;
  std::unique_ptr<telemetry::UdpTelemetry> telemetry_;  ///< outlives recorder_, which feeds it
  std::unique_ptr<recorder::Recorder> recorder_;
  std::unique_ptr<control::ControlServer> server_;
  const hapticd::daemon::system::RtSetupReport* rt_report_ = nullptr;

  mutable std::mutex scene_mutex_;
  CurrentScene scene_;
  std::vector<std::string> previous_channels_;  ///< names before scene_.effective_cycle

  // Calibration: who the device is for a stored origin, what start-up found
  // there, and how the origin in force came to be (control thread; status
  // reads it under the mutex).
  config::OriginIdentity origin_identity_;
  StoredOrigin stored_origin_;
  mutable std::mutex calibration_mutex_;
  mutable Calibration calibration_;
  mutable bool zero_unsettled_ = false;  ///< device.zero gave up waiting for the loop

  mutable std::mutex latest_mutex_;
  std::optional<TelemetrySample> latest_;
};

}  // namespace hapticd::daemon
