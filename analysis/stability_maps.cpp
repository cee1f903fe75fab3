#include "analysis/stability_maps.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include "analysis/critical_stiffness.hpp"
#include "analysis/integrator_stability.hpp"
#include "analysis/optimize.hpp"
#include "analysis/passivity.hpp"
#include "analysis/wall_stability.hpp"

namespace hapticd::analysis {

double discrete_damping_ratio(double alpha, double beta, int delay_samples) {
  double worst = 1.0;
  for (const std::complex<double>& z : wall_poles(alpha, beta, delay_samples)) {
    const double r = std::abs(z);
    if (!(r > 0.0)) continue;  // z = 0: fully damped
    const double log_r = std::log(r);
    const double theta = std::abs(std::arg(z));
    const double norm = std::hypot(log_r, theta);
    if (norm > 0.0) worst = std::min(worst, -log_r / norm);
  }
  return worst;
}

std::optional<MaximumDampingPoint> maximum_damping_beta(double alpha, int delay_samples) {
  const auto range = stable_damping_range(alpha, delay_samples);
  if (!range) return std::nullopt;
  const double upper = std::isfinite(range->upper) ? range->upper : range->lower + 10.0;
  const Minimum m =
      grid_then_golden([&](double b) { return -discrete_damping_ratio(alpha, b, delay_samples); },
                       range->lower, upper, 60, 1e-10);
  return MaximumDampingPoint{alpha, m.x, -m.value};
}

WallRegionMap wall_region_map(int max_delay, int points, StudyProgress& progress) {
  WallRegionMap map;
  progress.plan(static_cast<double>((max_delay + 1) * 3));
  for (int d = 0; d <= max_delay; ++d) {
    progress.stage("wall region d = " + std::to_string(d));
    const double top = beta_max_at_zero_stiffness(d);
    // Half the points log-spaced from top * 1e-4 to top / 2, half crowding
    // toward top (top - beta log-spaced down to 1e-6 top), where alpha_max
    // falls steeply to 0.
    const int half = points / 2;
    for (int i = 0; i < half; ++i) {
      const double beta = top * 0.5 * std::pow(2e-4, 1.0 - static_cast<double>(i) / half);
      map.boundary.push_back({d, beta, alpha_max(beta, d)});
    }
    for (int i = 0; i <= points - half; ++i) {
      const double beta = top * (1.0 - 0.5 * std::pow(2e-6, static_cast<double>(i) / (points - half)));
      map.boundary.push_back({d, beta, alpha_max(beta, d)});
    }
    progress.advance(1);
    const BoundaryPoint best = max_stiffness_point(d);
    map.maximum_stiffness.push_back({d, best.beta, best.alpha});
    for (int i = 0; i < points; ++i) {
      const double alpha =
          best.alpha * std::pow(1e-4, 1.0 - static_cast<double>(i) / (points - 1)) * (1.0 - 1e-6);
      if (const auto p = minimum_radius_damping(alpha, d))
        map.minimum_radius_path.push_back({d, p->beta, alpha});
    }
    progress.advance(1);
    for (int i = 0; i < points; ++i) {
      const double alpha =
          best.alpha * std::pow(1e-4, 1.0 - static_cast<double>(i) / (points - 1)) * (1.0 - 1e-6);
      if (const auto p = maximum_damping_beta(alpha, d))
        map.maximum_damping_path.push_back({d, p->beta, alpha});
    }
    progress.advance(1);
  }
  return map;
}

std::vector<WallMapPoint> passivity_region_map(double device_beta, int max_delay, int points) {
  std::vector<WallMapPoint> out;
  if (!(device_beta > 0.0) || points < 2) return out;
  for (int d = 0; d <= max_delay; ++d) {
    // As the stability boundary: half log-spaced up to device_beta / 2, half
    // crowding toward device_beta, where the passive alpha falls to 0.
    const int half = points / 2;
    for (int i = 0; i < half; ++i) {
      const double beta = device_beta * 0.5 * std::pow(2e-4, 1.0 - static_cast<double>(i) / half);
      out.push_back({d, beta, passive_alpha_max(beta, device_beta, d)});
    }
    for (int i = 0; i < points - half; ++i) {
      const double beta =
          device_beta * (1.0 - 0.5 * std::pow(2e-6, static_cast<double>(i) / std::max(1, points - half - 1)));
      const double alpha = passive_alpha_max(beta, device_beta, d);
      if (alpha > 0.0) out.push_back({d, beta, alpha});
    }
  }
  return out;
}

namespace {

bool integrator_stable(world::Integrator integrator, double wn_t, double zeta) {
  // A unit inertia and period: only w_n T and zeta matter.
  const SpringScene scene{wn_t * wn_t, 1.0, 2.0 * zeta * wn_t, 1.0, integrator};
  try {
    return analyze_integrator(scene).stable();
  } catch (const std::exception&) {
    return false;
  }
}

}  // namespace

std::vector<IntegratorRegionRow> integrator_region_map(const std::vector<world::Integrator>& integrators,
                                                       int per_decade, StudyProgress& progress) {
  std::vector<double> zetas{0.0};
  for (int i = 0; i <= 8 * 8; ++i) zetas.push_back(1e-5 * std::pow(10.0, i / 8.0));
  const int n = 6 * per_decade;
  progress.plan(static_cast<double>(integrators.size()) * (n + 1));
  std::vector<IntegratorRegionRow> rows;
  for (const world::Integrator integrator : integrators) {
    progress.stage(std::string("integrator region ") + std::string(world::to_string(integrator)));
    for (int i = 0; i <= n; ++i) {
      const double h = 1e-3 * std::pow(10.0, static_cast<double>(i) / per_decade);
      const auto stable = [&](double zeta) { return integrator_stable(integrator, h, zeta); };
      const auto edge = [&](double lo, double hi, bool lo_stable) {
        // Bisection (geometric once lo > 0) to 1e-9 relative.
        for (int k = 0; k < 100 && hi - lo > 1e-9 * hi; ++k) {
          const double mid = lo > 0.0 ? std::sqrt(lo * hi) : 0.5 * (lo + hi);
          (stable(mid) == lo_stable ? lo : hi) = mid;
        }
        return 0.5 * (lo + hi);
      };
      bool inside = stable(zetas[0]);
      double lower = 0.0;
      for (std::size_t j = 1; j < zetas.size(); ++j) {
        const bool now = stable(zetas[j]);
        if (now == inside) continue;
        const double at = edge(zetas[j - 1], zetas[j], inside);
        if (now) {
          lower = at;
        } else {
          rows.push_back({integrator, h, lower, at});
        }
        inside = now;
      }
      if (inside) rows.push_back({integrator, h, lower, std::numeric_limits<double>::infinity()});
      progress.advance(1);
    }
  }
  return rows;
}

std::vector<CriticalStiffnessRow> critical_stiffness_curves(double period_s, double max_delay_s,
                                                            double step_s, StudyProgress& progress) {
  const world::TwoMassPlant two_mass;
  const world::RigidPlant rigid{two_mass.total_mass(), two_mass.total_damping()};
  struct Curve {
    std::string name;
    world::LinearPlant plant;
    world::Sensor sensor;
  };
  const Curve curves[] = {{"rigid", rigid.model(), world::Sensor::motor},
                          {"two-mass", two_mass.model(), world::Sensor::motor},
                          {"two-mass", two_mass.model(), world::Sensor::body}};
  const int n = static_cast<int>(std::lround(max_delay_s / step_s));
  progress.plan(3.0 * (n + 1));
  std::vector<CriticalStiffnessRow> rows;
  for (const Curve& c : curves) {
    progress.stage("critical stiffness " + c.name + " " + std::string(world::to_string(c.sensor)));
    for (int i = 0; i <= n; ++i) {
      const double td = i * step_s;
      CriticalStiffnessRow row{c.name, c.sensor, td, std::numeric_limits<double>::quiet_NaN(),
                               std::numeric_limits<double>::quiet_NaN()};
      try {
        const CriticalStiffness k = critical_stiffness(c.plant, c.sensor, period_s, td);
        if (k.assessed()) {
          row.k_cr = k.k_cr;
          row.crossover_hz = k.crossover_hz;
        }
      } catch (const std::exception&) {
        // a delay beyond the analysis' range: no K_CR (NaN)
      }
      rows.push_back(row);
      progress.advance(1);
    }
  }
  return rows;
}

double rigid_critical_stiffness_jury(double mass, double damping, double period_s) {
  const double c = damping / mass;
  const double a = std::exp(-c * period_s);
  const double one_minus_a = -std::expm1(-c * period_s);  // keeps its digits for small bT/m
  const double n0 = (one_minus_a - c * period_s * a) / (mass * c * c);
  return one_minus_a / n0;
}

}  // namespace hapticd::analysis
