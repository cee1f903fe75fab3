#include "analysis/wall_stability.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

#include "analysis/optimize.hpp"
#include "world/text.hpp"

namespace hapticd::analysis {

namespace {

using cd = std::complex<double>;

const Polynomial stiffness_term{0.0, 1.0, 1.0};  // z (z + 1)
const Polynomial damping_term{-1.0, 0.0, 1.0};   // z^2 - 1

Polynomial mass_term(int d) {  // 2 z^{1+d} (z - 1)^2
  Polynomial p(static_cast<std::size_t>(d) + 4, 0.0);
  p[static_cast<std::size_t>(d) + 1] = 2.0;
  p[static_cast<std::size_t>(d) + 2] = -4.0;
  p[static_cast<std::size_t>(d) + 3] = 2.0;
  return p;
}

Polynomial reduced_mass_term(int d) {  // 2 z^{1+d} (z - 1) = mass_term / (z - 1)
  Polynomial p(static_cast<std::size_t>(d) + 3, 0.0);
  p[static_cast<std::size_t>(d) + 1] = -2.0;
  p[static_cast<std::size_t>(d) + 2] = 2.0;
  return p;
}

const Polynomial reduced_damping_term{1.0, 1.0};  // z + 1 = (z^2 - 1)/(z - 1)

void check_delay(int d) {
  if (d < 0) throw std::invalid_argument("delay_samples must be >= 0");
}

/// Eq. (3) on the unit circle is linear in (alpha, beta): the exact boundary
/// curve and its derivative in theta.
struct CurvePoint {
  double alpha, beta, dalpha, dbeta;
};

CurvePoint boundary_curve(double theta, int d) {
  const cd z = std::polar(1.0, theta);
  const Polynomial c = mass_term(d);
  const cd a = evaluate(stiffness_term, z);
  const cd b = evaluate(damping_term, z);
  Eigen::Matrix2d m;
  m << a.real(), b.real(), a.imag(), b.imag();
  const auto lu = m.partialPivLu();
  const cd cz = evaluate(c, z);
  const Eigen::Vector2d ab = lu.solve(Eigen::Vector2d(-cz.real(), -cz.imag()));
  const cd rhs = -(ab(0) * evaluate_derivative(stiffness_term, z) +
                   ab(1) * evaluate_derivative(damping_term, z) + evaluate_derivative(c, z)) *
                 cd(0.0, 1.0) * z;
  const Eigen::Vector2d dab = lu.solve(Eigen::Vector2d(rhs.real(), rhs.imag()));
  return {ab(0), ab(1), dab(0), dab(1)};
}

/// Hulin's figures: whole numbers from 1000 up (9000, not 9e+03), else 4 digits.
std::string format_number(double x) {
  namespace text = world::text;
  return std::abs(x) >= 1000.0 ? text::format_fixed(x, 0)
                               : text::format_significant(x, text::precision::summary);
}

std::string format_period(double t) {
  if (t < 1e-3) return format_number(t * 1e6) + " us";
  if (t < 1.0) return format_number(t * 1e3) + " ms";
  return format_number(t) + " s";
}

}  // namespace

Polynomial wall_characteristic_polynomial(double alpha, double beta, int delay_samples) {
  check_delay(delay_samples);
  return add_scaled(add_scaled(mass_term(delay_samples), alpha, stiffness_term), beta, damping_term);
}

std::vector<std::complex<double>> wall_poles(double alpha, double beta, int delay_samples) {
  return roots(wall_characteristic_polynomial(alpha, beta, delay_samples));
}

double pole_radius(double alpha, double beta, int delay_samples) {
  return root_radius(wall_characteristic_polynomial(alpha, beta, delay_samples));
}

bool wall_stable(double alpha, double beta, int delay_samples) {
  return pole_radius(alpha, beta, delay_samples) < 1.0;
}

double alpha_max(double beta, int delay_samples) {
  check_delay(delay_samples);
  const Polynomial p0 = add_scaled(mass_term(delay_samples), beta, damping_term);
  for (const Interval& i : stable_intervals(p0, stiffness_term, 0.0)) {
    if (i.lower == 0.0) return i.upper;
  }
  return 0.0;
}

double beta_max_at_zero_stiffness(int delay_samples) {
  check_delay(delay_samples);
  for (const Interval& i : stable_intervals(reduced_mass_term(delay_samples), reduced_damping_term, 0.0)) {
    if (i.lower == 0.0) return i.upper;
  }
  return 0.0;
}

std::vector<BoundaryPoint> stability_boundary(int delay_samples, int count) {
  const double top = beta_max_at_zero_stiffness(delay_samples);
  std::vector<BoundaryPoint> out;
  if (count <= 0) return out;
  out.reserve(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    const double beta = count == 1 ? 0.0 : top * i / (count - 1);
    out.push_back({beta, alpha_max(beta, delay_samples)});
  }
  return out;
}

BoundaryPoint max_stiffness_point(int delay_samples) {
  check_delay(delay_samples);
  const double top = beta_max_at_zero_stiffness(delay_samples);
  const Minimum m =
      grid_then_golden([&](double b) { return -alpha_max(b, delay_samples); }, 0.0, top, 16, 1e-10);
  BoundaryPoint best{m.x, -m.value};
  // Polish on the exact curve: find the boundary crossing at this beta and
  // bisect d alpha / d theta = 0 around it.
  const Polynomial p0 = add_scaled(mass_term(delay_samples), best.beta, damping_term);
  for (const UnitCircleCrossing& c : unit_circle_crossings(p0, stiffness_term)) {
    if (std::abs(c.t - best.alpha) > 1e-9 || c.theta <= 0.0 || c.theta >= 3.14159) continue;
    auto slope = [&](double th) { return boundary_curve(th, delay_samples).dalpha; };
    for (double h = 1e-7; h < 0.05; h *= 4.0) {
      double lo = std::max(c.theta - h, 1e-9), hi = std::min(c.theta + h, 3.14159);
      double slo = slope(lo);
      if ((slo > 0.0) == (slope(hi) > 0.0)) continue;
      while (hi - lo > 1e-15) {
        const double mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi) break;
        const double sm = slope(mid);
        if ((sm > 0.0) == (slo > 0.0)) {
          lo = mid;
          slo = sm;
        } else {
          hi = mid;
        }
      }
      const CurvePoint p = boundary_curve(0.5 * (lo + hi), delay_samples);
      if (p.alpha >= best.alpha - 1e-12 && std::abs(p.beta - best.beta) < 1e-6) best = {p.beta, p.alpha};
      break;
    }
    break;
  }
  return best;
}

