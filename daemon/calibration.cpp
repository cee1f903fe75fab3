#include "daemon/calibration.hpp"

#include <cstdio>

namespace hapticd::daemon {

using nlohmann::json;

namespace {

std::string figure(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

std::string restored_words(const Calibration& c, bool rotary, config::EncoderKind encoder) {
  const std::string how = c.stored_set_by == "homing"
                              ? "homed with method " + std::to_string(c.stored_homing_method)
                              : "zeroed at cycle " + std::to_string(c.cycle);
  std::string text = "restored from " + c.file + " (" + how + " at " + c.set_at + ", origin " +
                     figure(c.origin) + (rotary ? " rad" : " m") + ")";
  if (encoder == config::EncoderKind::incremental)
    text += "; incremental encoder: valid only if the device kept power and counting since";
  return text;
}

}  // namespace

std::string_view to_string(CalibrationKind kind) noexcept {
  switch (kind) {
    case CalibrationKind::none:
      return "none";
    case CalibrationKind::zeroed:
      return "zeroed";
    case CalibrationKind::homed:
      return "homed";
    case CalibrationKind::restored:
      return "restored";
  }
  return "none";
}

StoredOrigin find_stored_origin(const std::filesystem::path& file, const config::OriginIdentity& device) {
  StoredOrigin stored;
  stored.file = file;
  try {
    stored.record = config::load_origin_file(file);
  } catch (const config::OriginFileError& e) {
    stored.refused = std::string("not restored: ") + e.what();
    return stored;
  }
  if (!stored.record) return stored;
  if (const std::string why = config::identity_mismatch(stored.record->identity, device); !why.empty()) {
    stored.refused = "not restored: " + file.string() + " is another device's origin: " + why;
    stored.record.reset();
  }
  return stored;
}

Calibration initial_calibration(const std::optional<drivers::DeviceHoming>& homing,
                                const StoredOrigin& stored) {
  Calibration c;
  c.note = stored.refused;
  if (homing) {
    c.kind = CalibrationKind::homed;
    c.homing = homing;
    c.set_at = config::utc_now();
    c.origin = 0.0;  // the device's own position is measured from its home now
    return c;
  }
  if (stored.record) {
    c.kind = CalibrationKind::restored;
    c.origin = stored.record->position;
    c.cycle = stored.record->cycle;
    c.set_at = stored.record->set_at;
    c.file = stored.file.string();
    c.stored_set_by = stored.record->set_by;
    c.stored_homing_method = stored.record->homing_method;
  }
  return c;
}

config::OriginRecord record_of(const Calibration& c, const config::OriginIdentity& identity) {
  config::OriginRecord r;
  r.position = c.origin;
  r.set_by = c.kind == CalibrationKind::homed ? "homing" : "zero";
  r.homing_method = c.homing ? c.homing->method : 0;
  r.cycle = c.cycle;
  r.set_at = c.set_at;
  r.identity = identity;
  return r;
}

std::string summary(const Calibration& c, bool rotary, config::EncoderKind encoder) {
  const std::string unit = rotary ? " rad" : " m";
  switch (c.kind) {
    case CalibrationKind::zeroed:
      return "zeroed at cycle " + std::to_string(c.cycle) + " (origin " + figure(c.origin) + unit +
             " of the device's position)";
    case CalibrationKind::homed:
      return "homed: " + (c.homing ? c.homing->description : std::string("by the device")) + ", in " +
             figure(c.homing ? c.homing->duration_s : 0.0) + " s";
    case CalibrationKind::restored:
      return restored_words(c, rotary, encoder);
    case CalibrationKind::none:
      break;
  }
  return "not calibrated";
}

json to_json(const Calibration& c, const config::DeviceConfig& device, bool rotary, bool output_held) {
  json out{{"calibrated", c.kind != CalibrationKind::none},
           {"how", std::string(to_string(c.kind))},
           {"summary", summary(c, rotary, device.encoder)},
           {"origin", c.origin},
           {"unit", rotary ? "rad" : "m"},
           {"cycle", c.kind == CalibrationKind::none ? json(nullptr) : json(c.cycle)},
           {"set_at", c.set_at.empty() ? json(nullptr) : json(c.set_at)},
           {"homing_method", c.homing ? json(c.homing->method) : json(nullptr)},
           {"file", c.file.empty() ? json(nullptr) : json(c.file)},
           {"encoder", std::string(config::to_string(device.encoder))},
           {"keeping", std::string(config::to_string(device.origin_keeping()))},
           {"required", device.require_calibration},
           {"output_held", output_held},
           {"note", c.note.empty() ? json(nullptr) : json(c.note)}};
  if (c.homing) out["homing_periods"] = c.homing->periods;
  return out;
}

}  // namespace hapticd::daemon
