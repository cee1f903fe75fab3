#include "analysis/accuracy_study.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "analysis/accuracy_tracker.hpp"
#include "analysis/closed_loop.hpp"
#include "analysis/integrator_stability.hpp"
#include "analysis/non_finite.hpp"
#include "world/scene_catalog.hpp"
#include "world/units.hpp"

namespace hapticd::analysis {

namespace {

using non_finite::inf;
using non_finite::nan;

constexpr std::array<std::string_view, 5> scene_names{"spring-wheel", "spring-wheel-absolute",
                                                      "spring-wheel-relative", "spring-mass", "wall"};

}  // namespace

std::string_view to_string(AccuracyScene scene) noexcept {
  return scene_names[static_cast<std::size_t>(scene)];
}

std::optional<AccuracyScene> parse_accuracy_scene(std::string_view name) noexcept {
  for (const AccuracyScene s : all_accuracy_scenes) {
    if (to_string(s) == name) return s;
  }
  return std::nullopt;
}

AccuracyCase default_case(AccuracyScene scene, double device_period_s) {
  namespace d = world::scene_defaults;
  AccuracyCase c;
  c.scene = scene;
  switch (scene) {
    case AccuracyScene::spring_wheel:
    case AccuracyScene::spring_wheel_absolute:
    case AccuracyScene::spring_wheel_relative:
      c.stiffness = d::wheel_stiffness;
      c.inertia = d::wheel_inertia;
      c.step = world::units::deg_to_rad(d::wheel_max_angle_deg);
      if (scene != AccuracyScene::spring_wheel) c.damping = device_period_s * c.stiffness;  // 2.24
      break;
    case AccuracyScene::spring_mass:
      c.stiffness = d::mass_stiffness;
      c.inertia = d::mass_mass;
      c.step = 0.01;
      break;
    case AccuracyScene::wall:
      c.stiffness = d::wall_stiffness;
      c.damping = d::wall_damping;
      c.delay_samples = d::hulin_delay_samples;
      c.device = world::RigidPlant{d::hulin_mass, 0.0};
      c.step = 1.0;
      break;
  }
  return c;
}

double natural_frequency(const AccuracyCase& c) {
  return std::sqrt(c.stiffness / (has_integrator(c.scene) ? c.inertia : c.device.mass));
}

double damping_ratio(const AccuracyCase& c) {
  if (has_integrator(c.scene)) return c.damping / (2.0 * std::sqrt(c.stiffness * c.inertia));
  return (c.damping + c.device.damping) / (2.0 * std::sqrt(c.stiffness * c.device.mass));
}

AccuracyCase at_normalized_frequency(const AccuracyCase& c, double wn_t, double period_s) {
  const double zeta = damping_ratio(c);
  const double wn = wn_t / period_s;
  AccuracyCase out = c;
  if (has_integrator(c.scene)) {
    out.stiffness = c.inertia * wn * wn;
    out.damping = 2.0 * zeta * std::sqrt(out.stiffness * c.inertia);
  } else {
    out.stiffness = c.device.mass * wn * wn;
    out.damping = std::max(0.0, 2.0 * zeta * std::sqrt(out.stiffness * c.device.mass) - c.device.damping);
  }
  return out;
}

bool detail::relative_damping(const AccuracyCase& c) {
  return has_integrator(c.scene) && c.damping != 0.0 && c.scene != AccuracyScene::spring_wheel_absolute;
}

SecondOrderStep reference_problem(const AccuracyCase& c, double period_s) {
  SecondOrderStep r;
  r.natural_frequency = natural_frequency(c);
  if (has_integrator(c.scene)) {
    // e = w - z0: e'' + (b/J) e' + (k/J) e = (b/J) v(t), e(0) = -z0.
    r.decay = c.damping / (2.0 * c.inertia);
    r.initial = -c.step;
    if (detail::relative_damping(c)) {
      r.pulse = c.damping / c.inertia * c.step / period_s;
      r.pulse_width = period_s;
    }
  } else {
    // x = penetration: m x'' + (B + b) x' + K x = F_h, x(0) = 0.
    r.decay = (c.damping + c.device.damping) / (2.0 * c.device.mass);
    r.forcing = c.step / c.device.mass;
  }
  return r;
}

double detail::output_law(const AccuracyCase& c, double e, double e_dot, long n, double period_s) {
  if (!has_integrator(c.scene)) return -c.stiffness * e - c.damping * e_dot;
  if (!relative_damping(c)) return c.stiffness * e;
  const double measured_velocity = n == 0 ? c.step / period_s : 0.0;
  return c.stiffness * e + c.damping * (e_dot - measured_velocity);
}

double reference_output(const AccuracyCase& c, const SecondOrderStep& reference, long n, double period_s) {
  const double t = static_cast<double>(n) * period_s;
  const double e = reference.position(t);
  const double e_dot = has_integrator(c.scene) && !detail::relative_damping(c) ? 0.0 : reference.velocity(t);
  return detail::output_law(c, e, e_dot, n, period_s);
}

double output_scale(const AccuracyCase& c) {
  return has_integrator(c.scene) ? c.stiffness * std::abs(c.step) : std::abs(c.step);
}

std::string Method::name() const {
  switch (kind) {
    case Kind::integrator:
      return std::string(world::to_string(integrator));
    case Kind::sampled_wall:
      return "sampled-wall";
    case Kind::odeint_rk4:
      return "odeint-rk4";
    case Kind::odeint_dopri5:
      return "odeint-dopri5";
  }
  return "?";
}

std::string Method::label() const {
  if (kind != Kind::odeint_dopri5) return name();
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, " tol=%.0e", tolerance);
  return name() + buffer;
}

