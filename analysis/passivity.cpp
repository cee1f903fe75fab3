#include "analysis/passivity.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace hapticd::analysis {

namespace {

constexpr double pi = std::numbers::pi;
constexpr double eps = std::numeric_limits<double>::epsilon();

/// theta = w T in [0, pi]: 4096 steps, or 64 per period of cos(d theta).
std::vector<double> linear_grid(int delay_samples) {
  const int n = std::max(4096, 64 * (delay_samples + 1));
  std::vector<double> grid(static_cast<std::size_t>(n) + 1);
  for (int i = 0; i <= n; ++i) grid[static_cast<std::size_t>(i)] = pi * i / n;
  grid.back() = pi;
  return grid;
}

struct Candidate {
  double theta = 0.0;
  double value = -std::numeric_limits<double>::infinity();
};

/// The supremum over [grid.front(), grid.back()] = [0, pi] of a function
/// known on the grid (`values`), with value(theta) and slope(theta) (its
/// closed-form derivative, 0 at both ends: the function is even about 0 and
/// pi). Every strict local maximum of the grid is refined by bisecting the
/// slope's sign change in the bracket of its two neighbours; the grid value
/// stands if the refinement is not better. Ties (to 1e-13) keep the lowest
/// frequency.
template <typename Value, typename Slope>
Candidate refine_supremum(const std::vector<double>& grid, const std::vector<double>& values, Value&& value,
                          Slope&& slope) {
  Candidate best{grid.front(), values.front()};
  const auto consider = [&](double theta, double v) {
    if (v > best.value + 1e-13 * std::abs(best.value)) best = {theta, v};
  };
  for (std::size_t i = 1; i + 1 < grid.size(); ++i) {
    if (!(values[i] > values[i - 1] && values[i] >= values[i + 1])) continue;
    Candidate local{grid[i], values[i]};
    double lo = grid[i - 1], hi = grid[i + 1];
    if (slope(lo) >= 0.0 && slope(hi) <= 0.0) {
      for (int k = 0; k < 200; ++k) {
        const double mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi) break;
        const double g = slope(mid);
        if (g == 0.0) {
          lo = hi = mid;
          break;
        }
        (g > 0.0 ? lo : hi) = mid;
      }
      const double theta = 0.5 * (lo + hi);
      const double v = value(theta);
      if (v > local.value) local = {theta, v};
    }
    consider(local.theta, local.value);
  }
  consider(grid.back(), values.back());
  return best;
}

/// 1 + 2 sum_{k=1..d} cos k theta (the Dirichlet kernel), each cosine direct.
double dirichlet(double theta, int d) {
  double sum = 1.0;
  for (int k = 1; k <= d; ++k) sum += 2.0 * std::cos(k * theta);
  return sum;
}
double dirichlet_slope(double theta, int d) {
  double sum = 0.0;
  for (int k = 1; k <= d; ++k) sum -= 2.0 * k * std::sin(k * theta);
  return sum;
}

/// The wall's two cosine sums on the grid (by the Chebyshev recurrence
/// cos (k+1) t = 2 cos t cos k t - cos (k-1) t: only for bracketing; the
/// refined values use direct cosines).
class WallKernel {
 public:
  explicit WallKernel(int d) : d_(d), grid_(linear_grid(d)) {
    dirichlet_.resize(grid_.size());
    cos_next_.resize(grid_.size());
    for (std::size_t i = 0; i < grid_.size(); ++i) {
      const double c = std::cos(grid_[i]);
      double previous = 1.0, current = c, sum = 1.0;
      for (int k = 1; k <= d_; ++k) {
        sum += 2.0 * current;
        const double next = 2.0 * c * current - previous;
        previous = current;
        current = next;
      }
      dirichlet_[i] = sum;
      cos_next_[i] = current;  // cos((d+1) theta)
    }
  }

  WallSupremum supremum(double s, double b) const {
    std::vector<double> values(grid_.size());
    for (std::size_t i = 0; i < grid_.size(); ++i) values[i] = s * dirichlet_[i] - b * cos_next_[i];
    const int d = d_;
    const auto value = [&](double t) { return s * dirichlet(t, d) - b * std::cos((d + 1) * t); };
    const auto slope = [&](double t) {
      if (t <= 0.0 || t >= pi) return 0.0;
      return s * dirichlet_slope(t, d) + b * (d + 1) * std::sin((d + 1) * t);
    };
    const Candidate c = refine_supremum(grid_, values, value, slope);
    return {c.value, c.theta};
  }

