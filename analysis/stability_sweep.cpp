#include "analysis/stability_sweep.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>

#include "analysis/closed_loop.hpp"
#include "analysis/non_finite.hpp"
#include "analysis/wall_stability.hpp"
#include "world/any_scene.hpp"
#include "world/integrator.hpp"

namespace hapticd::analysis {

namespace {

using non_finite::inf;
using non_finite::nan;

/// |r - 1| within which a case is marginal (issue 12), and the distance from
/// z = 1 within which a released pole is the rigid-body drift.
constexpr double marginal_band = 1e-6;
constexpr double drift_band = 1e-6;

// ---------------------------------------------------------------- prediction

struct Prediction {
  bool assessed = false;
  double radius = nan;
  double angle = 0.0;  ///< |arg| of the dominant pole, rad per period
  std::string reason;  ///< why not assessed
};

Prediction predict(const SweepCase& c, const world::ScenePlan& plan) {
  Prediction p;
  if (!plan.linear) {
    p.reason = "no linear model";
    return p;
  }
  // The same spectra, and the same rule for "not computable", as the gate.
  if (!std::isfinite(c.device.mass) || !std::isfinite(c.device.damping)) {
    p.reason = "the device's mass or damping is not finite";
    return p;
  }
  std::vector<std::complex<double>> poles;
  if (c.mode == SweepMode::held) {
    NumericRecord record;
    poles = spectrum("the scene's state matrix", plan.linear->a, record).eigenvalues;
    if (!record.clean()) {
      p.reason = record.reason();
      return p;
    }
  } else {
    try {
      const ClosedLoopVerdict closed = analyze_closed_loop(c.device.plant, c.device.sensor, *plan.linear,
                                                           c.device.period_s, c.device.delay_samples);
      if (!closed.verdict.assessed()) {
        p.reason = closed.verdict.reason;
        return p;
      }
      poles = closed.eigenvalues;
    } catch (const std::exception& e) {
      p.reason = e.what();
      return p;
    }
  }
  for (const auto& z : poles) {
    if (!std::isfinite(z.real()) || !std::isfinite(z.imag())) {
      p.reason = "a pole is not finite";
      return p;
    }
  }
  // A spring released on a rigid device keeps the rigid-body translation:
  // one pole at z = 1 (two, a Jordan pair, without friction). It moves
  // device and virtual body together, so the run's relative coordinate does
  // not see it; any other pole near 1 is a real slow mode and stays.
  std::size_t drift = 0;
  if (c.mode == SweepMode::released && c.scene != "wall" && c.device.plant.dynamics.a.rows() == 2) {
    drift = c.device.damping > 0.0 ? 1 : 2;
  }
  std::sort(poles.begin(), poles.end(),
            [](const auto& a, const auto& b) { return std::abs(a - 1.0) < std::abs(b - 1.0); });
  p.radius = 0.0;
  for (std::size_t i = 0; i < poles.size(); ++i) {
    if (i < drift && std::abs(poles[i] - 1.0) < drift_band) continue;
    if (std::abs(poles[i]) > p.radius) {
      p.radius = std::abs(poles[i]);
      p.angle = std::abs(std::arg(poles[i]));
    }
  }
  p.assessed = true;
  return p;
}

// ---------------------------------------------------------------- the run

/// Periods watched from a NaN/Inf measurement on.
constexpr long fault_window = 64;

/// Largest |x| over blocks of `size` periods.
struct Envelope {
  long size = 4;
  std::vector<double> block_max;
  double current = 0.0;
  long filled = 0;
  void add(double deviation) {
    current = std::max(current, deviation);
    if (++filled == size) {
      block_max.push_back(current);
      current = 0.0;
      filled = 0;
    }
  }
};

struct RunOutcome {
  long periods = 0;
  Envelope envelope;
  double first = nan;  ///< first deviation (fallback when there are too few blocks)
  double last = nan;
  long last_n = 0;
  double peak_force = 0.0;
  bool hit_floor = false;
  std::string note;
  long nonfinite_outputs = 0;
  long first_nonfinite = -1;
};

double sensed_position(const world::LinearPlant& plant, world::Sensor sensor, const Eigen::VectorXd& x) {
  return plant.position(sensor).dot(x);
}

/// Deviation limits of a run: it stops above `upper` (overflow, or the wall
/// about to lose contact) and below `floor` (rounding of the equilibrium).
struct Room {
  double start = 1.0;
  double upper = 1e250;
  double floor = 1e-250;
};

class Run {
 public:
  Run(const SweepCase& c, const world::ScenePlan& plan, long periods, long block)
      : c_(c), plan_(plan), periods_(periods) {
    out_.envelope.size = block;
  }

