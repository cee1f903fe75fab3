#pragma once
/// \file
/// What `hapticctl tune relay` and `hapticctl identify` share: one
/// connection to the running hapticd, the scene that was loaded (restored on
/// every way out, Ctrl-C included), the recording of the run, and the
/// device model in force. Experiment scenes stop by themselves (their
/// `duration`), so a client that dies leaves the device at zero output.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/verbs.hpp"
#include "client/client.hpp"
#include "world/plant.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::cli {

/// Ctrl-C (or SIGTERM) during an experiment: the session restores what it changed.
struct Interrupted : std::runtime_error {
  Interrupted() : std::runtime_error("stopped by Ctrl-C") {}
};

/// The device model the daemon's stability gate uses (device.model).
struct DaemonModel {
  world::LinearPlant plant;
  world::Sensor sensor = world::Sensor::motor;
  world::Motion motion = world::Motion::linear;
  double period_s = 1e-3;
  int delay_periods = 0;
  double resolution = 0.0;
  double effective_mass = 0.0;
  bool two_mass = false;  ///< the plant has the cable mode (4 states)
  std::string source;     ///< "config", "identified: <file>", ...
  std::string summary;
  nlohmann::json json;
};

/// One recorded sample (cycle, measured position, force sent).
struct RecordedSample {
  std::uint64_t cycle = 0;
  double position = 0.0;
  double force = 0.0;
};

/// The rows of a hapticd recording (docs/config.md, "Recordings") with
/// first <= cycle < last, in order; every section's column line is read, so
/// scene changes inside the file do not matter. Throws std::runtime_error
/// naming the file when it cannot be read or has no such columns.
std::vector<RecordedSample> read_recorded(const std::filesystem::path& file, std::uint64_t first,
                                          std::uint64_t last);

class ExperimentSession {
 public:
  /// Connects, reads status and the model, installs the Ctrl-C handler.
  /// Exits through hapticctl::Exit (unreachable, refused) as the verbs do.
  explicit ExperimentSession(const hapticctl::CommonOptions& options);
  /// Restores the scene (and stops the recording) if finish() did not.
  ~ExperimentSession();
  ExperimentSession(const ExperimentSession&) = delete;
  ExperimentSession& operator=(const ExperimentSession&) = delete;

  nlohmann::json call(const std::string& method, const nlohmann::json& params = nlohmann::json::object());
  nlohmann::json status() { return call("status"); }

  const DaemonModel& model() const noexcept { return model_; }
  double period_s() const noexcept { return model_.period_s; }
  double torque_limit() const noexcept { return torque_limit_; }
  const std::string& scene_before() const noexcept { return scene_name_; }
  /// Scripts the simulated hand (the loopback's hand.set) and returns its
  /// script, or nothing when the driver has no such method (a real device:
  /// the user holds it). The hand is set free again at restore().
  std::optional<std::string> set_hand(const nlohmann::json& script);
  /// The driver's settings in force (device.describe "values").
  const nlohmann::json& driver_values() const noexcept { return driver_values_; }
  const std::string& driver() const noexcept { return driver_; }

  /// The measured position now (status.last.position).
  double position();
  /// Loads a scene (it starts at equilibrium at the measured position);
  /// returns the cycle it took effect in.
  std::uint64_t load(const std::string& scene, const nlohmann::json& parameters);
  /// Starts the session's recording (once); returns its absolute path.
  std::filesystem::path start_recording(const std::string& name);
  /// Stops it; returns the absolute path of the file.
  std::filesystem::path stop_recording();
  /// Waits until the loop has passed `cycle` (polling status); throws
  /// Interrupted on Ctrl-C, runtime_error when the loop stops advancing.
  void wait_for_cycle(std::uint64_t cycle);
  /// Reloads the scene that was loaded at the start (with force if it had
  /// been forced), after stopping the recording; idempotent, and nothing
  /// when the session changed nothing (refused flags). Returns what it did.
  std::string restore();
  static bool interrupted() noexcept;

 private:
  hapticctl::CommonOptions options_;
  std::optional<client::Client> client_;
  DaemonModel model_;
  double torque_limit_ = 0.0;
  std::string scene_name_;
  nlohmann::json scene_parameters_;
  bool scene_forced_ = false;
  bool hand_set_ = false;
  nlohmann::json driver_values_;
  std::string driver_;
  bool recording_ = false;
  bool restored_ = false;
  bool changed_ = false;  ///< a scene, recording or hand was set: restore() has work
};

/// "N/m" or "N m/rad" etc. for the session's motion.
struct MotionUnits {
  std::string position, force, stiffness;
};
MotionUnits units_of(world::Motion motion);

}  // namespace hapticd::cli
