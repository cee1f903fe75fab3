#pragma once
/// \file
/// What a driver implements: the hooks (docs/drivers.md), and the types they
/// speak. A driver's life follows ros2_control's configure / activate and
/// JACK2's open / start:
///
///   configure -> enable -> read/write once per period (RT) -> disable -> close
///                  ^                         |
///                  +---- clear_fault <-------+  (a latched device fault)
///
/// The framework's Device (device.hpp) holds that state, calls each hook
/// only in the state it is written for, turns a hook's exception into a
/// DeviceError with its key, counts errors and faults, and implements the
/// clear-fault contract: a driver writes none of that. As in ros2_control's
/// system.cpp, a component supplies hooks only; a test driver may override
/// read(), write() and model() and nothing else.
///
/// Everything but read() and write() runs outside the RT loop. Every driver
/// lives in drivers/<kind>/ with its protocol note; its simulated peer in
/// sim/<kind>/. Units are SI: position in m (linear) or rad (rotary), force
/// in N or N m.

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "drivers/stop_request.hpp"
#include "rpc/param_members.hpp"
#include "world/kinematics.hpp"
#include "world/parameter.hpp"
#include "world/plant.hpp"

namespace hapticd::drivers {

using world::Motion;     // the device's and the scenes' one Motion (world/parameter.hpp)
using world::to_string;  // to_string(Motion): "rotary", "linear"

/// Result of one RT-side device call (ros2_control style return code).
enum class IoResult : std::uint8_t {
  ok,     ///< value valid
  error,  ///< transient: no valid value this period (counted; the loop zeroes the output)
  fault,  ///< device-side fault: the loop latches a fault and zeroes the output
};

/// The most axes a device reads and writes together (world::max_axes, the
/// kinematics' fixed capacity: the engine checks they agree).
inline constexpr int max_axes = 6;

/// One sample read from the device.
struct Reading {
  double position = 0.0;  ///< m or rad, after encoder quantization
  /// No new sample came this period and position is the last one (a CiA 402
  /// TPDO not yet arrived: CiA 301 lets the master keep the last value). The
  /// loop renders it and flags the period (stale_position in the recording).
  bool stale = false;
};

/// What the loop tells a driver at configure().
struct LoopContext {
  double period_s = 1e-3;
  /// The daemon's stop request (SIGTERM): kept by the driver for the
  /// blocking waits of configure, enable and clear_fault (stop_request.hpp).
  StopToken stop{};
};

/// The model of the device the stability gate uses: from the config where
/// the device cannot know it, from the device where it can, and from
/// `hapticctl identify` once that exists. `source` says which.
struct DeviceModel {
  Motion motion = Motion::rotary;
  double effective_mass = 0.0;       ///< kg or kg m^2
  double viscous_damping = 0.0;      ///< N s/m or N m s/rad, to ground
  double position_resolution = 0.0;  ///< m or rad per count (0: continuous)
  int delay_periods = 0;             ///< output delay the device adds (a synchronous CANopen RPDO: 1)
  /// A richer linear model (e.g. the two-mass cable plant, Diaz & Gil eq.
  /// 3-9); without it the gate uses the rigid mass with viscous damping.
  std::optional<world::LinearPlant> plant;
  world::Sensor sensor = world::Sensor::motor;  ///< where the position comes from (with `plant`)
  std::string source = "config";                ///< "config", "device", "identified: <file>"
  std::string description;  ///< a few words, e.g. "rotary, two-mass" or "Copley Accelnet, node 3"
  /// One axis of a device with several: what it moves and its damping to
  /// ground, as effective_mass and viscous_damping say for one axis.
  struct Axis {
    double mass = 0.0;     ///< kg (kg m^2 for a rotary joint)
    double damping = 0.0;  ///< N s/m (N m s/rad)
  };
  /// Each axis of a device with several (as many as DeviceHooks::axes());
  /// empty for one axis, which the fields above describe. With several,
  /// effective_mass and viscous_damping are the lightest axis' (what a
  /// one-axis rule sees as the worst case).
  std::vector<Axis> axes;
  /// 1 for a one-axis model, else axes.size().
  int axis_count() const noexcept { return axes.empty() ? 1 : static_cast<int>(axes.size()); }
  /// A pantograph (issue 22): its axes are the two motor joints, linked to
  /// the handle by this linkage (world/kinematics.hpp), and the task-space
  /// box it is used in (m), over which the gate takes its worst case.
  struct Pantograph {
    world::PantographGeometry geometry;
    double x_min = 0.0, x_max = 0.0, y_min = 0.0, y_max = 0.0;
  };
  std::optional<Pantograph> pantograph;
};

/// A reference search the device ran itself before the loop (CiA 402
/// homing): its position is then measured from the home the standard
/// defines, and the daemon counts the device as calibrated (origin 0).
struct DeviceHoming {
  int method = 0;           ///< the device's method number (CiA 402 0x6098)
  std::string description;  ///< "CiA 402 homing method 37 (on the current position)"
  double duration_s = 0.0;  ///< from the start command to the home attained
  std::uint64_t periods = 0;
  double home_position = 0.0;  ///< m or rad, the first position read after it
};

/// A driver-specific counter (late TPDOs, CRC errors, dropped frames ...).
struct NamedCounter {
  std::string name;
  std::uint64_t value = 0;
};

/// A non-RT lifecycle step failed: one line, with the figure ("3 frames =
/// 0.39 ms at 500 kbit/s: a 250 us period needs 1 Mbit/s"). key() names the
/// [device.<driver>] parameter to blame, if one is; the daemon turns it into
/// that key's file:line:column.
class DeviceError : public std::runtime_error {
 public:
  explicit DeviceError(const std::string& message, std::string key = {})
      : std::runtime_error(message), key_(std::move(key)) {}
  const std::string& key() const noexcept { return key_; }