  RunOutcome go() {
    if (c_.mode == SweepMode::held) {
      held();
    } else if (c_.scene == "wall") {
      wall();
    } else {
      released_spring();
    }
    return out_;
  }

 private:
  double fault_offset(long n) const {
    if (c_.fault == MeasurementFault::encoder_jump && n >= n0())
      return c_.fault_counts * c_.encoder_resolution;
    if (c_.fault == MeasurementFault::nan && n == n0()) return nan;
    if (c_.fault == MeasurementFault::inf && n == n0()) return inf;
    return 0.0;
  }
  long n0() const { return std::max<long>(8, periods_ / 4); }
  bool faulty() const { return c_.fault == MeasurementFault::nan || c_.fault == MeasurementFault::inf; }

  /// Records one period; false to stop.
  bool record(long n, double force, double deviation, const Room& room) {
    out_.periods = n + 1;
    if (std::isfinite(force)) {
      out_.peak_force = std::max(out_.peak_force, std::abs(force));
    } else {
      ++out_.nonfinite_outputs;
      if (out_.first_nonfinite < 0) out_.first_nonfinite = n;
    }
    if (faulty()) {
      // The growth is measured before the fault; after it, only what the scene emits.
      if (n < n0()) track(n, deviation);
      return n + 1 < n0() + fault_window;
    }
    if (!std::isfinite(deviation)) {
      out_.note = "state not finite at period " + std::to_string(n);
      return false;
    }
    track(n, deviation);
    if (deviation > room.upper) {
      out_.note = "stopped at the growth limit after " + std::to_string(n + 1) + " periods";
      return false;
    }
    if (deviation < room.floor) {
      out_.hit_floor = true;
      out_.note = "decayed to the rounding floor after " + std::to_string(n + 1) + " periods";
      return false;
    }
    return true;
  }

  void track(long n, double deviation) {
    if (n == 0) out_.first = deviation;
    out_.last = deviation;
    out_.last_n = n;
    out_.envelope.add(deviation);
  }

  /// The hand holds the device at 0; the virtual body starts at 1.
  void held() {
    world::AnyScene scene = plan_.scene_object;
    world::reset(scene, 1.0);
    const Room room{1.0, 1e250, 1e-250};
    std::array<double, world::max_scene_channels> ch{};
    for (long n = 0; n < periods_; ++n) {
      const double y = 0.0 + fault_offset(n);
      const double force = world::step(scene, y);
      world::channels(scene, ch);
      const double deviation = std::abs(ch[0] - y) + c_.device.period_s * std::abs(ch[1]);
      Room r = room;
      if (c_.fault == MeasurementFault::encoder_jump) r.floor = 1e-15 * std::abs(y);
      if (!record(n, force, deviation, r)) return;
    }
    if (out_.note.empty()) out_.note = "ran " + std::to_string(periods_) + " periods";
  }

  /// The device, displaced by 1 mm (or mrad) from the virtual body, is let go.
  void released_spring() {
    const world::DiscreteStateSpace zoh = world::discretize_zoh(c_.device.plant.dynamics, c_.device.period_s);
    world::AnyScene scene = plan_.scene_object;
    world::reset(scene, 0.0);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(zoh.ad.rows());
    const double x0 = 1e-3;
    x(0) = x0;
    const Eigen::VectorXd motor = zoh.bd.col(world::motor_force_input);
    std::vector<double> line(static_cast<std::size_t>(c_.device.delay_samples), 0.0);
    std::size_t head = 0;
    std::array<double, world::max_scene_channels> ch{};
    const long half = x.size() / 2;
    for (long n = 0; n < periods_; ++n) {
      const double offset = fault_offset(n);
      const double y = sensed_position(c_.device.plant, c_.device.sensor, x) + offset;
      const double force = world::step(scene, y);
      world::channels(scene, ch);
      const double velocity = x(half);  // the sensed body's velocity (rigid: the only one)
      const double deviation = std::abs(y - ch[0]) + c_.device.period_s * std::abs(velocity - ch[1]);
      Room r{x0, 1e250, 1e-14 * (x0 + std::abs(c_.fault == MeasurementFault::encoder_jump ? offset : 0.0))};
      if (!record(n, force, deviation, r)) return;
      double applied = force;
      if (!line.empty()) {
        applied = line[head];
        line[head] = force;
        head = (head + 1) % line.size();
      }
      if (!std::isfinite(applied)) applied = 0.0;  // the engine's guard: a non-finite output is zeroed
      x = zoh.ad * x + motor * applied;
    }
    if (out_.note.empty()) out_.note = "ran " + std::to_string(periods_) + " periods";
  }

