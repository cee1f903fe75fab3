#include "world/chirp_scene.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace hapticd::world {

namespace {

std::int64_t whole_periods(double seconds, double period_s) {
  return static_cast<std::int64_t>(std::llround(seconds / period_s));
}

}  // namespace

ChirpScene::ChirpScene(const ChirpParameters& p, double period_s) : amplitude_(p.amplitude) {
  if (!(std::isfinite(period_s) && period_s > 0.0)) throw std::invalid_argument("period must be > 0");
  if (!(std::isfinite(p.amplitude) && p.amplitude > 0.0))
    throw std::invalid_argument("amplitude must be > 0");
  const double nyquist = 0.5 / period_s;
  if (!(std::isfinite(p.start_frequency) && p.start_frequency > 0.0)) {
    throw std::invalid_argument("start_frequency must be > 0 Hz");
  }
  if (!(std::isfinite(p.end_frequency) && p.end_frequency > p.start_frequency &&
        p.end_frequency <= nyquist)) {
    throw std::invalid_argument(
        "end_frequency must lie above start_frequency and at most at the Nyquist "
        "frequency 1/(2T) = " +
        std::to_string(nyquist) + " Hz");
  }
  if (!(std::isfinite(p.sweep_s) && whole_periods(p.sweep_s, period_s) >= 2)) {
    throw std::invalid_argument("sweep must last at least 2 periods");
  }
  if (!(std::isfinite(p.duration_s) && whole_periods(p.duration_s, period_s) >= 1)) {
    throw std::invalid_argument("duration must last at least 1 period");
  }
  sweep_steps_ = whole_periods(p.sweep_s, period_s);
  duration_steps_ = whole_periods(p.duration_s, period_s);
  start_hz_ = p.start_frequency;
  const double log_ratio = std::log(p.end_frequency / p.start_frequency);
  const double sweep = static_cast<double>(sweep_steps_) * period_s;
  growth_per_step_ = log_ratio / static_cast<double>(sweep_steps_);
  phase_scale_ = 2.0 * std::numbers::pi * p.start_frequency * sweep / log_ratio;
}

double ChirpScene::step(double /*measured_position*/) noexcept {
  if (steps_ >= duration_steps_) {
    frequency_hz_ = 0.0;
    return 0.0;
  }
  const auto j = static_cast<double>(steps_ % sweep_steps_);
  ++steps_;
  const double growth = std::exp(growth_per_step_ * j);
  frequency_hz_ = start_hz_ * growth;
  return amplitude_ * std::sin(phase_scale_ * (growth - 1.0));
}

}  // namespace hapticd::world