std::optional<Interval> stable_damping_range(double alpha, int delay_samples) {
  check_delay(delay_samples);
  if (alpha == 0.0) {
    const double top = beta_max_at_zero_stiffness(delay_samples);
    if (top > 0.0) return Interval{0.0, top};
    return std::nullopt;
  }
  const Polynomial p0 = add_scaled(mass_term(delay_samples), alpha, stiffness_term);
  // Negative damping is not physical; start the family at beta = 0.
  const auto pieces = stable_intervals(p0, damping_term, 0.0);
  if (pieces.empty()) return std::nullopt;
  return pieces.front();
}

std::optional<MinimumRadiusPoint> minimum_radius_damping(double alpha, int delay_samples) {
  const auto range = stable_damping_range(alpha, delay_samples);
  if (!range || !std::isfinite(range->upper)) return std::nullopt;
  const Minimum m = grid_then_golden([&](double b) { return pole_radius(alpha, b, delay_samples); },
                                     range->lower, range->upper, 40, 1e-11);
  return MinimumRadiusPoint{alpha, m.x, m.value};
}

MinimumRadiusPoint minimum_radius_point(int delay_samples) {
  const double top = max_stiffness_point(delay_samples).alpha;
  auto radius = [&](double a) {
    const auto p = minimum_radius_damping(a, delay_samples);
    return p ? p->radius : 1.0;
  };
  const Minimum m = grid_then_golden(radius, 0.0, top, 40, 1e-10);
  return *minimum_radius_damping(m.x, delay_samples);
}