  /// The hand pushes the device into the wall with F_h; it starts 1 ppm
  /// (of the room to contact loss) off the equilibrium penetration F_h / K.
  void wall() {
    const double t = c_.device.period_s;
    const double k = std::get<double>(plan_.parameters.at("stiffness"));
    const double b = std::get<double>(plan_.parameters.at("damping"));
    const double x_wall = std::get<double>(plan_.parameters.at("position"));
    const double equilibrium = c_.hand_force / k;
    // Beyond this deviation the law is no longer linear: the wall would pull
    // (clamped) once B |v| > K pen, |v| up to 2 |dev| / T.
    const double linear = b > 0.0 ? std::min(1.0, k * t / (4.0 * b)) : 1.0;
    const Room room{1e-6 * linear * equilibrium, 0.5 * linear * equilibrium, 1e-14 * equilibrium};
    const world::DiscreteStateSpace zoh = world::discretize_zoh(c_.device.plant.dynamics, t);
    const Eigen::VectorXd motor = zoh.bd.col(world::motor_force_input);
    const Eigen::VectorXd hand = zoh.bd.col(world::hand_force_input) * c_.hand_force;
    world::AnyScene scene = plan_.scene_object;
    world::reset(scene, x_wall);  // at the surface: armed
    // The hand holds the device at the equilibrium until the estimator and
    // the delay line have settled (every output then is -F_h).
    const int delay = static_cast<int>(std::get<double>(plan_.parameters.at("delay")));
    for (int i = 0; i < delay + 3; ++i) world::step(scene, x_wall + equilibrium);
    std::vector<double> line(static_cast<std::size_t>(c_.device.delay_samples), -c_.hand_force);
    std::size_t head = 0;
    // At rest in contact: A x + B_motor F + B_hand F_h = 0 with F = -K (C x - x_wall).
    // (Two-mass: the cable is stretched by F_h / k_c, the sensed position is F_h / K.)
    const world::ContinuousStateSpace& plant = c_.device.plant.dynamics;
    const Eigen::RowVectorXd sensed = c_.device.plant.position(c_.device.sensor);
    const Eigen::MatrixXd loop = plant.a - k * plant.b.col(world::motor_force_input) * sensed;
    const Eigen::VectorXd rest =
        loop.fullPivLu().solve(-plant.b.col(world::hand_force_input) * c_.hand_force -
                               k * x_wall * plant.b.col(world::motor_force_input));
    Eigen::VectorXd x = rest;
    x(0) += room.start;
    double previous = x_wall + equilibrium;
    const long half = x.size() / 2;
    for (long n = 0; n < periods_; ++n) {
      const double y = sensed_position(c_.device.plant, c_.device.sensor, x) + fault_offset(n);
      const double force = world::step(scene, y);
      double deviation = 0.0;
      for (long i = 0; i < half; ++i) deviation += std::abs(x(i) - rest(i)) + t * std::abs(x(half + i));
      if (!record(n, force, deviation, room)) return;
      const double law = -k * (y - x_wall) - b * (y - previous) / t;
      if (!faulty() && (!(y - x_wall > 0.0) || law > 0.0)) {
        out_.note = "left the linear contact law at period " + std::to_string(n);
        return;
      }
      if (std::isfinite(y)) previous = y;
      double applied = force;
      if (!line.empty()) {
        applied = line[head];
        line[head] = force;
        head = (head + 1) % line.size();
      }
      if (!std::isfinite(applied)) applied = 0.0;
      x = zoh.ad * x + motor * applied + hand;
    }
    if (out_.note.empty()) out_.note = "ran " + std::to_string(periods_) + " periods";
  }

