#pragma once
/// \file
/// The device seam. The RT loop calls read() and write() once per period and
/// nothing else; start() and stop() run outside the RT loop. Every driver
/// lives in drivers/<kind>/ with its protocol notes and a simulated peer.
/// Units are SI: position in m (linear) or rad (rotary), force in N or N m.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace hapticd::drivers {

enum class Motion { rotary, linear };

/// Result of one RT-side device call (ros2_control style return code).
enum class IoResult : std::uint8_t {
  ok,     ///< value valid
  error,  ///< transient: no valid value this period (counted; the loop zeroes the output)
  fault,  ///< device-side fault: the loop latches a fault and zeroes the output
};

/// One sample read from the device.
struct Reading {
  double position = 0.0;  ///< m or rad, after encoder quantization
};

/// What a driver says about itself; filled outside the RT loop.
struct DeviceInfo {
  std::string driver;  ///< "loopback", "usb-hid", ...
  Motion motion = Motion::rotary;
  double effective_mass = 0.0;       ///< kg or kg m^2: what stability checks use
  double viscous_damping = 0.0;      ///< N s/m or N m s/rad
  double position_resolution = 0.0;  ///< m or rad per count (0: continuous)
  int inherent_delay_samples = 0;    ///< output delay the device adds, in periods
};

/// A parameter a driver accepts (JACK2 style), so the CLI and the config can
/// list them with their defaults and help.
struct DriverParameter {
  std::string name;
  std::string type;           ///< "number", "integer", "string", "bool"
  std::string default_value;  ///< as it would be written in the TOML config
  std::string unit;           ///< SI unit, empty if none
  std::string help;
};

/// Counters a driver keeps; read outside the RT loop (relaxed atomics or
/// copies taken at a period boundary are the driver's business).
struct DeviceStatus {
  bool running = false;
  std::uint64_t read_errors = 0;
  std::uint64_t write_errors = 0;
  std::uint64_t faults = 0;
  std::string last_error;  ///< filled outside RT
};

class Device {
 public:
  virtual ~Device() = default;
  virtual DeviceInfo info() const = 0;
  /// Open and enable (non-RT). Throws std::runtime_error with a clear message on failure.
  virtual void start() = 0;
  /// Zero the output and disable the amplifier (non-RT, also on every shutdown path).
  virtual void stop() noexcept = 0;
  /// RT: read the current position. No allocation, no locks.
  virtual IoResult read(Reading& out) noexcept = 0;
  /// RT: command a force/torque for the coming period. No allocation, no locks.
  virtual IoResult write(double force) noexcept = 0;
  virtual DeviceStatus status() const = 0;
};

}  // namespace hapticd::drivers