bool discretization_stable(const AccuracyCase& c, const Method& method, double period_s) {
  try {
    if (method.kind == Method::Kind::integrator) {
      return analyze_integrator({c.stiffness, c.inertia, c.damping, period_s, method.integrator}).stable();
    }
    if (method.kind == Method::Kind::odeint_rk4) {
      // Odeint's RK4 on the continuous problem is our rk4 on the same body.
      const SecondOrderStep r = reference_problem(c, period_s);
      const double wn = r.natural_frequency;
      return analyze_integrator({wn * wn, 1.0, 2.0 * r.decay, period_s, world::Integrator::rk4}).stable();
    }
    if (method.kind == Method::Kind::sampled_wall) {
      return analyze_closed_loop(c.device.model(), world::Sensor::motor,
                                 detail::wall_linear_model(c, period_s), period_s)
          .stable();
    }
  } catch (const std::exception&) {
    return false;  // a verdict that cannot be formed is not "stable"
  }
  return true;
}

double stability_limit(const AccuracyCase& c, const Method& method, double period_s) {
  const auto stable_at = [&](double h) {
    return discretization_stable(at_normalized_frequency(c, h, period_s), method, period_s);
  };
  constexpr int per_decade = 16;
  double previous = 0.0;
  for (int i = 0; i <= 6 * per_decade; ++i) {
    const double h = 1e-3 * std::pow(10.0, static_cast<double>(i) / per_decade);
    if (stable_at(h)) {
      previous = h;
      continue;
    }
    if (i == 0) return 0.0;
    double lo = previous;
    double hi = h;
    for (int k = 0; k < 60 && hi / lo > 1.0 + 1e-12; ++k) {
      const double mid = std::sqrt(lo * hi);
      (stable_at(mid) ? lo : hi) = mid;
    }
    return lo;
  }
  return inf;
}

namespace {

/// max over [0, theta] of x |f(x)|: a scan, then golden section around the best point.
template <class F>
double max_weighted(F&& f, double theta) {
  const auto g = [&](double x) { return x * std::abs(f(x)); };
  constexpr int n = 20000;
  double best_x = 0.0;
  for (int i = 1; i <= n; ++i) {
    const double x = theta * i / n;
    if (g(x) > g(best_x)) best_x = x;
  }
  double a = std::max(0.0, best_x - theta / n);
  double b = std::min(theta, best_x + theta / n);
  for (int i = 0; i < 100; ++i) {
    const double m1 = b - 0.6180339887498949 * (b - a);
    const double m2 = a + 0.6180339887498949 * (b - a);
    if (g(m1) > g(m2)) {
      b = m2;
    } else {
      a = m1;
    }
  }
  return std::max(g(best_x), g(0.5 * (a + b)));
}

}  // namespace

double ErrorLaw::at(double h) const { return order == 0 ? 0.0 : constant * std::pow(h, order); }

