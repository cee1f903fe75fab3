#include "sim/gpio_pwm/amplifier.hpp"

#include <algorithm>
#include <utility>

namespace hapticd::drivers::gpio_pwm::sim {

bool Amplifier::watchdog_expired() const noexcept {
  return config_.watchdog_periods != 0 && periods_since_pump_edge_ > config_.watchdog_periods;
}

double Amplifier::step(const AmplifierInputs& in) noexcept {
  if (in.charge_pump != last_pump_) {
    ++pump_edges_;
    periods_since_pump_edge_ = 0;
    last_pump_ = in.charge_pump;
  } else {
    ++periods_since_pump_edge_;
  }
  powered_ = in.enable && !in.brake && !fault_ && !watchdog_expired();
  if (!powered_) return 0.0;
  const double magnitude = std::clamp(in.pwm_active_fraction, 0.0, 1.0) * config_.force_at_full_duty;
  return in.direction_positive ? magnitude : -magnitude;
}

void Amplifier::trip(std::string reason) {
  fault_ = true;
  reason_ = std::move(reason);
}

void Amplifier::set_reset(bool active) noexcept {
  if (reset_ && !active && fault_) {
    fault_ = false;
    reason_.clear();
    ++resets_;
  }
  reset_ = active;
}

}  // namespace hapticd::drivers::gpio_pwm::sim
