#include "analysis/two_mass.hpp"

#include <cmath>

#include "analysis/optimize.hpp"

namespace hapticd::analysis {

namespace {

Polynomial multiply(const Polynomial& a, const Polynomial& b) {
  Polynomial r(a.size() + b.size() - 1, 0.0);
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j) r[i + j] += a[i] * b[j];
  return r;
}

Polynomial body_polynomial(const world::TwoMassPlant& p) {  // p_d, eq. (8)
  return {p.cable_stiffness, p.body_damping + p.cable_damping, p.body_mass};
}

Polynomial motor_polynomial(const world::TwoMassPlant& p) {  // p_m, eq. (9)
  return {p.cable_stiffness, p.motor_damping + p.cable_damping, p.motor_mass};
}

}  // namespace

ResonanceParameters resonance_parameters(const world::TwoMassPlant& p) {
  ResonanceParameters r;
  const double m = p.total_mass();
  const double b = p.total_damping();
  r.omega_1 = std::sqrt(p.cable_stiffness / p.motor_mass);
  r.omega_2 = std::sqrt(p.cable_stiffness / p.body_mass);
  r.omega_n = std::sqrt(p.cable_stiffness * m / (p.body_mass * p.motor_mass));
  r.z_1 = (p.motor_damping + p.cable_damping) / p.motor_mass;
  r.z_2 = (p.body_damping + p.cable_damping) / p.body_mass;
  r.z_n = r.z_1 + r.z_2 - b / m;
  r.q = p.motor_mass * r.z_n * r.omega_n;
  r.q_db = 20.0 * std::log10(r.q);
  r.numerics.check_finite("omega_1 = sqrt(k_c / m_m)", r.omega_1);
  r.numerics.check_finite("omega_2 = sqrt(k_c / m_d)", r.omega_2);
  r.numerics.check_finite("omega_n = sqrt(k_c m / (m_d m_m))", r.omega_n);
  r.numerics.check_finite("z_n = z_1 + z_2 - b / m", r.z_n);
  r.numerics.check_finite("Q = m_m z_n omega_n", r.q);
  r.numerics.check_finite("20 log10(Q)", r.q_db);
  return r;
}

Polynomial two_mass_denominator(const world::TwoMassPlant& p) {
  const Polynomial coupling{p.cable_stiffness, p.cable_damping};
  return add_scaled(multiply(body_polynomial(p), motor_polynomial(p)), -1.0, multiply(coupling, coupling));
}

Polynomial two_mass_factored_denominator(const world::TwoMassPlant& p) {
  const ResonanceParameters r = resonance_parameters(p);
  const double m = p.total_mass();
  const Polynomial rigid{0.0, p.total_damping(), m};
  const Polynomial mode{r.omega_n * r.omega_n, r.z_n, 1.0};
  Polynomial d = multiply(rigid, mode);
  for (double& c : d) c *= p.body_mass * p.motor_mass / m;
  return d;
}

std::complex<double> motor_transfer(const world::TwoMassPlant& p, std::complex<double> s) {
  return evaluate(body_polynomial(p), s) / evaluate(two_mass_denominator(p), s);
}

std::optional<ResonantPeak> resonant_peak(const world::TwoMassPlant& p) {
  const ResonanceParameters modes = resonance_parameters(p);
  if (!modes.assessed()) return std::nullopt;
  const double wn = modes.omega_n;
  const double lo = 0.5 * wn, hi = 2.0 * wn;
  auto neg_mag = [&](double w) { return -std::abs(motor_transfer(p, {0.0, w})); };
  const Minimum m = grid_then_golden(neg_mag, lo, hi, 200, 1e-9 * wn);
  const double step = (hi - lo) / 201.0;
  if (m.x < lo + step || m.x > hi - step) return std::nullopt;
  ResonantPeak peak;
  peak.omega_rad_per_s = m.x;
  peak.distance = -1.0 / m.value;
  peak.distance_db = 20.0 * std::log10(peak.distance);
  if (!std::isfinite(peak.distance_db)) return std::nullopt;
  return peak;
}

std::optional<bool> rigid_model_suffices(const ResonanceParameters& modes, const CriticalStiffness& k) {
  if (!modes.assessed() || !k.assessed()) return std::nullopt;
  return modes.q >= k.k_cr;
}

}  // namespace hapticd::analysis