ErrorLaw leading_error_law(world::Integrator integrator, double theta) {
  const auto cosine = [](double x) { return std::cos(x); };
  const auto sine = [](double x) { return std::sin(x); };
  switch (integrator) {
    case world::Integrator::forward_euler:
      return {1, 0.5 * max_weighted(cosine, theta)};
    case world::Integrator::semi_implicit_euler:
      return {1, 0.5};
    case world::Integrator::trapezoid:
      return {2, max_weighted(sine, theta) / 12.0};
    case world::Integrator::rk4:
      return {4, max_weighted(sine, theta) / 120.0};
    case world::Integrator::exact:
      return {0, 0.0};
  }
  return {};
}

ErrorLaw wall_error_law(const AccuracyCase& c) {
  if (!(c.damping > 0.0)) return {};
  return {1, (c.delay_samples + 0.5) * c.damping / (c.device.mass * natural_frequency(c))};
}

std::vector<double> log_grid(double from, double to, int per_decade) {
  if (!(from > 0.0) || !(to >= from) || per_decade < 1) throw std::invalid_argument("log_grid: bad range");
  const int n = std::max(1, static_cast<int>(std::ceil(std::log10(to / from) * per_decade - 1e-9)));
  std::vector<double> out;
  for (int i = 0; i <= n; ++i) out.push_back(from * std::pow(to / from, static_cast<double>(i) / n));
  out.back() = to;
  return out;
}

AccuracyStudyOptions default_accuracy_options(double device_period_s) {
  AccuracyStudyOptions o;
  for (const AccuracyScene s : all_accuracy_scenes) o.cases.push_back(default_case(s, device_period_s));
  o.periods_s = {20e-6, 50e-6, 100e-6, 200e-6, 500e-6, 1e-3, 2e-3, 5e-3, 10e-3};
  o.device_period_s = device_period_s;
  o.wn_t = log_grid(1e-3, std::numbers::pi, 8);
  return o;
}

namespace {

std::vector<Method> scene_methods(const AccuracyCase& c, const AccuracyStudyOptions& o) {
  std::vector<Method> out;
  if (has_integrator(c.scene)) {
    for (const world::Integrator i : o.integrators) out.push_back({Method::Kind::integrator, i, 0.0});
  } else {
    out.push_back({Method::Kind::sampled_wall, world::Integrator::exact, 0.0});
  }
  return out;
}

long periods_in(double duration_s, double period_s) { return std::lround(duration_s / period_s) + 1; }

double sweep_duration(const AccuracyCase& c, const AccuracyStudyOptions& o) {
  return o.sweep_cycles * 2.0 * std::numbers::pi / natural_frequency(c);
}

/// Work units (compared outputs) of the whole study, for the progress bar.
double planned_units(const AccuracyStudyOptions& o) {
  const double duration = o.durations_s.back();
  double units = 0.0;
  for (const AccuracyCase& c : o.cases) {
    const double methods = static_cast<double>(scene_methods(c, o).size()) + (o.odeint ? 2.0 : 0.0);
    for (const double t : o.periods_s) units += methods * static_cast<double>(periods_in(duration, t));
    if (o.odeint) {
      units += 2.0 * static_cast<double>(o.tolerances.size() * periods_in(duration, o.device_period_s));
    }
    for (const double h : o.wn_t) {
      const AccuracyCase ch = at_normalized_frequency(c, h, o.device_period_s);
      units += static_cast<double>(scene_methods(c, o).size() *
                                   periods_in(sweep_duration(ch, o), o.device_period_s));
    }
  }
  return units;
}

/// The derived leading error of the w_n T sweep, where there is one
/// (undamped spring scenes; the damped wall).
ErrorLaw predicted_law(const AccuracyCase& c, const Method& m, const AccuracyStudyOptions& o) {
  if (m.kind == Method::Kind::sampled_wall) return wall_error_law(c);
  if (m.kind == Method::Kind::integrator && c.damping == 0.0) {
    return leading_error_law(m.integrator, 2.0 * std::numbers::pi * o.sweep_cycles);
  }
  return {};
}

void fit_orders(AccuracyStudy& study, const AccuracyCase& c) {
  // The exact integrator's (or the smallest) error is the rounding floor.
  double floor = 1e-15;
  for (const SweepRow& r : study.sweep) {
    if (r.scene == c.scene && r.method.kind == Method::Kind::integrator &&
        r.method.integrator == world::Integrator::exact && std::isfinite(r.error)) {
      floor = std::max(floor, r.error);
    }
  }
  for (const Method& m : scene_methods(c, study.options)) {
    if (m.kind == Method::Kind::integrator && m.integrator == world::Integrator::exact) continue;
    OrderFit fit{c.scene, m, 0, nan, nan, {}};
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    std::vector<const SweepRow*> used;
    for (const SweepRow& r : study.sweep) {
      if (r.scene != c.scene || r.method.label() != m.label()) continue;
      if (!(r.wn_t <= 0.05) || !(r.error > 1e3 * floor) || !(r.error < 3e-2)) continue;
      const double x = std::log(r.wn_t), y = std::log(r.error);
      sx += x, sy += y, sxx += x * x, sxy += x * y;
      used.push_back(&r);
    }
    fit.points = static_cast<int>(used.size());
    if (fit.points >= 3) {
      const double n = fit.points;
      fit.order = (n * sxy - sx * sy) / (n * sxx - sx * sx);
      fit.predicted = predicted_law(c, m, study.options);
      const int p = fit.predicted.order > 0 ? fit.predicted.order : static_cast<int>(std::lround(fit.order));
      double sum = 0.0;
      for (const SweepRow* r : used) sum += r->error / std::pow(r->wn_t, p);
      fit.constant = sum / n;
    }
    study.orders.push_back(fit);
  }
}

}  // namespace

