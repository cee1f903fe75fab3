#pragma once
/// \file
/// The framework's Device: one final class around a driver's hooks
/// (device_hooks.hpp), as ros2_control's hardware_interface/system.cpp holds
/// the lifecycle for every component. It
/// - holds the state (closed, configured, enabled) and calls each hook only
///   in the state it is written for: a call out of order is the caller's
///   bug and throws std::logic_error, naming the driver and the state;
/// - turns a hook's exception into a DeviceError with its key (a DeviceError
///   passes as it is, StopRequested too; anything else is named after the
///   driver and the step), and keeps the last one for status();
/// - counts read and write errors and latched faults on the RT path, with
///   one acquire load per call and no allocation;
/// - implements the clear-fault contract once: allowed from configure() on,
///   while the RT thread runs; the fault latch resets only when the hook
///   confirms the device cleared.

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/device_hooks.hpp"

namespace hapticd::drivers {

enum class DeviceState { closed, configured, enabled, fault };
std::string_view to_string(DeviceState state) noexcept;  ///< "closed", "configured", ...

/// Everything but the RT return codes (ros2_control: return codes plus a
/// status struct). Read from non-RT threads at any time.
struct DeviceStatus {
  DeviceState state = DeviceState::closed;
  std::uint64_t read_errors = 0;   ///< read() calls with no valid value (refused ones too)
  std::uint64_t write_errors = 0;  ///< write() calls not carried out (refused ones too)
  std::uint64_t faults = 0;        ///< faults latched since construction
  std::string fault_reason;        ///< the device's own words ("EMCY 0x2310: over current"); "" if none
  std::string last_error;
  std::vector<NamedCounter> counters;
};

class Device final {
 public:
  /// `kind`: the driver's registry name, for messages ("canopen"). Throws
  /// std::invalid_argument for hooks that say fewer than 1 or more than
  /// max_axes axes.
  Device(std::string kind, std::unique_ptr<DeviceHooks> hooks);
  ~Device();  ///< close()
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  // ---- non-RT lifecycle (device_hooks.hpp says what each step does) ----

  void configure(const LoopContext& loop);  ///< closed -> configured
  void enable();                            ///< configured (or enabled) -> enabled
  /// From configure() on, while the RT thread keeps calling read()/write().
  std::string clear_fault();
  void disable() noexcept;  ///< enabled -> configured; nothing otherwise
  void close() noexcept;    ///< disable(), then -> closed; idempotent

  // ---- RT: read() from configure() on, write() only while enabled;
  // refused calls return IoResult::error and are counted ----

  IoResult read(Reading& out) noexcept {
    if (state_.load(std::memory_order_acquire) == Lifecycle::closed || axes_ != 1)
      return counted_read(IoResult::error);
    const IoResult r = hooks_->read(out);
    return r == IoResult::ok ? r : counted_read(r);
  }
  IoResult write(double force) noexcept {
    if (state_.load(std::memory_order_acquire) != Lifecycle::enabled || axes_ != 1)
      return counted_write(IoResult::error);
    const IoResult r = hooks_->write(force);
    return r == IoResult::ok ? r : counted_write(r);
  }

  // ---- RT, several axes: every axis in one call, the same rules and
  // counting as read()/write(); refused (counted) unless the span has one
  // entry per axis. read()/write() are refused on a device with several ----

  int axes() const noexcept { return axes_; }
  IoResult read_axes(std::span<Reading> out) noexcept {
    if (state_.load(std::memory_order_acquire) == Lifecycle::closed || std::ssize(out) != axes_)
      return counted_read(IoResult::error);
    const IoResult r = hooks_->read_axes(out);
    return r == IoResult::ok ? r : counted_read(r);
  }
  IoResult write_axes(std::span<const double> forces) noexcept {
    if (state_.load(std::memory_order_acquire) != Lifecycle::enabled || std::ssize(forces) != axes_)
      return counted_write(IoResult::error);
    const IoResult r = hooks_->write_axes(forces);
    return r == IoResult::ok ? r : counted_write(r);
  }

  // ---- any non-RT thread ----

  DeviceModel model() const;  ///< from configure() on
  /// The device's identity for a stored calibration: the hook's, else the
  /// model's description (from configure() on).
  std::string identity() const;
  std::optional<DeviceHoming> homing() const { return hooks_->homing(); }
  DeviceStatus status() const;
  std::vector<DeviceMethod> methods() { return hooks_->methods(); }
  const std::string& kind() const noexcept { return kind_; }

  /// The driver's own object, for its tests and tools (std::bad_cast if it
  /// is another driver's).
  template <class Hooks>
  Hooks& hooks_as() {
    return dynamic_cast<Hooks&>(*hooks_);
  }
  template <class Hooks>
  const Hooks& hooks_as() const {
    return dynamic_cast<const Hooks&>(*hooks_);
  }

 private:
  enum class Lifecycle : std::uint8_t { closed, configured, enabled };

  [[noreturn]] void out_of_order(const char* step) const;
  /// Runs a lifecycle hook; a failure is kept for status() and rethrown as
  /// a DeviceError (see the file comment).
  template <class Step>
  auto guarded(const char* step, Step&& run);
  IoResult counted_read(IoResult r) noexcept;
  IoResult counted_write(IoResult r) noexcept;
  void count_fault() noexcept;

  const std::string kind_;
  const std::unique_ptr<DeviceHooks> hooks_;
  const int axes_;  ///< hooks_->axes(), asked once
  std::atomic<Lifecycle> state_{Lifecycle::closed};
  std::atomic<bool> latched_{false};  ///< a fault since the last successful clear
  std::atomic<std::uint64_t> read_errors_{0}, write_errors_{0}, faults_{0};
  mutable std::mutex error_mutex_;  // last_error_ (non-RT)
  std::string last_error_;
};

}  // namespace hapticd::drivers