 private:
  int d_;
  std::vector<double> grid_;
  std::vector<double> dirichlet_;
  std::vector<double> cos_next_;
};

PassivityBound not_assessed(std::string reason) {
  PassivityBound b;
  b.state = PassivityState::cannot_assess;
  b.reason = std::move(reason);
  return b;
}

PassivityBound bounded_at(double required, double theta, double period_s) {
  PassivityBound b;
  b.state = PassivityState::bounded;
  b.reason.clear();
  b.required_damping = required;
  b.frequency_hz = theta / (2.0 * pi * period_s);
  b.at_zero_frequency_limit = theta == 0.0;
  return b;
}

void check_period_and_delay(double period_s, int delay_samples, NumericRecord& record) {
  record.check_finite("the period T", period_s);
  record.require(!(period_s <= 0.0), "the period T = " + short_number(period_s) + " s must be > 0");
  record.require(delay_samples >= 0 && delay_samples <= max_passivity_delay_samples,
                 "the delay d = " + std::to_string(delay_samples) + " samples must be 0 to " +
                     std::to_string(max_passivity_delay_samples));
}

void check_non_negative(std::string_view what, double value, std::string_view unit, NumericRecord& record) {
  record.check_finite(what, value);
  record.require(!(value < 0.0), std::string(what) + " = " + short_number(value) + " " + std::string(unit) +
                                     " is negative: it must be >= 0");
}

// ---------------------------------------------------------------------------
// Any linear scene: H(z) = -z^-d (C (zI - A)^-1 B + D).

class TransferKernel {
 public:
  TransferKernel(const world::DiscreteLinearScene& scene, int delay, double period_s)
      : a_(scene.a), b_(scene.b), c_(scene.c), d_(scene.d(0, 0)), delay_(delay), half_t_(period_s / 2.0) {}

  /// f(theta) of (CS), with q = Im H / sin(theta) computed without a division.
  double value(double theta) const { return evaluate(theta).value; }

  /// f'(theta) = (T/2) [Re H' + cot(theta/2) (q - Im H')], H' = dH/dtheta.
  double slope(double theta) const {
    if (theta <= 0.0 || theta >= pi) return 0.0;
    const Evaluation e = evaluate(theta);
    const std::complex<double> z = std::polar(1.0, theta);
    std::complex<double> g = d_, g_prime = 0.0;
    const Eigen::Index q = a_.rows();
    if (q > 0) {
      const Eigen::MatrixXcd m = z * Eigen::MatrixXcd::Identity(q, q) - a_.cast<std::complex<double>>();
      const Eigen::PartialPivLU<Eigen::MatrixXcd> lu(m);
      const Eigen::VectorXcd x = lu.solve(b_.cast<std::complex<double>>());
      g += (c_.cast<std::complex<double>>() * x)(0, 0);
      g_prime = -(c_.cast<std::complex<double>>() * lu.solve(x))(0, 0);  // G'(z) = -C (zI-A)^-2 B
    }
    const std::complex<double> j(0.0, 1.0);
    const std::complex<double> zd = std::polar(1.0, -delay_ * theta);
    const std::complex<double> h_theta = -zd * (-j * static_cast<double>(delay_) * g + j * z * g_prime);
    const double cot_half = (1.0 + std::cos(theta)) / std::sin(theta);
    return half_t_ * (h_theta.real() + cot_half * (e.q - h_theta.imag()));
  }

 private:
  struct Evaluation {
    double value = 0.0;
    double q = 0.0;  ///< Im H / sin theta
  };

