#include <chrono>
#include <cstdlib>
#include <iostream>
#include <system_error>

#include "daemon/methods/method_support.hpp"
#include "daemon/service.hpp"

namespace hapticd::daemon {

using nlohmann::json;
using rpc::RpcError;
namespace code = rpc::code;
using control::Access;
using control::PeerInfo;
using namespace std::chrono_literals;

// Calibration (docs/config.md, "Calibration"): the origin the loop subtracts
// from every position, set by device.zero, by the device's own homing, or
// restored from the state directory; and status.calibration.

namespace {

/// How long device.zero waits for a valid reading, in loop time.
constexpr auto zero_window = 2000ms;

bool rotary(const DeviceModel& model) { return model.info.motion == drivers::Motion::rotary; }

}  // namespace

void Service::start_calibration() {
  const auto& device = options_.config.device;
  Calibration c = initial_calibration(device_.device->homing(), stored_origin_);
  if (c.kind != CalibrationKind::none) engine_->preset_origin(c.origin);
  if (c.kind == CalibrationKind::homed) persist_origin(c);  // the homed frame: origin 0
  if (!c.note.empty()) std::cerr << "hapticd: calibration: " << c.note << "\n";
  std::cout << "hapticd: calibration: " << summary(c, rotary(model_), device.encoder)
            << (device.require_calibration && c.kind == CalibrationKind::none
                    ? "; output held at zero until `hapticctl device zero` ([device] require_calibration)"
                    : "")
            << std::endl;
  std::lock_guard lock(calibration_mutex_);
  calibration_ = std::move(c);
}

std::string Service::persist_origin(Calibration& c) {
  const auto& device = options_.config.device;
  if (device.origin_keeping() != config::OriginKeeping::persist) return {};
  // NOLINTNEXTLINE(concurrency-mt-unsafe): no setenv in the daemon
  const auto file = config::resolve_origin_file(device, std::getenv("STATE_DIRECTORY"));
  try {
    config::write_origin_file(file, record_of(c, origin_identity_));
  } catch (const std::system_error& e) {
    c.note = std::string("the origin is in force but was not kept: ") + e.what();
    std::cerr << "hapticd: calibration: " << c.note << "\n";
    return {};
  }
  c.file = file.string();
  return c.file;
}

void Service::settle_zero() const {
  std::lock_guard lock(calibration_mutex_);
  if (!zero_unsettled_ || engine_->origin_request_pending()) return;
  zero_unsettled_ = false;
  const auto outcome = engine_->settle_origin();
  if (!outcome || !outcome->taken) return;
  calibration_ = Calibration{};
  calibration_.kind = CalibrationKind::zeroed;
  calibration_.origin = outcome->origin;
  calibration_.cycle = outcome->cycle;
  calibration_.set_at = config::utc_now();
  calibration_.note = "device.zero was taken after it stopped waiting (the loop was late): not kept";
}

Calibration Service::calibration() const {
  settle_zero();
  std::lock_guard lock(calibration_mutex_);
  return calibration_;
}

bool Service::output_held_uncalibrated() const {
  return options_.config.device.require_calibration && !engine_->calibrated();
}

json Service::calibration_json() const {
  return to_json(calibration(), options_.config.device, rotary(model_), output_held_uncalibrated());
}

json Service::zero_device() {
  settle_zero();
  if (engine_->finished()) throw RpcError(code::busy, "the RT loop has stopped; nothing can take effect");
  if (const int axes = device_.device->axes(); axes != 1) {
    throw RpcError(code::refused, "device.zero sets the origin of a device with one axis; this one has " +
                                      std::to_string(axes) + ", whose positions are the stage's own");
  }
  if (engine_->origin_request_pending())
    throw RpcError(code::busy, "an earlier device.zero is still waiting for the RT loop");
  const Calibration before = calibration();
  recorder_->hold_for_scene();  // no sample from the new origin under the old header
  const auto outcome = engine_->zero_here(zero_window);
  if (!outcome) {
    std::lock_guard lock(calibration_mutex_);
    zero_unsettled_ = true;
    throw RpcError(code::busy, "the RT loop did not take the origin within 2 s");
  }
  if (!outcome->taken) {
    const std::string fault = engine_->fault_description();
    throw RpcError(code::refused, "device.zero: the device gave no valid position within 2 s of loop time" +
                                      (fault.empty() ? std::string() : " (fault latched: " + fault + ")") +
                                      "; the origin is unchanged");
  }
  Calibration c;
  c.kind = CalibrationKind::zeroed;
  c.origin = outcome->origin;
  c.cycle = outcome->cycle;
  c.set_at = config::utc_now();
  const std::string kept = persist_origin(c);
  {
    std::lock_guard lock(calibration_mutex_);
    calibration_ = c;
  }
  recorder::RecordingHeader header = header_for(current_scene());
  header.change = "origin set by device.zero";
  recorder_->set_scene(std::move(header), outcome->cycle);
  json reply{{"origin", outcome->origin},
             {"previous_origin", outcome->previous},
             {"previously", std::string(to_string(before.kind))},
             {"unit", rotary(model_) ? "rad" : "m"},
             {"cycle", outcome->cycle},
             {"kept", kept.empty() ? json(nullptr) : json(kept)},
             {"calibration", calibration_json()}};
  return reply;
}

void Service::register_calibration_methods(control::ControlServer& server) {
  server.register_method(
      "device.zero", [this](const json&, const PeerInfo&) { return zero_device(); }, Access::write);
}

}  // namespace hapticd::daemon
