#include "analysis/critical_stiffness.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "analysis/optimize.hpp"
#include "world/integrator.hpp"

namespace hapticd::analysis {

namespace {

using cd = std::complex<double>;

/// [e^{Ah}, int_0^h e^{As} ds b]: the ZOH pair over h.
std::pair<Eigen::MatrixXd, Eigen::VectorXd> exp_and_integral(const Eigen::MatrixXd& a,
                                                             const Eigen::VectorXd& b, double h) {
  const world::DiscreteStateSpace d = world::discretize_zoh({a, b}, h);
  return {d.ad, d.bd.col(0)};
}

}  // namespace

DelayedZoh discretize_delayed_zoh(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, double period_s,
                                  double delay_s) {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) throw std::invalid_argument("period must be > 0");
  if (!(delay_s >= 0.0) || !(delay_s <= 1e6 * period_s)) {
    throw std::invalid_argument("delay must be >= 0 and at most 1e6 periods");
  }
  DelayedZoh d;
  d.period_s = period_s;
  double whole = std::floor(delay_s / period_s);
  double frac = delay_s - whole * period_s;
  if (frac > period_s * (1.0 - 1e-12)) {  // rounding just below a whole sample
    whole += 1.0;
    frac = 0.0;
  }
  if (frac < period_s * 1e-12) frac = 0.0;
  d.whole_samples = static_cast<int>(whole);
  d.fraction_s = frac;
  const auto [phi, gamma_full] = exp_and_integral(a, b, period_s);
  d.phi = phi;
  if (frac == 0.0) {
    d.gamma0 = gamma_full;
    d.gamma1 = Eigen::VectorXd::Zero(a.rows());
  } else {
    const auto [e_rest, g0] = exp_and_integral(a, b, period_s - frac);
    const auto [e_frac, g1] = exp_and_integral(a, b, frac);
    d.gamma0 = g0;
    d.gamma1 = e_rest * g1;
  }
  return d;
}

std::complex<double> frequency_response(const DelayedZoh& sys, const Eigen::RowVectorXd& c,
                                        double omega_rad_per_s) {
  const cd z = std::polar(1.0, omega_rad_per_s * sys.period_s);
  const Eigen::Index n = sys.phi.rows();
  const Eigen::MatrixXcd m = z * Eigen::MatrixXcd::Identity(n, n) - sys.phi.cast<cd>();
  const Eigen::VectorXcd rhs = sys.gamma0.cast<cd>() + sys.gamma1.cast<cd>() / z;
  const Eigen::VectorXcd x = m.partialPivLu().solve(rhs);
  return (c.cast<cd>() * x)(0) * std::pow(z, -sys.whole_samples);
}

std::vector<PhaseCrossover> phase_crossovers(const DelayedZoh& sys, const Eigen::RowVectorXd& c,
                                             double lowest_rad_per_s) {
  const double nyquist = std::numbers::pi / sys.period_s;
  const double start = lowest_rad_per_s > 0.0 ? lowest_rad_per_s : 1e-4 / sys.period_s;
  constexpr int points = 6000;
  const double ratio = std::pow(nyquist / start, 1.0 / (points - 1));
  std::vector<PhaseCrossover> out;
  auto h = [&](double w) { return frequency_response(sys, c, w); };

  cd prev = h(start);
  if (prev.real() < 0.0 && prev.imag() > 0.0) out.push_back({0.0, prev, 0.0});
  double w_prev = start;
  for (int i = 1; i < points; ++i) {
    const double w = i == points - 1 ? nyquist : start * std::pow(ratio, i);
    const cd cur = h(w);
    if (cur.imag() == 0.0 || (cur.imag() > 0.0) != (prev.imag() > 0.0)) {
      const double wc = cur.imag() == 0.0 ? w
                                          : bisect_sign_change([&](double x) { return h(x).imag(); }, w_prev,
                                                               w, prev.imag(), 1e-13 * w);
      const cd hc = h(wc);
      if (hc.real() < 0.0) out.push_back({wc, hc, -1.0 / hc.real()});
    }
    prev = cur;
    w_prev = w;
  }
  // z = -1: H is real there (up to rounding); the scan may miss a sign change.
  const cd hn = h(nyquist);
  const bool have_nyquist = !out.empty() && out.back().omega_rad_per_s > nyquist * (1.0 - 1e-9);
  if (hn.real() < 0.0 && !have_nyquist) out.push_back({nyquist, hn, -1.0 / hn.real()});
  return out;
}