  Evaluation evaluate(double theta) const {
    const double c = std::cos(theta), s = std::sin(theta);
    double re_g = d_, im_g_over_s = 0.0;
    const Eigen::Index q = a_.rows();
    if (q > 0) {
      // (zI - A)^-1 = (M - j s I) P^-1, M = c I - A, P = M^2 + s^2 I (M and P commute).
      const Eigen::MatrixXd m = c * Eigen::MatrixXd::Identity(q, q) - a_;
      const Eigen::MatrixXd p = m * m + s * s * Eigen::MatrixXd::Identity(q, q);
      const Eigen::VectorXd y = p.partialPivLu().solve(b_);
      im_g_over_s = -(c_ * y)(0, 0);
      re_g += (c_ * (m * y))(0, 0);
    }
    // sin(d theta) / sin(theta) = U_{d-1}(c), Chebyshev of the second kind.
    double u_previous = 0.0, u = 1.0;  // U_{-1}, U_0
    for (int k = 1; k < delay_; ++k) {
      const double next = 2.0 * c * u - u_previous;
      u_previous = u;
      u = next;
    }
    const double u_delay = delay_ == 0 ? 0.0 : u;
    const double cos_dt = std::cos(delay_ * theta), sin_dt = std::sin(delay_ * theta);
    // z^-d G: real part, and imaginary part over sin(theta); H = -z^-d G.
    const double re_h = -(cos_dt * re_g + sin_dt * s * im_g_over_s);
    const double q_h = -(cos_dt * im_g_over_s - u_delay * re_g);
    return {half_t_ * (re_h - (1.0 + c) * q_h), q_h};
  }

  Eigen::MatrixXd a_, b_, c_;
  double d_;
  int delay_;
  double half_t_;
};

/// Smallest singular value of a complex matrix.
double smallest_singular_value(const Eigen::MatrixXcd& m) {
  const Eigen::JacobiSVD<Eigen::MatrixXcd> svd(m);
  const auto& s = svd.singularValues();
  return s.size() == 0 ? 0.0 : s(s.size() - 1);
}

/// The eigenvalues of a that are poles of H: controllable from b and
/// observable in c (Popov-Belevitch-Hautus rank tests on [lambda I - a; c]
/// and [lambda I - a, b], each block scaled to unit size, to 1e-9).
struct Poles {
  std::vector<std::complex<double>> poles;
  double spectral_radius = 0.0;  ///< of a, all modes
};
Poles transfer_poles(const world::DiscreteLinearScene& scene, NumericRecord& record) {
  const Spectrum modes = spectrum("the scene's state matrix a", scene.a, record);
  Poles out;
  if (!record.clean()) return out;
  out.spectral_radius = modes.radius;
  const Eigen::Index q = scene.a.rows();
  if (q == 0) return out;  // H = -z^-d D: no poles
  const double b_size = scene.b.cwiseAbs().maxCoeff(), c_size = scene.c.cwiseAbs().maxCoeff();
  if (b_size == 0.0 || c_size == 0.0) return out;
  const double a_size = 1.0 + scene.a.cwiseAbs().maxCoeff();
  const Eigen::MatrixXcd a = scene.a.cast<std::complex<double>>() / a_size;
  for (const std::complex<double>& lambda : modes.eigenvalues) {
    const Eigen::MatrixXcd shifted = lambda / a_size * Eigen::MatrixXcd::Identity(q, q) - a;
    Eigen::MatrixXcd observe(q + 1, q);
    observe << shifted, scene.c.cast<std::complex<double>>() / c_size;
    Eigen::MatrixXcd control(q, q + 1);
    control << shifted, scene.b.cast<std::complex<double>>() / b_size;
    if (smallest_singular_value(observe) > 1e-9 && smallest_singular_value(control) > 1e-9)
      out.poles.push_back(lambda);
  }
  return out;
}

/// Drops the states nothing reads: state i with c(i) = 0 whose column of a
/// is zero off the diagonal feeds neither the output nor another state (the
/// virtual body's position when k = 0). What is left has no such mode, so
/// (zI - a) is not singular on the unit circle because of it.
world::DiscreteLinearScene without_unread_states(world::DiscreteLinearScene m) {
  for (Eigen::Index i = m.a.rows() - 1; i >= 0; --i) {
    bool unread = m.c(0, i) == 0.0;
    for (Eigen::Index r = 0; r < m.a.rows() && unread; ++r) unread = r == i || m.a(r, i) == 0.0;
    if (!unread) continue;
    const Eigen::Index q = m.a.rows();
    std::vector<Eigen::Index> keep;
    for (Eigen::Index k = 0; k < q; ++k)
      if (k != i) keep.push_back(k);
    world::DiscreteLinearScene reduced;
    reduced.a = m.a(keep, keep);
    reduced.b = m.b(keep, Eigen::all);
    reduced.c = m.c(Eigen::all, keep);
    reduced.d = m.d;
    reduced.output_delay_samples = m.output_delay_samples;
    return without_unread_states(std::move(reduced));
  }
  return m;
}

