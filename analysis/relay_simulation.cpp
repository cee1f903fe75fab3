#include "analysis/relay_simulation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <stdexcept>

#include "analysis/non_finite.hpp"
#include "world/integrator.hpp"
#include "world/relay_scene.hpp"

namespace hapticd::analysis {

namespace {

using non_finite::nan;

template <class Scene>
RelayRecord run(Scene scene, const SampledRelay& r, std::int64_t steps) {
  const Eigen::VectorXd b = r.plant.dynamics.b.col(world::motor_force_input);
  const world::DiscreteStateSpace d = world::discretize_zoh({r.plant.dynamics.a, b}, r.period_s);
  const Eigen::RowVectorXd c = r.plant.position(r.sensor);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(r.plant.dynamics.a.rows());
  // The device's own output delay: a line of device_delay + 1 cells.
  std::vector<double> line(static_cast<std::size_t>(r.device_delay) + 1, 0.0);
  std::size_t head = 0;
  RelayRecord out;
  out.position.reserve(static_cast<std::size_t>(steps));
  out.force.reserve(static_cast<std::size_t>(steps));
  bool first = true;
  for (std::int64_t n = 0; n < steps; ++n) {
    double y = c * x;
    if (r.resolution > 0.0) y = std::floor(y / r.resolution) * r.resolution;
    if (first) {
      scene.reset(y);
      first = false;
    }
    double f = scene.step(y);
    if (r.torque_limit > 0.0) f = std::clamp(f, -r.torque_limit, r.torque_limit);
    out.position.push_back(y);
    out.force.push_back(f);
    line[head] = f;
    const double applied = line[(head + 1) % line.size()];
    head = (head + 1) % line.size();
    x = d.ad * x + d.bd.col(0) * applied;
  }
  return out;
}

}  // namespace

double loop_delay_s(const SampledRelay& relay) noexcept {
  return static_cast<double>(relay.device_delay + relay.delay_samples) * relay.period_s;
}

RelayRecord simulate_relay(const SampledRelay& r, std::int64_t steps) {
  if (!(r.period_s > 0.0) || !std::isfinite(r.period_s)) throw std::invalid_argument("period must be > 0");
  if (r.device_delay < 0 || r.delay_samples < 0 ||
      r.delay_samples > static_cast<int>(world::max_relay_delay_samples)) {
    throw std::invalid_argument("relay simulation: delays must be >= 0 and the relay's at most " +
                                std::to_string(world::max_relay_delay_samples) + " samples");
  }
  world::RelayParameters p{r.amplitude, r.hysteresis, -r.start_offset};
  p.delay_samples = r.delay_samples;
  using H = world::RelayHysteresis;
  using D = world::RelayDelay;
  const bool band = r.hysteresis > 0.0;
  if (r.delay_samples == 0) {
    return band ? run(world::RelayScene<H::band>(p), r, steps) : run(world::RelayScene<H::none>(p), r, steps);
  }
  return band ? run(world::RelayScene<H::band, D::samples>(p), r, steps)
              : run(world::RelayScene<H::none, D::samples>(p), r, steps);
}

std::optional<std::size_t> matching_crossover(const std::vector<PhaseCrossover>& crossovers,
                                              double frequency_hz, double tolerance) {
  std::optional<std::size_t> best;
  double best_distance = std::log(tolerance);
  const double w = 2.0 * std::numbers::pi * frequency_hz;
  for (std::size_t i = 0; i < crossovers.size(); ++i) {
    if (!(crossovers[i].omega_rad_per_s > 0.0)) continue;
    const double distance = std::abs(std::log(w / crossovers[i].omega_rad_per_s));
    if (distance <= best_distance) {
      best_distance = distance;
      best = i;
    }
  }
  return best;
}

std::optional<std::size_t> critical_crossover(const std::vector<PhaseCrossover>& crossovers) {
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < crossovers.size(); ++i) {
    if (!std::isfinite(crossovers[i].stiffness)) continue;
    if (!best || crossovers[i].stiffness < crossovers[*best].stiffness) best = i;
  }
  return best;
}

std::vector<PhaseCrossover> loop_crossovers(const world::LinearPlant& plant, world::Sensor sensor,
                                            double period_s, double delay_s) {
  const DelayedZoh sys = discretize_delayed_zoh(
      plant.dynamics.a, plant.dynamics.b.col(world::motor_force_input), period_s, delay_s);
  return phase_crossovers(sys, plant.position(sensor));
}

bool RelayBias::usable() const {
  return std::isfinite(spectrum_gain_db) && std::isfinite(spectrum_frequency_ratio) &&
         std::isfinite(describing_gain_db) && std::isfinite(describing_frequency_ratio);
}

RelayBias relay_bias(const SampledRelay& relay, std::int64_t steps, std::int64_t steady_from) {
  RelayBias bias;
  const double delay = loop_delay_s(relay);
  bias.model = critical_stiffness(relay.plant, relay.sensor, relay.period_s, delay);
  bias.crossovers = loop_crossovers(relay.plant, relay.sensor, relay.period_s, delay);
  const RelayRecord record = simulate_relay(relay, steps);
  const auto from = static_cast<std::size_t>(std::clamp<std::int64_t>(steady_from, 0, steps));
  const std::span<const double> y(record.position.data() + from, record.position.size() - from);
  const std::span<const double> f(record.force.data() + from, record.force.size() - from);
  bias.simulated = analyze_relay(y, f, relay.period_s, relay.amplitude);
  bias.spectrum_gain_db = bias.spectrum_frequency_ratio = nan;
  bias.describing_gain_db = bias.describing_frequency_ratio = nan;
  if (!bias.model.assessed() || !bias.simulated.spectrum) return bias;
  bias.locked = matching_crossover(bias.crossovers, bias.simulated.spectrum->frequency_hz);
  if (!bias.simulated.steady || bias.locked != critical_crossover(bias.crossovers)) return bias;
  bias.spectrum_gain_db = bias.simulated.spectrum->gain_margin_db - bias.model.gain_margin_db;
  bias.spectrum_frequency_ratio = bias.simulated.spectrum->frequency_hz / bias.model.crossover_hz;
  if (const auto& df = bias.simulated.describing_function) {
    bias.describing_gain_db = df->gain_margin_db - bias.model.gain_margin_db;
    bias.describing_frequency_ratio = df->frequency_hz / bias.model.crossover_hz;
  }
  return bias;
}

}  // namespace hapticd::analysis
