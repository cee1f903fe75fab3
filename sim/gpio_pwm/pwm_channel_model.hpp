#pragma once
/// \file
/// One exported PWM channel as the kernel's sysfs interface handles writes
/// to it (drivers/pwm/sysfs.c + pwm_apply_state() in drivers/pwm/core.c).
/// No system calls: the testbed's PWM attributes are plain files, so the
/// simulated board replays each write the driver made through this model
/// and refuses what the kernel would refuse.
///
/// Kernel rules followed:
/// - every store (period, duty_cycle, enable, polarity) takes the current
///   state, changes one field and applies it; the core refuses a state with
///   period 0 or duty_cycle > period with EINVAL, whatever field changed
///   (so on a freshly exported channel, period 0, even "enable = 0" and the
///   polarity are refused until a period is written);
/// - enable accepts 0 and 1 only (EINVAL otherwise);
/// - polarity accepts "normal" and "inversed"; changing it while enabled is
///   EBUSY (what legacy drivers return; the stricter behaviour is modelled
///   so a driver that works here works on them too);
/// - a value that is not a decimal number is EINVAL.

#include <cstdint>
#include <string>
#include <string_view>

namespace hapticd::drivers::gpio_pwm::sim {

struct PwmChannelState {
  std::uint64_t period_ns = 0;
  std::uint64_t duty_ns = 0;
  bool enabled = false;
  bool inversed = false;
  friend bool operator==(const PwmChannelState&, const PwmChannelState&) = default;
};

class PwmChannelModel {
 public:
  /// The state right after export (period 0 on most chips; a chip whose
  /// bootloader left it running may start elsewhere).
  explicit PwmChannelModel(PwmChannelState initial = {}) : state_(initial) {}

  /// A write of `text` to attribute `name` ("period", "duty_cycle",
  /// "enable", "polarity"). Returns 0 or the errno; a refused write leaves
  /// the state unchanged. An unknown attribute is ENOENT.
  int write(std::string_view name, std::string_view text);
  /// What reading the attribute gives ("%llu\n", "%d\n", "normal\n").
  std::string read(std::string_view name) const;
  /// The same text into `out` without allocating; returns its length (0 for
  /// an unknown attribute or a buffer under 24 bytes).
  std::size_t format(std::string_view name, char* out, std::size_t size) const noexcept;

  const PwmChannelState& state() const noexcept { return state_; }
  /// The fraction of each period the pin is high: duty / period, or
  /// 1 - duty / period when inversed. A disabled channel gives 0 here; the
  /// kernel promises no level for a disabled PWM (see the protocol note),
  /// which is why the driver keeps it enabled at duty 0 instead.
  double high_fraction() const noexcept;

 private:
  static bool acceptable(const PwmChannelState& s) noexcept {
    return s.period_ns > 0 && s.duty_ns <= s.period_ns;
  }
  PwmChannelState state_;
};

}  // namespace hapticd::drivers::gpio_pwm::sim
