#pragma once
/// \file
/// The gpio-pwm Device: an H-bridge on a PWM channel and GPIO lines, the
/// position from a kernel counter or from two encoder lines. See README.md.
///
/// The framework's Device holds the lifecycle: no hook checks the order or
/// counts read/write errors (a failed line or PWM write is IoResult::error
/// in that period, and the framework counts it).
///
/// Threads: read()/write() belong to the RT thread; clear_fault() runs on
/// the control thread while the RT thread keeps calling them (the fault
/// latch and its clearing are atomics; the reset line is its own request);
/// configure/enable/disable/close only while the RT thread is not inside
/// read()/write(); health() from any thread (the non-RT calls share a
/// mutex, which read()/write() never take).

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "drivers/device_hooks.hpp"
#include "drivers/gpio_pwm/counter_unwrap.hpp"
#include "drivers/gpio_pwm/drive_command.hpp"
#include "drivers/gpio_pwm/gpio_lines.hpp"
#include "drivers/gpio_pwm/gpio_pwm_config.hpp"
#include "drivers/gpio_pwm/sysfs_attributes.hpp"

namespace hapticd::drivers::gpio_pwm {

class GpioPwmDevice final : public DeviceHooks {
 public:
  /// Validates the configuration (throws ParameterError naming the key).
  explicit GpioPwmDevice(GpioPwmConfig config);
  ~GpioPwmDevice() override;
  GpioPwmDevice(const GpioPwmDevice&) = delete;
  GpioPwmDevice& operator=(const GpioPwmDevice&) = delete;

  /// Opens the chip, requests the lines, configures the PWM channel to
  /// enabled at duty 0, opens the counter or starts the quadrature thread.
  /// Enable inactive, brake active. Throws TransportError (a DeviceError
  /// with the key).
  void configure(const LoopContext& loop) override;
  /// Arms the output: duty 0 now; the enable line goes active and the
  /// brake is released with the first write().
  void enable() override;
  /// Pulses the reset line (if any), checks the fault line reads inactive,
  /// then clears the latch. Returns what was cleared ("" if nothing was
  /// latched); throws TransportError("fault_line") if the fault persists.
  std::string clear_fault() override;
  /// Duty 0, enable inactive, brake active; the charge pump stops (no more
  /// writes). Idempotent.
  void disable() noexcept override;
  /// Releases every line and file (disable() has run); the PWM channel
  /// stays exported and enabled at duty 0. Idempotent.
  void close() noexcept override;

  IoResult read(Reading& out) noexcept override;
  IoResult write(double force) noexcept override;

  /// From the config (the device cannot measure its own mass): motion,
  /// mass, damping, the encoder's resolution; no added delay.
  DeviceModel model() const override;
  DeviceHealth health() const override;
  const GpioPwmConfig& config() const noexcept { return config_; }
  /// One line: chip, PWM, position source, and whether the rig is safe if
  /// hapticd is killed (a charge pump) or not.
  std::string description() const;

 private:
  enum Output : std::size_t { enable_out, direction_out, brake_out, pump_out, output_count };
  void request_outputs();
  void open_reset_and_fault();
  std::string open_position();
  /// One commit of every output line (the pump toggles); false if it failed.
  bool set_outputs(bool enable, bool brake) noexcept;
  /// Duty 0, enable inactive, brake on; false if a write failed.
  bool drive_off() noexcept;
  bool fault_line_active();
  void pulse_reset();
  void release() noexcept;

  GpioPwmConfig config_;
  StopToken stop_;  ///< from configure(): the reset pulse and the export wait give way to it
  DriveScaling scaling_;
  double position_per_count_ = 0.0;
  std::string fault_reason_;
  std::string description_;

  // Kernel resources (non-RT lifecycle).
  std::unique_ptr<GpioChip> chip_;
  std::unique_ptr<OutputLines> outputs_;
  std::unique_ptr<OutputLines> reset_;
  std::unique_ptr<EdgeInput> fault_;
  std::unique_ptr<EdgeInput> encoder_a_, encoder_b_;
  std::unique_ptr<QuadratureReader> quadrature_;
  std::unique_ptr<PwmOutput> pwm_;
  std::unique_ptr<CounterInput> counter_;
  std::optional<CounterUnwrap> unwrap_;

  // Output bulk: which slot holds which role (-1: not wired), active levels.
  std::array<int, output_count> slot_{-1, -1, -1, -1};
  std::array<unsigned, output_count> output_offsets_{};  ///< the chip's offset per wired role
  std::array<bool, output_count> active_low_{};
  std::array<int, output_count> levels_{};
  std::size_t used_outputs_ = 0;

  // RT state.
  bool direction_positive_ = true;
  bool pump_ = false;

  // Shared with non-RT threads.
  mutable std::mutex lifecycle_;  // non-RT calls only
  bool enabled_ = false;  // under lifecycle_: enable() again (after a clear) leaves the RT's PWM alone
  /// Why the device's own latch is set (RT-safe: a code; the words in health()).
  enum class FaultCause : std::uint8_t { none, fault_line, counter_implausible };
  /// Latches `cause` unless a fault is latched already (RT).
  void latch(FaultCause cause) noexcept;
  bool latched() const noexcept { return fault_cause_.load(std::memory_order_acquire) != FaultCause::none; }
  std::string counter_fault_words() const;

  std::atomic<FaultCause> fault_cause_{FaultCause::none};
  /// The implausible count and the last good one before it (RT -> health()).
  std::atomic<std::uint64_t> implausible_raw_{0}, last_good_raw_{0};
  std::atomic<std::uint64_t> counter_range_errors_{0};
  std::atomic<int> last_errno_{0};
};

}  // namespace hapticd::drivers::gpio_pwm