AccuracyStudy run_accuracy_study(const AccuracyStudyOptions& options, StudyProgress& progress) {
  if (options.durations_s.empty() || options.cases.empty())
    throw std::invalid_argument("empty accuracy study");
  AccuracyStudy study;
  study.options = options;
  progress.plan(planned_units(options));
  const double device_t = options.device_period_s;

  for (const AccuracyCase& c : options.cases) {
    const std::string scene(to_string(c.scene));
    std::vector<Method> methods = scene_methods(c, options);
    if (options.odeint) methods.push_back({Method::Kind::odeint_rk4, world::Integrator::rk4, 0.0});
    // Figure 1 (and figure 2 from the runs at the device period).
    for (const Method& m : methods) {
      for (const double t : options.periods_s) {
        progress.stage(scene + " " + m.label() + " T = " + std::to_string(t * 1e6) + " us");
        RunOptions ro{t, options.durations_s, t == device_t ? 10 : 0, options.timing_steps};
        study.work_precision.push_back(
            {c.scene, m, t, natural_frequency(c) * t, run_method(c, m, ro, progress)});
        if (t == device_t) study.growth.push_back({c.scene, m, t, study.work_precision.back().run});
      }
    }
    if (options.odeint) {
      for (const double tol : options.tolerances) {
        const Method m{Method::Kind::odeint_dopri5, world::Integrator::rk4, tol};
        progress.stage(scene + " " + m.label());
        RunOptions ro{device_t, options.durations_s, 10, options.timing_steps};
        study.work_precision.push_back(
            {c.scene, m, device_t, natural_frequency(c) * device_t, run_method(c, m, ro, progress)});
        if (std::find(options.growth_tolerances.begin(), options.growth_tolerances.end(), tol) !=
            options.growth_tolerances.end()) {
          study.growth.push_back({c.scene, m, device_t, study.work_precision.back().run});
        }
      }
    }
    // Figure 3: w_n T at the device period, damping ratio held.
    for (const Method& m : scene_methods(c, options)) {
      progress.stage(scene + " " + m.label() + " w_n T sweep");
      for (const double h : options.wn_t) {
        const AccuracyCase ch = at_normalized_frequency(c, h, device_t);
        RunOptions ro{device_t, {sweep_duration(ch, options)}, 0, 0};
        const RunResult r = run_method(ch, m, ro, progress);
        const ErrorLaw law = predicted_law(c, m, options);
        study.sweep.push_back({c.scene, m, h, r.errors.back(), law.order > 0 ? law.at(h) : nan, r.stable});
      }
      study.limits.push_back({c.scene, m, stability_limit(c, m, device_t)});
    }
    fit_orders(study, c);
  }
  return study;
}

}  // namespace hapticd::analysis