/// The linear grid plus points crowding each pole's angle (its resonance is
/// about 1 - |p| wide) and log-spaced points near theta = 0.
std::vector<double> transfer_grid(int delay, const std::vector<std::complex<double>>& poles) {
  std::vector<double> grid = linear_grid(delay);
  for (int i = 0; i <= 48; ++i) grid.push_back(std::pow(10.0, -9.0 + 6.0 * i / 48.0));
  for (const std::complex<double>& p : poles) {
    const double phi = std::abs(std::arg(p));
    const double width = std::max(1.0 - std::abs(p), 1e-15);
    grid.push_back(phi);
    for (double offset = width / 16.0; offset < 0.05; offset *= 1.5) {
      grid.push_back(phi - offset);
      grid.push_back(phi + offset);
    }
  }
  std::erase_if(grid, [](double t) { return !(t >= 0.0 && t <= pi); });
  std::sort(grid.begin(), grid.end());
  grid.erase(std::unique(grid.begin(), grid.end()), grid.end());
  return grid;
}

std::string hz_text(double theta, double period_s) { return short_number(theta / (2.0 * pi * period_s)); }

/// Unbounded when the largest pole of H is on or outside the unit circle
/// (judge_radius with the integrators' tolerance); nothing when inside.
std::optional<PassivityBound> unbounded_by_poles(const std::vector<std::complex<double>>& poles,
                                                 double spectral_radius, double period_s,
                                                 const NumericRecord& record) {
  std::complex<double> largest = 0.0;
  for (const auto& p : poles)
    if (std::abs(p) > std::abs(largest)) largest = p;
  const double tolerance = 1e-12 + 64.0 * eps * std::max(1.0, spectral_radius);
  const Verdict v = judge_radius(std::abs(largest), tolerance, period_s, record, "the scene's matrices");
  if (!v.assessed()) return not_assessed(v.reason);
  if (v.state == VerdictState::stable) return std::nullopt;
  const double theta = std::abs(std::arg(largest));
  PassivityBound b;
  b.state = PassivityState::unbounded;
  b.required_damping = std::numeric_limits<double>::infinity();
  b.frequency_hz = theta / (2.0 * pi * period_s);
  b.reason = v.marginal() ? "not passive at any device damping: the virtual body's undamped mode at " +
                                hz_text(theta, period_s) + " Hz (pole on the unit circle)"
                          : "not passive at any device damping: the virtual body is unstable (pole radius " +
                                short_number(std::abs(largest)) + " at " + hz_text(theta, period_s) +
                                " Hz): it generates energy by itself";
  return b;
}

}  // namespace

std::string_view to_string(PassivityState state) noexcept {
  switch (state) {
    case PassivityState::bounded:
      return "bounded";
    case PassivityState::unbounded:
      return "unbounded";
    case PassivityState::cannot_assess:
      return "cannot_assess";
  }
  return "cannot_assess";
}

WallSupremum wall_supremum(double stiffness_term, double damping_term, int delay_samples) {
  return WallKernel(delay_samples).supremum(stiffness_term, damping_term);
}

PassivityBound wall_passivity(double stiffness, double damping, double period_s, int delay_samples) {
  NumericRecord record;
  check_non_negative("the stiffness K", stiffness, "N/m", record);
  check_non_negative("the damping B", damping, "N s/m", record);
  check_period_and_delay(period_s, delay_samples, record);
  if (!record.clean()) return not_assessed(record.reason());
  const double s = stiffness * period_s / 2.0;
  record.check_finite("K T / 2", s);
  if (!record.clean()) return not_assessed(record.reason());
  const WallSupremum w = wall_supremum(s, damping, delay_samples);
  record.check_finite("the required damping", w.value);
  if (!record.clean()) return not_assessed(record.reason());
  return bounded_at(w.value, w.theta, period_s);
}

