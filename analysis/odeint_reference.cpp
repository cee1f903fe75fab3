#include "analysis/odeint_reference.hpp"

#include <array>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <stdexcept>

#include "analysis/accuracy_tracker.hpp"

namespace hapticd::analysis {

namespace {

namespace odeint = boost::numeric::odeint;
using State = std::array<double, 2>;

/// e'' = G - 2 sigma e' - w_n^2 e with u = e / L, v = e' / (w_n L):
/// u' = w_n v, v' = G / (w_n L) - 2 sigma v - w_n u.
struct Body {
  double wn = 1.0;
  double two_sigma = 0.0;
  double g = 0.0;  ///< G / (w_n L)
  void operator()(const State& x, State& dxdt, double /*t*/) const {
    dxdt[0] = wn * x[1];
    dxdt[1] = g - two_sigma * x[1] - wn * x[0];
  }
};

struct Problem {
  SecondOrderStep reference;
  double length = 1.0;  ///< L
  Body body;            ///< held forcing only
  Body pulsed;          ///< with the pulse, over [0, tp)
  State start{};
};

Problem make_problem(const AccuracyCase& c, double period_s) {
  Problem p;
  p.reference = reference_problem(c, period_s);
  const SecondOrderStep& r = p.reference;
  const double wn = r.natural_frequency;
  p.length = std::abs(r.initial) + std::abs(r.forcing) / (wn * wn);
  if (!(p.length > 0.0)) throw std::invalid_argument("accuracy case has no step");
  p.body = {wn, 2.0 * r.decay, r.forcing / (wn * p.length)};
  p.pulsed = p.body;
  p.pulsed.g += r.pulse / (wn * p.length);
  p.start = {r.initial / p.length, 0.0};
  return p;
}

/// Calls observe(n, output) for n = 0 .. last with the RK4 solution;
/// stops when observe returns false. Returns the periods observed.
template <class Observe>
long integrate_rk4(const AccuracyCase& c, const Problem& p, double t, long last, Observe&& observe) {
  odeint::runge_kutta4<State> stepper;
  State x = p.start;
  const double wn = p.reference.natural_frequency;
  const bool pulse = p.reference.pulse != 0.0 && p.reference.pulse_width > 0.0;
  for (long n = 0; n <= last; ++n) {
    if (!observe(n, detail::output_law(c, p.length * x[0], wn * p.length * x[1], n, t))) return n + 1;
    stepper.do_step(n == 0 && pulse ? p.pulsed : p.body, x, static_cast<double>(n) * t, t);
  }
  return last + 1;
}

template <class Observe>
long integrate_dopri5(const AccuracyCase& c, const Problem& p, double tolerance, double t, long last,
                      long& steps, Observe&& observe) {
  const double wn = p.reference.natural_frequency;
  const auto out = [&](const State& x, long n) {
    return detail::output_law(c, p.length * x[0], wn * p.length * x[1], n, t);
  };
  const double dt0 = 1e-3 / wn;
  State x = p.start;
  long n = 0;
  double start = 0.0;
  if (p.reference.pulse != 0.0 && p.reference.pulse_width > 0.0) {
    if (!observe(0, out(x, 0))) return 1;
    Body pulsed = p.pulsed;
    steps += static_cast<long>(odeint::integrate_adaptive(
        odeint::make_controlled(tolerance, tolerance, odeint::runge_kutta_dopri5<State>()), pulsed, x, 0.0,
        p.reference.pulse_width, std::min(dt0, p.reference.pulse_width)));
    n = 1;
    start = p.reference.pulse_width;
  }
  auto stepper = odeint::make_dense_output(tolerance, tolerance, odeint::runge_kutta_dopri5<State>());
  stepper.initialize(x, start, dt0);
  Body body = p.body;
  bool stepped = false;
  State at{};
  for (; n <= last; ++n) {
    const double tn = static_cast<double>(n) * t;
    while (stepper.current_time() < tn) {
      stepper.do_step(body);
      stepped = true;
      ++steps;
    }
    if (stepped) {
      stepper.calc_state(tn, at);
    } else {
      at = x;  // still at the start: nothing to interpolate yet
    }
    if (!observe(n, out(at, n))) return n + 1;
  }
  return last + 1;
}

}  // namespace

RunResult run_odeint(const AccuracyCase& c, const Method& method, const RunOptions& options,
                     StudyProgress& progress) {
  const bool rk4 = method.kind == Method::Kind::odeint_rk4;
  if (!rk4 && method.kind != Method::Kind::odeint_dopri5) throw std::invalid_argument("not an Odeint method");
  if (!rk4 && !(method.tolerance > 0.0)) throw std::invalid_argument("dopri5 needs a tolerance > 0");
  RunResult result;
  detail::ErrorTracker tracker(c, options, result);
  const Problem problem = make_problem(c, options.period_s);
  const double t = options.period_s;
  const long last = tracker.last();
  long steps = 0;
  const auto compare = [&](long n, double output) { return tracker.observe(n, output); };
  const long observed = rk4 ? integrate_rk4(c, problem, t, last, compare)
                            : integrate_dopri5(c, problem, method.tolerance, t, last, steps, compare);
  tracker.finish(observed);
  progress.advance(static_cast<double>(last + 1));

  // Timing: the same integration, the observer only keeps the output.
  std::array<double, 256> ring{};
  const auto keep = [&](long n, double output) {
    ring[static_cast<std::size_t>(n) & 255u] = output;
    return true;
  };
  // Repeated until 2 ms of CPU time, for the clock's resolution (1 us).
  long timed = 0;
  double cpu = 0.0;
  for (int repetition = 0; repetition < 1000 && cpu < 2e-3; ++repetition) {
    long ignored = 0;
    const double begin = progress.clock()();
    timed += rk4 ? integrate_rk4(c, problem, t, last, keep)
                 : integrate_dopri5(c, problem, method.tolerance, t, last, ignored, keep);
    cpu += progress.clock()() - begin;
  }
  volatile double sink = 0.0;
  for (const double v : ring) sink = sink + v;
  progress.advance(static_cast<double>(last + 1));

  result.solver_steps = rk4 ? observed - 1 : steps;
  result.cpu_s_per_step = cpu / static_cast<double>(timed);
  result.cpu_s_per_simulated_s = result.cpu_s_per_step / t;
  result.stable = discretization_stable(c, method, t);
  return result;
}

}  // namespace hapticd::analysis
