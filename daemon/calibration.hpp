#pragma once
/// \file
/// What the daemon knows of the device's calibration (docs/config.md,
/// "Calibration"), off the RT path: how the origin the engine subtracts
/// came to be (device.zero at a cycle, the device's own homing, restored from
/// the state directory, or none), the stored origin found at start-up and
/// why one was refused, and the words and JSON status gives of it. The
/// origin itself is the engine's (daemon/engine/origin.hpp).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "daemon/config/config.hpp"
#include "daemon/config/origin_file.hpp"
#include "drivers/device_hooks.hpp"

namespace hapticd::daemon {

enum class CalibrationKind { none, zeroed, homed, restored };
std::string_view to_string(CalibrationKind kind) noexcept;  ///< "none", "zeroed", "homed", "restored"

struct Calibration {
  CalibrationKind kind = CalibrationKind::none;
  double origin = 0.0;      ///< m or rad, in the device's frame
  std::uint64_t cycle = 0;  ///< zeroed: the cycle it took effect in; restored: the one stored
  std::string set_at;       ///< UTC, when it was set (restored: when it was first set)
  std::optional<drivers::DeviceHoming> homing;  ///< homed: what the device did
  /// restored: the file, and how the stored origin was set ("zero", "homing")
  std::string file;
  std::string stored_set_by;
  int stored_homing_method = 0;
  /// Why a stored origin was not restored, or the last write of the file
  /// that failed ("" when neither).
  std::string note;
};

/// What start-up found in the state directory ([device] origin = "persist").
struct StoredOrigin {
  std::filesystem::path file;
  std::optional<config::OriginRecord> record;  ///< one that applies to this device
  std::string refused;                         ///< why the file there was not taken ("" if none)
};

/// Reads and checks the stored origin against this device's identity;
/// never throws (a bad or stale file is said in `refused`).
StoredOrigin find_stored_origin(const std::filesystem::path& file, const config::OriginIdentity& device);

/// The calibration the loop starts with: the device's homing if it ran one
/// (origin 0), else a stored origin that applies, else none.
Calibration initial_calibration(const std::optional<drivers::DeviceHoming>& homing,
                                const StoredOrigin& stored);

/// The record written to the state directory for `calibration`.
config::OriginRecord record_of(const Calibration& calibration, const config::OriginIdentity& identity);

/// One line: "zeroed at cycle 1234 (origin 0.785398 rad)", "homed with CiA 402
/// method 37 ...", "restored from FILE (...)", "not calibrated".
std::string summary(const Calibration& calibration, bool rotary, config::EncoderKind encoder);

/// status.calibration (docs/protocol.md).
nlohmann::json to_json(const Calibration& calibration, const config::DeviceConfig& device, bool rotary,
                       bool output_held);

}  // namespace hapticd::daemon
