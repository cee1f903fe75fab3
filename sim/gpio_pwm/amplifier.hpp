#pragma once
/// \file
/// The power stage of the simulated board: an H-bridge driven by a PWM
/// input and a direction input, with an enable, an optional brake, a fault
/// output that latches until a reset pulse, and the external charge-pump
/// watchdog of the protocol note (LinuxCNC's charge_pump: a square wave the
/// controller toggles every period; the watchdog keeps the power stage
/// enabled only while the wave keeps coming). No system calls; stepped one
/// period at a time by the board.

#include <cstdint>
#include <string>

namespace hapticd::drivers::gpio_pwm::sim {

struct AmplifierConfig {
  double force_at_full_duty = 1.0;  ///< N or N m at 100 % duty (the board's own gain)
  /// Periods without a charge-pump edge after which the watchdog cuts the
  /// power stage; 0: no watchdog fitted (the enable line alone decides).
  unsigned watchdog_periods = 0;
};

/// The logical levels of the board's inputs during one period (after the
/// board's wiring: true = active).
struct AmplifierInputs {
  bool enable = false;
  bool direction_positive = true;
  bool brake = false;
  bool charge_pump = false;
  double pwm_active_fraction = 0.0;  ///< 0..1 of the period the bridge is driven
};

class Amplifier {
 public:
  explicit Amplifier(AmplifierConfig config) : config_(config) {}

  /// One period: the force the motor receives over it (0 unless enabled,
  /// not braking, not in fault and, with a watchdog, pumped).
  double step(const AmplifierInputs& in) noexcept;

  /// The power stage trips (over-current, over-temperature ...): off, fault
  /// output active, until a reset pulse.
  void trip(std::string reason);
  /// The reset input's logical level. The fault clears on the pulse's end
  /// (active -> inactive), as a latch reset by an RC one-shot does.
  void set_reset(bool active) noexcept;

  bool fault() const noexcept { return fault_; }
  const std::string& fault_reason() const noexcept { return reason_; }
  bool watchdog_expired() const noexcept;
  /// Whether the bridge drove the motor in the last period.
  bool powered() const noexcept { return powered_; }
  std::uint64_t pump_edges() const noexcept { return pump_edges_; }
  std::uint64_t resets() const noexcept { return resets_; }

 private:
  AmplifierConfig config_;
  bool fault_ = false;
  std::string reason_;
  bool reset_ = false;
  bool last_pump_ = false;
  std::uint64_t periods_since_pump_edge_ = UINT64_MAX / 2;  // no wave seen yet: not armed
  std::uint64_t pump_edges_ = 0;
  std::uint64_t resets_ = 0;
  bool powered_ = false;
};

}  // namespace hapticd::drivers::gpio_pwm::sim