  const SweepCase& c_;
  const world::ScenePlan& plan_;
  long periods_;
  RunOutcome out_;
};

struct Measured {
  double log_growth = nan;
  long window = 0;
  bool bound_only = false;  ///< too few periods before the floor: an upper bound
};

/// ln r per period: least squares of ln(block max) over the blocks after the
/// first quarter (the transient), or the end-to-end ratio when there are
/// fewer than three.
Measured measure(const RunOutcome& run) {
  Measured m;
  const auto& blocks = run.envelope.block_max;
  const long size = run.envelope.size;
  const std::size_t skip = blocks.size() / 4;
  std::vector<std::pair<double, double>> points;
  for (std::size_t i = skip; i < blocks.size(); ++i) {
    if (blocks[i] > 0.0 && std::isfinite(blocks[i])) {
      points.emplace_back((static_cast<double>(i) + 0.5) * static_cast<double>(size), std::log(blocks[i]));
    }
  }
  if (points.size() >= 3) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (const auto& [x, y] : points) sx += x, sy += y, sxx += x * x, sxy += x * y;
    const double n = static_cast<double>(points.size());
    m.log_growth = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    m.window = static_cast<long>(points.size()) * size;
    return m;
  }
  if (run.last_n > 0 && run.first > 0.0) {
    // Gone below the floor within a few blocks: the floor bounds the decay.
    const double last = run.last > 0.0 ? run.last : std::numeric_limits<double>::denorm_min();
    m.log_growth = std::log(last / run.first) / static_cast<double>(run.last_n);
    m.window = run.last_n;
    m.bound_only = run.hit_floor;
  }
  return m;
}

std::string fmt(double v) { return short_number(v); }

void plan_gate(const SweepCase& c, SweepResult& r) {
  const GateOutcome outcome = gate_scene(c.scene, c.parameters, c.device, false);
  if (const auto* refused = std::get_if<GateRefusal>(&outcome)) {
    r.gate_accepts = false;
    r.gate_decision = refused->invalid     ? "refused (invalid)"
                      : !refused->assessed ? "refused (cannot assess)"
                                           : "refused (unstable)";
    r.gate_reason = refused->message;
  } else {
    r.gate_accepts = true;
    r.gate_decision = "accepted";
    r.gate_reason = std::get<GateAccepted>(outcome).stability.summary;
  }
}

}  // namespace

void judge_growth(SweepResult& r, long window, bool bound_only) {
  const double g = r.predicted_log_growth;
  const double measured = r.measured_log_growth;
  if (std::abs(r.predicted_radius - 1.0) <= marginal_band) {
    r.agreement = SweepAgreement::marginal;
    return;
  }
  r.tolerance =
      (std::isfinite(g) ? 0.05 * std::abs(g) : 0.0) + (window > 0 ? 4.0 / static_cast<double>(window) : inf);
  if (!std::isfinite(measured)) {
    r.agreement = SweepAgreement::disagree;
    r.why = "the run gave no growth to compare";
    return;
  }
  if (g > 0.0) {  // unstable: the growing mode dominates the run
    if (std::abs(measured - g) > r.tolerance) {
      r.agreement = SweepAgreement::disagree;
      r.why = "predicted growth " + fmt(g) + " per period, measured " + fmt(measured);
      return;
    }
    if (r.gate_accepts) {
      r.agreement = SweepAgreement::disagree;
      r.why = "the gate accepts a set the run shows growing";
      return;
    }
  } else {  // stable: the run decays at least as fast as the slowest pole
    const bool too_slow = bound_only ? !(measured < 0.0) : measured > g + r.tolerance;
    if (too_slow) {
      r.agreement = SweepAgreement::disagree;
      r.why = "predicted decay " + fmt(g) + " per period, measured " + fmt(measured);
      return;
    }
  }
  r.agreement = SweepAgreement::agree;
}

std::string_view to_string(SweepAgreement agreement) noexcept {
  switch (agreement) {
    case SweepAgreement::agree:
      return "agree";
    case SweepAgreement::disagree:
      return "DISAGREE";
    case SweepAgreement::marginal:
      return "marginal";
    case SweepAgreement::not_run:
      return "not run";
    case SweepAgreement::fault_handled:
      return "fault";
  }
  return "?";
}