 private:
  std::string key_;
};

/// A control-plane method a driver adds (the loopback's hand.set and
/// fault.inject; a CANopen SDO read for commissioning). The handler runs on
/// the control thread and throws rpc::RpcError for bad params.
struct DeviceMethod {
  std::string name;
  bool needs_write = true;  ///< only writers may call it (else any reader)
  std::string summary;
  std::function<nlohmann::json(const nlohmann::json& params)> handler;
  /// The params members it takes, each with its type: the daemon refuses
  /// any other member, or a wrong type, before the handler runs.
  rpc::ParamMembers members{};
};

/// What a driver says of itself besides the RT return codes (any non-RT
/// thread, any time after construction).
struct DeviceHealth {
  bool faulted = false;      ///< the device is in fault now (its own latch)
  std::string fault_reason;  ///< the device's own words ("EMCY 0x2310: over current"); "" if none
  std::string last_error;    ///< the driver's last problem in words, "" if none
  std::vector<NamedCounter> counters;
};

/// The hooks. The framework (Device) guarantees the order; a hook never
/// checks it. Each non-RT hook may throw DeviceError (with the key to
/// blame) or StopRequested; any other exception becomes a DeviceError
/// naming the driver and the step.
class DeviceHooks {
 public:
  virtual ~DeviceHooks() = default;

  // ---- non-RT lifecycle ----

  /// closed -> configured. Open the bus, identify the device, read its
  /// identity and limits, check the period against the link budget, arm the
  /// device's own watchdog. Blocking waits give way to loop.stop (device
  /// disabled, StopRequested thrown). read() is called from here on.
  virtual void configure(const LoopContext& loop) { (void)loop; }
  /// configured -> enabled: power stage on, with zero output first. Also
  /// called when already enabled (again after a clear): idempotent.
  virtual void enable() {}
  /// While configured or enabled, on the control thread WHILE the RT thread
  /// keeps calling read()/write() (the engine holds the output at zero):
  /// device-side reset (CiA 402 fault-reset edge, Modbus reset register,
  /// board reset bit), then enable again; hand the request over lock-free
  /// and wait, bounded, for the device to confirm. Returns what it cleared
  /// on the device, in words ("" if it had no fault); throws DeviceError if
  /// the device stays in fault.
  virtual std::string clear_fault() { return {}; }
  /// enabled -> configured: output to zero, power stage off. The RT thread
  /// is no longer calling read()/write().
  virtual void disable() noexcept {}
  /// configured -> closed (disable() has run): release the bus.
  virtual void close() noexcept {}

  // ---- RT, once per period, from one thread: no allocation, lock, text,
  // or syscall other than the device I/O; bounded well inside the period.
  // read() from configure() on, write() only while enabled ----

  virtual IoResult read(Reading& out) noexcept = 0;
  /// Commands a force or torque for the coming period.
  virtual IoResult write(double force) noexcept = 0;

  // ---- several axes: read and written together, one sample instant for
  // all, one call each per period. A one-axis driver writes none of this ----

  /// 1 to max_axes; fixed from construction (the framework asks once).
  virtual int axes() const noexcept { return 1; }
  /// Every axis at once, out.size() == axes() (the framework checks it).
  /// Default: read(), for a one-axis driver.
  virtual IoResult read_axes(std::span<Reading> out) noexcept {
    return out.size() == 1 ? read(out[0]) : IoResult::error;
  }
  /// Every axis' force or torque for the coming period, forces.size() ==
  /// axes(). Default: write(), for a one-axis driver.
  virtual IoResult write_axes(std::span<const double> forces) noexcept {
    return forces.size() == 1 ? write(forces[0]) : IoResult::error;
  }

  // ---- any non-RT thread ----

  /// From configure() on.
  virtual DeviceModel model() const = 0;
  virtual DeviceHealth health() const { return {}; }
  /// Who the device is, for a stored calibration (docs/config.md,
  /// "Calibration"): bus address and serial where the driver knows them.
  /// From configure() on; "" (the default): the model's description.
  virtual std::string identity() const { return {}; }
  /// The reference search enable() ran, if the device was asked for one.
  virtual std::optional<DeviceHoming> homing() const { return std::nullopt; }
  /// Control-plane methods of this driver (none by default).
  virtual std::vector<DeviceMethod> methods() { return {}; }
};

}  // namespace hapticd::drivers