double wall_max_stiffness_term(double damping_term, double device_term, int delay_samples) {
  if (!(device_term > damping_term) || !std::isfinite(device_term) || !std::isfinite(damping_term))
    return 0.0;
  const WallKernel kernel(delay_samples);
  const double n = 2.0 * delay_samples + 1.0;
  // f <= s (2d+1) + B everywhere and f(0) = s (2d+1) - B: the root is in [lo, hi].
  // Newton from hi: the supremum is convex in s, so its tangent lies below it
  // and every iterate stays at or above the root (lo only guards rounding).
  double lo = (device_term - damping_term) / n, hi = (device_term + damping_term) / n;
  double s = hi;
  for (int i = 0; i < 100; ++i) {
    const WallSupremum w = kernel.supremum(s, damping_term);
    const double excess = w.value - device_term;
    (excess > 0.0 ? hi : lo) = s;
    if (std::abs(excess) <= 1e-15 * device_term) return s;
    // The supremum's slope in s: the Dirichlet kernel where it is reached (envelope); > 0 there.
    const double slope = dirichlet(w.theta, delay_samples);
    double next = slope > 0.0 ? s - excess / slope : 0.5 * (lo + hi);
    if (!(next >= lo && next <= hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - s) <= 1e-15 * s) return excess > 0.0 ? next : s;
    s = next;
  }
  return lo;
}

PassivityVerdict analyze_wall_passivity(double stiffness, double damping, double period_s, int delay_samples,
                                        std::optional<double> device_damping) {
  PassivityVerdict v;
  v.bound = wall_passivity(stiffness, damping, period_s, delay_samples);
  v.device_damping = device_damping;
  if (!device_damping || !v.bound.assessed()) return v;
  NumericRecord record;
  check_non_negative("the device damping b", *device_damping, "N s/m", record);
  if (!record.clean()) {
    v.bound = not_assessed(record.reason());
    return v;
  }
  v.passive = v.bound.bounded() && *device_damping >= v.bound.required_damping;
  v.max_stiffness = 2.0 * wall_max_stiffness_term(damping, *device_damping, delay_samples) / period_s;
  return v;
}

double passive_alpha_max(double beta, double device_beta, int delay_samples) {
  return 2.0 * wall_max_stiffness_term(beta, device_beta, delay_samples);
}

std::vector<PassivityBoundaryPoint> passivity_boundary(double device_beta, int delay_samples, int count) {
  std::vector<PassivityBoundaryPoint> out;
  if (!(device_beta > 0.0) || !std::isfinite(device_beta) || count < 2) return out;
  out.push_back({0.0, passive_alpha_max(0.0, device_beta, delay_samples)});
  const int logged = count - 1;  // the last one at device_beta, where alpha reaches 0
  for (int i = 0; i < logged; ++i) {
    const double fraction = logged == 1 ? 1.0 : static_cast<double>(i) / (logged - 1);
    const double beta = i == logged - 1 ? device_beta : device_beta * std::pow(1e-4, 1.0 - fraction);
    out.push_back({beta, passive_alpha_max(beta, device_beta, delay_samples)});
  }
  return out;
}

PassivityBound scene_passivity(const world::DiscreteLinearScene& scene, double period_s,
                               int extra_delay_samples) {
  NumericRecord record;
  const int delay = scene.output_delay_samples + extra_delay_samples;
  check_period_and_delay(period_s, delay, record);
  record.require(scene.d.rows() == 1 && scene.d.cols() == 1 && scene.b.cols() == 1 && scene.c.rows() == 1 &&
                     scene.b.rows() == scene.a.rows() && scene.c.cols() == scene.a.rows() &&
                     scene.a.rows() == scene.a.cols(),
                 "the scene's linear model is not a single-input single-output system");
  if (!record.clean()) return not_assessed(record.reason());
  record.check_finite("the scene's matrix b", scene.b);
  record.check_finite("the scene's matrix c", scene.c);
  record.check_finite("the scene's matrix d", scene.d);
  record.check_finite("the scene's state matrix a", scene.a);
  if (!record.clean()) return not_assessed(record.reason());
  const world::DiscreteLinearScene model = without_unread_states(scene);
  const Poles poles = transfer_poles(model, record);
  if (!record.clean()) return not_assessed(record.reason());
  if (auto unbounded = unbounded_by_poles(poles.poles, poles.spectral_radius, period_s, record))
    return *unbounded;

  const TransferKernel kernel(model, delay, period_s);
  const std::vector<double> grid = transfer_grid(delay, poles.poles);
  std::vector<double> values(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) {
    values[i] = kernel.value(grid[i]);
    record.check_finite("the required damping at " + hz_text(grid[i], period_s) + " Hz", values[i]);
    if (!record.clean()) return not_assessed(record.reason());
  }
  const Candidate best = refine_supremum(
      grid, values, [&](double t) { return kernel.value(t); }, [&](double t) { return kernel.slope(t); });
  record.check_finite("the required damping", best.value);
  if (!record.clean()) return not_assessed(record.reason());
  return bounded_at(best.value, best.theta, period_s);
}