double log10_growth_per_second(double log_growth_per_period, double period_s) {
  return log_growth_per_period / (period_s * std::numbers::ln10);
}

SweepResult run_sweep_case(const SweepCase& c, const SweepOptions& options) {
  SweepResult r;
  r.input = c;
  plan_gate(c, r);
  auto built = world::plan_scene(c.scene, c.parameters, c.device.period_s, c.device.motion);
  if (const auto* error = std::get_if<world::SceneError>(&built)) {
    r.predicted_verdict = "cannot assess: " + error->message;
    r.run_note = "not run: the scene cannot be built";
    r.agreement = r.gate_accepts ? SweepAgreement::disagree : SweepAgreement::not_run;
    if (r.gate_accepts) r.why = "the gate accepts a scene that cannot be built";
    return r;
  }
  const world::ScenePlan& plan = std::get<world::ScenePlan>(built);
  const Prediction p = predict(c, plan);
  r.predicted_assessed = p.assessed;
  r.predicted_radius = p.radius;
  if (!p.assessed) {
    r.predicted_verdict = "cannot assess: " + p.reason;
    r.run_note = "not run: no finite prediction to compare";
    r.agreement = r.gate_accepts ? SweepAgreement::disagree : SweepAgreement::not_run;
    if (r.gate_accepts) r.why = "the gate accepts a set whose poles are not finite (" + p.reason + ")";
    return r;
  }
  r.predicted_log_growth = p.radius > 0.0 ? std::log(p.radius) : -inf;
  const double g = r.predicted_log_growth;
  r.predicted_verdict =
      std::abs(p.radius - 1.0) <= marginal_band ? "marginal" : (g > 0 ? "unstable" : "stable");

  // Long enough to grow or decay by e^30 (or to the run's limits), at least
  // 20 blocks of 1.5 periods of the dominant oscillation.
  const double oscillation = p.angle > 1e-12 ? 2.0 * std::numbers::pi / p.angle : 1.0;
  const long block =
      std::clamp<long>(static_cast<long>(std::ceil(1.5 * oscillation)), 4, options.max_periods / 40);
  const bool marginal = r.predicted_verdict == "marginal";
  const double wanted =
      marginal || !std::isfinite(g) ? 0.1 * static_cast<double>(options.max_periods) : 30.0 / std::abs(g);
  const long periods = std::clamp<long>(
      static_cast<long>(std::max(wanted, 20.0 * static_cast<double>(block))), 64, options.max_periods);
  Run run(c, plan, periods, block);
  const RunOutcome outcome = run.go();
  r.ran = true;
  r.periods_run = outcome.periods;
  r.peak_force = outcome.peak_force;
  r.run_note = outcome.note;
  const Measured m = measure(outcome);
  r.measured_log_growth = m.log_growth;
  r.fit_periods = m.window;
  if (c.fault == MeasurementFault::nan || c.fault == MeasurementFault::inf) {
    r.agreement = SweepAgreement::fault_handled;
    r.run_note = outcome.nonfinite_outputs == 0
                     ? "the scene's output stayed finite"
                     : "output not finite in " + std::to_string(outcome.nonfinite_outputs) + " of the " +
                           std::to_string(fault_window) + " periods from the fault on (first at period " +
                           std::to_string(outcome.first_nonfinite) +
                           "): the engine zeroes it and latches a fault; fault clear restarts the scene";
    return r;
  }
  if (c.fault == MeasurementFault::encoder_jump) {
    r.run_note += "; peak |F| " + fmt(outcome.peak_force) + " after the jump (the torque limit caps it)";
  }
  judge_growth(r, m.window, m.bound_only);
  return r;
}

std::vector<SweepResult> run_stability_sweep(const std::vector<SweepCase>& cases, const SweepOptions& options,
                                             StudyProgress& progress) {
  progress.plan(static_cast<double>(cases.size()));
  std::vector<SweepResult> results;
  results.reserve(cases.size());
  for (const SweepCase& c : cases) {
    progress.stage(c.family + ": " + c.name);
    results.push_back(run_sweep_case(c, options));
    progress.advance(1);
  }
  std::stable_partition(results.begin(), results.end(),
                        [](const SweepResult& r) { return r.agreement == SweepAgreement::disagree; });
  return results;
}

}  // namespace hapticd::analysis