namespace {

struct PlantModes {
  int at_zero = 0;  ///< poles at s = 0 (2: a free mass, no damping at all)
  double slowest = std::numeric_limits<double>::infinity();  ///< |pole| of the slowest other one, rad/s
};

PlantModes plant_modes(const Eigen::MatrixXd& a) {
  NumericRecord ignored;  // A was checked finite before
  const Spectrum s = spectrum("the plant's A", a, ignored);
  PlantModes m;
  for (const auto& p : s.eigenvalues) {
    // A double pole at 0 is computed only to ~sqrt(eps) of the largest.
    if (std::abs(p) <= std::sqrt(std::numeric_limits<double>::epsilon()) * s.radius) {
      ++m.at_zero;
    } else {
      m.slowest = std::min(m.slowest, std::abs(p));
    }
  }
  return m;
}

/// What makes H meaningless for this plant, recorded: non-finite A or B, a
/// wrong or too coarse ZOH (check_zoh), or a slow pole e^(lambda T) within
/// rounding of the integrator's z = 1: H near the crossover (~sqrt(lambda/T))
/// then carries no trace of the damping (scanned from below b/m, b = 1e-30
/// N s/m on 5.4 kg gave K_CR = 6e-10 N/m, a 1e300 kg mass 1e290 N/m; both are 2 b / T).
void check_plant(const world::LinearPlant& plant, double period_s, NumericRecord& record) {
  record.check_finite("the plant's A", plant.dynamics.a);
  record.check_finite("the plant's B", plant.dynamics.b);
  if (!record.clean()) return;
  const world::ContinuousStateSpace motor{plant.dynamics.a, plant.dynamics.b.col(world::motor_force_input)};
  check_zoh("the plant", motor, world::discretize_zoh(motor, period_s), record);
  const double slowest = plant_modes(plant.dynamics.a).slowest;
  if (std::isfinite(slowest)) {
    record.require(std::numeric_limits<double>::epsilon() / (slowest * period_s) <= 1e-6,
                   "the plant's slowest mode, " + short_number(slowest) +
                       " rad/s, moves its discrete pole by " + short_number(slowest * period_s) +
                       " per period: lost in rounding next to z = 1 (it needs 2.2e-10)");
  }
}

}  // namespace

CriticalStiffness critical_stiffness(const world::LinearPlant& plant, world::Sensor sensor, double period_s,
                                     double delay_s) {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) throw std::invalid_argument("period must be > 0");
  if (!(delay_s >= 0.0) || !(delay_s <= max_delay_periods * period_s)) {
    throw std::invalid_argument("delay must be 0 to " + std::to_string(max_delay_periods) + " periods");
  }
  CriticalStiffness k;
  NumericRecord& record = k.numerics;
  check_plant(plant, period_s, record);
  if (!record.clean()) return k;
  const DelayedZoh sys = discretize_delayed_zoh(
      plant.dynamics.a, plant.dynamics.b.col(world::motor_force_input), period_s, delay_s);
  record.check_finite("Gamma0", sys.gamma0);
  record.check_finite("Gamma1", sys.gamma1);
  const PlantModes modes = plant_modes(plant.dynamics.a);
  const double start = std::min(1e-4 / period_s, 1e-2 * modes.slowest);
  const auto crossovers =
      record.clean() ? phase_crossovers(sys, plant.position(sensor), start) : std::vector<PhaseCrossover>{};
  record.require(!crossovers.empty(), "no phase crossover of H(e^(j w T)) from " + short_number(start) +
                                          " rad/s to pi/T: no finite critical stiffness was found");
  if (!record.clean()) return k;
  record.require(crossovers.front().omega_rad_per_s > 0.0 || modes.at_zero >= 2,
                 "the phase is already past -180 deg at the lowest frequency scanned, " +
                     short_number(start) +
                     " rad/s, but the plant is damped: its crossover lies lower and K_CR is not 0");
  const PhaseCrossover* best = &crossovers.front();
  for (const auto& c : crossovers) {
    record.check_finite("-1 / H at a phase crossover", c.stiffness);
    if (c.stiffness < best->stiffness) best = &c;
  }
  k.k_cr = best->stiffness;
  k.crossover_rad_per_s = best->omega_rad_per_s;
  k.crossover_hz = best->omega_rad_per_s / (2.0 * std::numbers::pi);
  k.gain_margin_db = 20.0 * std::log10(best->stiffness);
  return k;
}

}  // namespace hapticd::analysis