namespace {

template <world::SpringDamping D>
world::DiscreteLinearScene spring_model(const world::SpringParameters& p, double period_s) {
  return world::SpringScene<D>(p, period_s).linear_model();
}

}  // namespace

PassivityBound spring_passivity(const SpringPassivityInput& input) {
  NumericRecord record;
  world::SpringParameters p = input.parameters;
  check_non_negative("the stiffness k", p.stiffness, "N/m", record);
  record.check_finite("the inertia J", p.inertia);
  record.require(!(p.inertia <= 0.0), "the inertia J = " + short_number(p.inertia) + " must be > 0");
  check_period_and_delay(input.period_s, input.delay_samples, record);
  if (input.damping_auto) p.damping = input.period_s * p.stiffness;
  check_non_negative("the damping b", p.damping, "N s/m", record);
  if (!record.clean()) return not_assessed(record.reason());
  world::DiscreteLinearScene model;
  try {
    if (p.damping == 0.0) {
      model = spring_model<world::SpringDamping::none>(p, input.period_s);
    } else if (input.reference == world::SpringDamping::absolute) {
      model = spring_model<world::SpringDamping::absolute>(p, input.period_s);
    } else {
      model = spring_model<world::SpringDamping::relative>(p, input.period_s);
    }
  } catch (const std::exception& e) {
    return not_assessed(std::string("the spring scene cannot be built: ") + e.what());
  }
  return scene_passivity(model, input.period_s, input.delay_samples);
}

PassivityVerdict analyze_spring_passivity(const SpringPassivityInput& input,
                                          std::optional<double> device_damping) {
  PassivityVerdict v;
  v.bound = spring_passivity(input);
  v.device_damping = device_damping;
  if (!device_damping || !v.bound.assessed()) return v;
  NumericRecord record;
  check_non_negative("the device damping b", *device_damping, "N s/m", record);
  if (!record.clean()) {
    v.bound = not_assessed(record.reason());
    return v;
  }
  const double b = *device_damping;
  v.passive = v.bound.bounded() && b >= v.bound.required_damping;
  const auto passive_at = [&](double k) {
    SpringPassivityInput trial = input;
    trial.parameters.stiffness = k;
    const PassivityBound bound = spring_passivity(trial);
    return bound.bounded() && b >= bound.required_damping;
  };
  // Log scan, 4 per decade from 1e-3 to 1e9, then geometric bisection.
  constexpr int steps = 48;
  const auto k_at = [](int i) { return 1e-3 * std::pow(10.0, i / 4.0); };
  int first_failure = -1;
  for (int i = 0; i <= steps && first_failure < 0; ++i)
    if (!passive_at(k_at(i))) first_failure = i;
  if (first_failure < 0) {
    v.max_stiffness = k_at(steps);
    v.max_stiffness_at_range_top = true;
  } else if (first_failure > 0) {
    double lo = k_at(first_failure - 1), hi = k_at(first_failure);
    while (hi - lo > 1e-9 * hi) {
      const double mid = std::sqrt(lo * hi);
      if (mid <= lo || mid >= hi) break;
      (passive_at(mid) ? lo : hi) = mid;
    }
    v.max_stiffness = lo;
  }
  return v;
}

}  // namespace hapticd::analysis
