#include "world/chirp_scene.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "world/scene_catalog.hpp"

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
  if (!(std::isfinite(p.sweep_s) && whole_periods(p.sweep_s, period_s) >= 2 &&
        whole_periods(p.sweep_s, period_s) <= max_chirp_sweep_steps)) {
    throw std::invalid_argument("sweep must last 2 to " + std::to_string(max_chirp_sweep_steps) + " periods");
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
  double sum = 0.0;
  for (std::int64_t j = 0; j < sweep_steps_; ++j) {
    sum += std::sin(phase_scale_ * (std::exp(growth_per_step_ * static_cast<double>(j)) - 1.0));
  }
  mean_ = sum / static_cast<double>(sweep_steps_);
  gain_ = amplitude_ / (1.0 + std::abs(mean_));
  const std::int64_t cycle = whole_periods(1.0 / p.start_frequency, period_s);
  fade_steps_ = std::max<std::int64_t>(1, std::min({cycle, sweep_steps_ / 2, duration_steps_ / 2}));
}

double ChirpScene::step(double /*measured_position*/) noexcept {
  if (steps_ >= duration_steps_) {
    frequency_hz_ = 0.0;
    return 0.0;
  }
  const std::int64_t n = steps_++;
  const double growth = std::exp(growth_per_step_ * static_cast<double>(n % sweep_steps_));
  frequency_hz_ = start_hz_ * growth;
  const double force = gain_ * (std::sin(phase_scale_ * (growth - 1.0)) - mean_);
  const std::int64_t edge = std::min(n, duration_steps_ - n);  // steps from the nearer end
  if (edge >= fade_steps_) return force;
  const double fade =
      0.5 - 0.5 * std::cos(std::numbers::pi * static_cast<double>(edge) / static_cast<double>(fade_steps_));
  return fade * force;
}

// The registry entry (world/scene_registry.hpp): an excitation, not a
// feedback law, so the gate has nothing to judge; its units follow the
// device's motion.

namespace {

using P = ParameterSpec;

std::vector<ParameterSpec> chirp_parameters() {
  namespace r = parameter_range;
  const ChirpParameters c;
  return {
      P::number("amplitude", "N", "force amplitude A (|F| <= A)")
          .on_rotary("N m")
          .defaults_to(c.amplitude)
          .above(0.0)
          .at_most(r::max_force),
      P::number("start_frequency", "Hz", "sweep start frequency f0")
          .defaults_to(c.start_frequency)
          .above(0.0)
          .at_most(r::max_frequency_hz),
      P::number("end_frequency", "Hz", "sweep end frequency f1 (> f0, at most 1/(2T))")
          .defaults_to(c.end_frequency)
          .above(0.0)
          .at_most(r::max_frequency_hz),
      P::number("sweep", "s", "one sweep f0 -> f1 (the excitation's period)")
          .defaults_to(c.sweep_s)
          .above(0.0)
          .at_most(r::max_duration_s),
      P::number("duration", "s", "then output 0 for good")
          .defaults_to(c.duration_s)
          .above(0.0)
          .at_most(r::max_duration_s),
  };
}

void build_chirp(ScenePlan& plan, const SceneContext& context) {
  const ParameterSet& p = plan.parameters;
  const ChirpParameters cp{number_of(p, "amplitude"), number_of(p, "start_frequency"),
                           number_of(p, "end_frequency"), number_of(p, "sweep"), number_of(p, "duration")};
  set_scene(plan, ChirpScene(cp, context.period_s), context.motion);
}

}  // namespace

SceneDescription ChirpEntry::describe() {
  return {.name = "chirp",
          .reference = "Diaz & Gil II, Fig. 4 (swept sine for identification)",
          .summary = "F = A sin(phi(t)): exponential sweep f0 -> f1 every `sweep` seconds, repeated",
          .parameters = chirp_parameters(),
          .fixed_motion = std::nullopt,
          .stability = StabilityRule::none,
          .unstable_hint = {},
          .build = build_chirp};
}

}  // namespace hapticd::world