WallVerdict analyze_wall(double mass_kg, double period_s, int delay_samples,
                         std::optional<double> stiffness_n_per_m, std::optional<double> damping_n_s_per_m) {
  const double k = stiffness_n_per_m.value_or(0.0);
  const double b = damping_n_s_per_m.value_or(0.0);
  if (!(mass_kg > 0.0) || !std::isfinite(mass_kg)) throw std::invalid_argument("mass must be > 0");
  if (!(period_s > 0.0) || !std::isfinite(period_s)) throw std::invalid_argument("period must be > 0");
  check_delay(delay_samples);
  if (!(k >= 0.0) || !std::isfinite(k)) throw std::invalid_argument("stiffness must be finite and >= 0");
  if (!(b >= 0.0) || !std::isfinite(b)) throw std::invalid_argument("damping must be finite and >= 0");

  WallVerdict v;
  v.mass_kg = mass_kg;
  v.period_s = period_s;
  v.delay_samples = delay_samples;
  v.stiffness = k;
  v.damping = b;
  v.alpha = normalized_stiffness(k, mass_kg, period_s);
  v.beta = normalized_damping(b, mass_kg, period_s);
  NumericRecord record;
  record.check_finite("alpha = K T^2 / m", v.alpha);
  record.check_finite("beta = B T / m", v.beta);
  // Companion-matrix roots are exact for coefficients perturbed by eps times
  // their norm: past 1e-7 of the mass term's 2 they no longer describe the device.
  const auto rounding = [](double sum) {
    return 32.0 * std::numeric_limits<double>::epsilon() * (2.0 + sum);
  };
  const auto resolvable = [&](double sum) {
    return std::isfinite(sum) && rounding(sum) <= max_radius_tolerance;
  };
  record.require(resolvable(v.alpha + v.beta),
                 "alpha = " + short_number(v.alpha) + ", beta = " + short_number(v.beta) +
                     ": the mass term 2 z^(1+d) (z-1)^2 of Hulin eq. (3) is lost in their rounding");
  v.pole_radius = std::numeric_limits<double>::quiet_NaN();
  if (record.clean()) {
    // alpha = 0: the drift root z = 1 is not an instability of the wall: divide it out.
    const Polynomial p = v.alpha == 0.0
                             ? add_scaled(reduced_mass_term(delay_samples), v.beta, reduced_damping_term)
                             : wall_characteristic_polynomial(v.alpha, v.beta, delay_samples);
    const auto poles = roots(p);
    record.check_finite("the roots of Hulin eq. (3)", poles);
    v.pole_radius = 0.0;
    for (const auto& z : poles) v.pole_radius = std::max(v.pole_radius, std::abs(z));
  }
  v.verdict = judge_radius(v.pole_radius, rounding(v.alpha + v.beta), period_s, record);
  const BoundaryPoint top = max_stiffness_point(delay_samples);
  v.alpha_max = top.alpha;
  v.beta_at_alpha_max = top.beta;
  v.k_max = physical_stiffness(top.alpha, mass_kg, period_s);
  v.b_at_k_max = physical_damping(top.beta, mass_kg, period_s);
  v.beta_max_at_zero_stiffness = beta_max_at_zero_stiffness(delay_samples);
  v.b_max_at_zero_stiffness = physical_damping(v.beta_max_at_zero_stiffness, mass_kg, period_s);
  // The limits at the requested damping (stiffness) only where its own term is resolvable.
  if (resolvable(v.beta)) {
    v.alpha_max_for_damping = alpha_max(v.beta, delay_samples);
    v.k_max_for_damping = physical_stiffness(v.alpha_max_for_damping, mass_kg, period_s);
  }
  if (resolvable(v.alpha)) {
    if (const auto range = stable_damping_range(v.alpha, delay_samples)) {
      v.damping_range = Interval{physical_damping(range->lower, mass_kg, period_s),
                                 physical_damping(range->upper, mass_kg, period_s)};
    }
  }
  return v;
}

std::string refusal_message(const WallVerdict& v) {
  if (v.stable()) return {};
  if (!v.verdict.assessed()) {
    return "K = " + format_number(v.stiffness) + " N/m with B = " + format_number(v.damping) +
           " N s/m on m = " + format_number(v.mass_kg) + " kg, T = " + format_period(v.period_s) +
           " cannot be assessed: " + v.verdict.reason;
  }
  std::string s = "K = " + format_number(v.stiffness) + " N/m with B = " + format_number(v.damping) +
                  " N s/m is outside the stable region for m = " + format_number(v.mass_kg) +
                  " kg, T = " + format_period(v.period_s) + ", d = " + std::to_string(v.delay_samples) +
                  " (pole radius " + format_number(v.pole_radius) + "): ";
  if (v.alpha_max_for_damping > 0.0) {
    s += "the largest stable K for B = " + format_number(v.damping) + " N s/m is " +
         format_number(v.k_max_for_damping) + " N/m";
  } else {
    s += "no stiffness is stable with B = " + format_number(v.damping) + " N s/m (B must be below " +
         format_number(v.b_max_at_zero_stiffness) + " N s/m and above 0)";
  }
  if (v.damping_range) {
    s += "; K = " + format_number(v.stiffness) + " N/m is stable for B between " +
         format_number(v.damping_range->lower) + " and " + format_number(v.damping_range->upper) + " N s/m";
  } else {
    s += "; no damping stabilizes K = " + format_number(v.stiffness) + " N/m: the largest stable K is " +
         format_number(v.k_max) + " N/m, at B = " + format_number(v.b_at_k_max) + " N s/m";
  }
  return s;
}

}  // namespace hapticd::analysis
