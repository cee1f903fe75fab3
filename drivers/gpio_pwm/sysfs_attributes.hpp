#pragma once
/// \file
/// Transport, part 2 of 2: the kernel's PWM channel
/// (/sys/class/pwm/pwmchipN/pwmM, Documentation/ABI/testing/sysfs-class-pwm)
/// and counter (/sys/bus/counter/devices/counterX/countY,
/// Documentation/ABI/testing/sysfs-bus-counter) as sysfs attribute files,
/// opened once at configure and kept open: each period costs one pread()
/// of the count and at most one pwrite() of the duty cycle, at offset 0 (a
/// sysfs attribute is re-read from offset 0; a write is one store whatever
/// the offset).
///
/// Configure-time calls allocate and throw TransportError naming the key;
/// the per-period calls (PwmOutput::set_duty, CounterInput::read) return an
/// errno and neither allocate, lock nor throw.

#include <atomic>
#include <cstdint>
#include <string>
#include <string_view>

#include "drivers/gpio_pwm/pwm_plan.hpp"
#include "drivers/gpio_pwm/transport_error.hpp"
#include "drivers/stop_request.hpp"

namespace hapticd::drivers::gpio_pwm {

/// One attribute file, open for the device's life.
class SysfsAttribute {
 public:
  SysfsAttribute() = default;
  /// Throws TransportError(key) with the path and the reason.
  SysfsAttribute(std::string path, bool writable, std::string_view key);
  ~SysfsAttribute();
  SysfsAttribute(SysfsAttribute&& other) noexcept;
  SysfsAttribute& operator=(SysfsAttribute&& other) noexcept;
  SysfsAttribute(const SysfsAttribute&) = delete;
  SysfsAttribute& operator=(const SysfsAttribute&) = delete;

  /// RT: one pread() at offset 0 and the decimal parse. 0, the errno, or
  /// EBADMSG when the text is not an unsigned number.
  int read_u64(std::uint64_t& out) const noexcept;
  /// RT: one pwrite() of "<value>\n" at offset 0. 0 or the errno.
  int write_u64(std::uint64_t value) const noexcept;
  /// Non-RT: "normal", "inversed", "quadrature x4" (first line, no newline).
  std::string read_text() const;
  int write_text(std::string_view text) const noexcept;
  const std::string& path() const noexcept { return path_; }
  bool is_open() const noexcept { return fd_ >= 0; }

 private:
  std::string path_;
  int fd_ = -1;
};

/// One PWM channel, configured to the defined off state: enabled, duty 0.
/// The kernel documents no output level for a disabled PWM (some chips
/// hold the last level, some float: Documentation/driver-api/pwm.rst, "If
/// you rely on getting the inactive state, use .duty_cycle=0, .enabled=true"),
/// so the channel is never disabled while hapticd runs, nor at close.
class PwmOutput {
 public:
  struct Settings {
    std::string chip_dir;  ///< /sys/class/pwm/pwmchipN
    unsigned channel = 0;
    std::uint64_t period_ns = 50'000;
    bool inversed = false;
    double export_timeout_s = 1.0;
    StopToken stop{};  ///< the export wait gives way to it (StopRequested)
  };
  /// Exports the channel if needed (and waits, bounded, for its directory:
  /// udev may still be fixing permissions), sets the polarity, the period
  /// and duty 0 in an order the kernel accepts, then enables it. Throws
  /// TransportError naming the key (pwm_chip, pwm_channel, pwm_period,
  /// pwm_inversed, export_timeout).
  explicit PwmOutput(const Settings& settings);

  /// RT: duty in ns (<= the period), written only if it changed. 0 or the
  /// errno (the cached state keeps what the kernel accepted).
  int set_duty(std::uint64_t duty_ns) noexcept;
  /// RT: period and duty together, in the order the kernel accepts.
  int set_timing(const PwmTiming& target) noexcept;
  /// Duty 0, still enabled (every exit path).
  int off() noexcept { return set_duty(0); }
  PwmTiming timing() const noexcept { return timing_; }
  const std::string& channel_dir() const noexcept { return channel_dir_; }
  /// The number of sysfs writes made by set_duty/set_timing (unchanged
  /// values cost nothing). Readable from any thread.
  std::uint64_t writes() const noexcept { return writes_.load(std::memory_order_relaxed); }

 private:
  void export_channel(const Settings& settings);
  void write_or_throw(const SysfsAttribute& attribute, std::uint64_t value, const char* key);

  std::string channel_dir_;
  SysfsAttribute period_, duty_, enable_;
  PwmTiming timing_;
  std::atomic<std::uint64_t> writes_{0};  // written by the RT thread only
};

/// One count of a kernel counter device (ti-eqep, stm32-lptimer-cnt,
/// intel-qep, 104-quad-8 ...): the count decoded in hardware.
class CounterInput {
 public:
  /// Opens <counter_dir>/count<index>/count; reads its ceiling (the largest
  /// count before it wraps to 0; absent: 2^64 - 1) and function ("quadrature
  /// x4" ...). Throws TransportError (key "counter" / "counter_count").
  CounterInput(const std::string& counter_dir, unsigned index);

  /// RT: one pread() of the count. 0 or the errno.
  int read(std::uint64_t& raw) const noexcept { return count_.read_u64(raw); }
  std::uint64_t ceiling() const noexcept { return ceiling_; }
  const std::string& function() const noexcept { return function_; }
  const std::string& path() const noexcept { return count_.path(); }

 private:
  SysfsAttribute count_;
  std::uint64_t ceiling_ = UINT64_MAX;
  std::string function_;
};

}  // namespace hapticd::drivers::gpio_pwm
