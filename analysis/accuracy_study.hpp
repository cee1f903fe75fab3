#pragma once
/// \file
/// Error against run time of every linear scene and integrator (issue 12).
///
/// The problem is a held step, Freudenberg 2.3-2.4:
///  - spring scenes: the device is held at z0 from t = 0 with the virtual
///    body at rest at 0 (reset(0), then step(z0) every period); the output is
///    the scene's force/torque on the device, F = k (w - y) [+ b (w' - v)];
///  - the wall in contact: the device (a rigid mass m) rests at the wall's
///    surface and the hand pushes into the wall with a constant F_h from
///    t = 0; the device is advanced by its exact ZOH, the output is the
///    force the wall commands (after its delay line).
/// The reference is the continuous solution of the held-input problem the
/// scene sees (step_response.hpp): the measured position is z0 from t = 0
/// on and, for relative damping, the velocity input is the backward
/// difference as the scene holds it, z0 / T over [0, T) and 0 after (the
/// ideal step would be an impulse z0 delta(t); the estimator spreads it over
/// one period, which is not the integrator's error). So the exact (ZOH)
/// integrator is exact here up to rounding. For the wall the reference is the
/// continuous PD wall on the continuous mass, m x'' + (B + b) x' + K x = F_h:
/// what the sampled wall (hold, backward difference, delay) approximates.
/// The error is max_n |F[n] - F(nT)| divided by k |z0| (springs, Freudenberg's
/// peak torque) or |F_h| (wall).

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/step_response.hpp"
#include "analysis/study_progress.hpp"
#include "world/integrator.hpp"
#include "world/plant.hpp"

namespace hapticd::analysis {

enum class AccuracyScene { spring_wheel, spring_wheel_absolute, spring_wheel_relative, spring_mass, wall };
inline constexpr std::array<AccuracyScene, 5> all_accuracy_scenes{
    AccuracyScene::spring_wheel, AccuracyScene::spring_wheel_absolute, AccuracyScene::spring_wheel_relative,
    AccuracyScene::spring_mass, AccuracyScene::wall};
/// "spring-wheel", "spring-wheel-absolute", "spring-wheel-relative", "spring-mass", "wall".
std::string_view to_string(AccuracyScene scene) noexcept;
std::optional<AccuracyScene> parse_accuracy_scene(std::string_view name) noexcept;
/// True for the scenes with an integrator (all but the wall).
constexpr bool has_integrator(AccuracyScene scene) noexcept { return scene != AccuracyScene::wall; }

struct AccuracyCase {
  AccuracyScene scene = AccuracyScene::spring_wheel;
  double stiffness = 0.0;    ///< k, N m/rad or N/m; the wall's K, N/m
  double inertia = 0.0;      ///< J (kg m^2) or m (kg) of the virtual body; springs only
  double damping = 0.0;      ///< b (N m s/rad or N s/m); the wall's B (N s/m)
  double step = 0.0;         ///< held step: z0 (rad or m) for the springs, F_h (N) for the wall
  int delay_samples = 0;     ///< the wall's d
  world::RigidPlant device;  ///< the mass the wall is rendered on (wall only)
};

/// The scene catalog's defaults: the 1 Hz Freudenberg wheel with a 45 degree
/// step, the 2 Hz spring-mass with a 1 cm step, the damped wheels with
/// Freudenberg's b = T k (2.24) at `device_period_s`, Hulin's wall (K = 9 kN/m,
/// B = 46 N s/m, d = 1) on m = 0.1 kg pushed with 1 N.
AccuracyCase default_case(AccuracyScene scene, double device_period_s);
/// w_n: sqrt(k / J), or sqrt(K / m) for the wall.
double natural_frequency(const AccuracyCase& c);
/// zeta: b / (2 sqrt(k J)), or (B + b_device) / (2 sqrt(K m)) for the wall.
double damping_ratio(const AccuracyCase& c);
/// The case with its stiffness set for w_n T = wn_t and its damping for the same zeta.
AccuracyCase at_normalized_frequency(const AccuracyCase& c, double wn_t, double period_s);
/// The continuous held-input problem for period T (see the file comment), in
/// the coordinate e = w - z0 (springs) or x - x_wall (wall).
SecondOrderStep reference_problem(const AccuracyCase& c, double period_s);
/// F(nT) of the reference: the scene's own output law on the reference state.
double reference_output(const AccuracyCase& c, const SecondOrderStep& reference, long n, double period_s);
/// k |z0| or |F_h|: the errors are divided by it.
double output_scale(const AccuracyCase& c);

/// What renders the case: a world integrator (spring scenes), the sampled
/// wall's own law (no integrator: ZOH device, backward difference, delay), or
/// a Boost.Odeint reference on the continuous problem.
struct Method {
  enum class Kind { integrator, sampled_wall, odeint_rk4, odeint_dopri5 };
  Kind kind = Kind::integrator;
  world::Integrator integrator = world::Integrator::exact;
  double tolerance = 0.0;  ///< odeint_dopri5: absolute and relative, on the state in units of the step
  /// "rk4", "sampled-wall", "odeint-rk4", "odeint-dopri5".
  std::string name() const;
  /// name, plus " tol=1e-06" for dopri5.
  std::string label() const;
};

struct RunOptions {
  double period_s = 1e-3;                ///< T; Odeint's dopri5 is observed at the same instants
  std::vector<double> checkpoints_s{1};  ///< ascending; the last is the simulated duration
  int growth_points_per_decade = 0;      ///< > 0: record the running maximum at log-spaced times
  long timing_steps = 1L << 17;          ///< steps timed per repetition (3 repetitions, fastest kept)
};

struct TimedError {
  double time_s = 0.0;
  double error = 0.0;  ///< largest error over [0, time_s]
};

struct RunResult {
  std::vector<double> errors;  ///< per checkpoint: largest error up to it (inf once the output is not finite)
  std::vector<TimedError> growth;
  long periods = 0;             ///< outputs compared
  long solver_steps = 0;        ///< Odeint: steps taken (rk4: one per period)
  double cpu_s_per_step = 0.0;  ///< CPU time per period of the scene's step alone, or of the Odeint run
  double cpu_s_per_simulated_s = 0.0;  ///< cpu_s_per_step / T
  bool stable = true;                  ///< the analysis' verdict for this discretization (Odeint: true)
  bool contact_kept = true;            ///< wall: in contact (the linear law applied) at every n >= 1
};

RunResult run_method(const AccuracyCase& c, const Method& method, const RunOptions& options,
                     StudyProgress& progress);

/// The stability verdict for the case at period T: analyze_integrator for a
/// spring scene (the scene's own Ad, the device held), the closed loop with
/// the rigid device (analyze_closed_loop) for the wall.
bool discretization_stable(const AccuracyCase& c, const Method& method, double period_s);
/// Largest w_n T (zeta held) for which discretization_stable holds, by a
/// log scan of [1e-3, 1e3] and bisection: 0 if unstable already at 1e-3,
/// +inf if stable up to 1e3.
double stability_limit(const AccuracyCase& c, const Method& method, double period_s);

/// Leading-order error of the undamped held step, max over w_n t in
/// [0, theta], of the integrator at h = w_n T: constant * h^order. Derived
/// from the amplification factor R(jh) of each scheme (Ad is a function of
/// T A, so the discrete solution is -z0 |R|^n cos(n arg R) for the normal
/// schemes):
///   forward Euler  |R| = sqrt(1 + h^2): amplitude grows by theta h / 2
///                  -> (theta / 2) h;
///   semi-implicit  det Ad = 1, arg R = h + h^3/24, but the orbit is an
///                  ellipse: x_n = -z0 (cos n phi + h^2/(2 sin phi) sin n phi),
///                  a half-step lag -> (1/2) h, bounded in time;
///   trapezoid      |R| = 1, arg R = 2 atan(h/2) = h - h^3/12
///                  -> ((theta - pi/2) / 12) h^2;
///   rk4            R = e^{jh} - (jh)^5/120 + ..., phase lag h^5/120 per step
///                  -> ((theta - pi/2) / 120) h^4;
///   exact          0 (rounding only).
/// (theta - pi/2: a phase error shows most where |sin| = 1 before theta.)
struct ErrorLaw {
  int order = 0;
  double constant = 0.0;
  double at(double h) const;
};
ErrorLaw leading_error_law(world::Integrator integrator, double theta);
/// The sampled wall's contact transient: the ideal wall force starts at
/// contact with slope -B F_h / m, and the sampled law sees it d + 1/2 samples
/// late (the delay line, and the backward difference estimates the velocity
/// half a sample back), so the error is (d + 1/2) T B F_h / m:
/// order 1 in w_n T with constant (d + 1/2) B / (m w_n) = (d + 1/2) 2 zeta_B.
/// The leading term while that transient is the largest error (a damped
/// wall, B > 0); with B = 0 nothing is predicted (order 0).
ErrorLaw wall_error_law(const AccuracyCase& c);

struct AccuracyStudyOptions {
  std::vector<AccuracyCase> cases;
  std::vector<world::Integrator> integrators{world::all_integrators.begin(), world::all_integrators.end()};
  std::vector<double> periods_s;                ///< work-precision sweep (figure 1)
  std::vector<double> durations_s{1, 10, 100};  ///< checkpoints, ascending
  double device_period_s = 1e-3;                ///< figure 2 (error against time) and the w_n T sweep
  std::vector<double> wn_t;                     ///< w_n T sweep (figure 3)
  double sweep_cycles = 1;                      ///< the w_n T sweep runs this many natural periods
  std::vector<double> tolerances{1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12};
  std::vector<double> growth_tolerances{1e-6, 1e-10};  ///< dopri5 tolerances shown in figure 2
  bool odeint = true;
  long timing_steps = 1L << 17;
};

/// Log-spaced values from `from` to `to`, `per_decade` per decade, ends included.
std::vector<double> log_grid(double from, double to, int per_decade);
/// The default sweeps: periods 20 us .. 10 ms (1-2-5), w_n T 1e-3 .. pi
/// (8 per decade), durations 1, 10, 100 s.
AccuracyStudyOptions default_accuracy_options(double device_period_s);

struct WorkPrecisionRow {
  AccuracyScene scene{};
  Method method;
  double period_s = 0.0;
  double wn_t = 0.0;
  RunResult run;
};

struct GrowthSeries {
  AccuracyScene scene{};
  Method method;
  double period_s = 0.0;
  RunResult run;  ///< run.growth holds the curve
};

struct SweepRow {
  AccuracyScene scene{};
  Method method;
  double wn_t = 0.0;
  double error = 0.0;      ///< largest error over sweep_cycles natural periods
  double predicted = 0.0;  ///< leading_error_law (undamped spring scenes), else NaN
  bool stable = true;
};

struct StabilityLimitRow {
  AccuracyScene scene{};
  Method method;
  double wn_t = 0.0;  ///< 0: unstable over the whole sweep; inf: no limit
};

/// Least-squares slope of log(error) against log(w_n T) over the sweep points
/// in the asymptotic range (h <= 0.1, error at least 1e3 times the exact
/// integrator's rounding floor and below 1e-2), and the constant error / h^order
/// at the smallest of them.
struct OrderFit {
  AccuracyScene scene{};
  Method method;
  int points = 0;
  double order = 0.0;
  double constant = 0.0;  ///< measured error / h^predicted order (mean over the points)
  ErrorLaw predicted;     ///< order 0 when there is no prediction (damped)
};

struct AccuracyStudy {
  AccuracyStudyOptions options;
  std::vector<WorkPrecisionRow> work_precision;
  std::vector<GrowthSeries> growth;
  std::vector<SweepRow> sweep;
  std::vector<StabilityLimitRow> limits;
  std::vector<OrderFit> orders;
};

/// Runs everything; throws StudyCancelled if `progress` asks to stop.
AccuracyStudy run_accuracy_study(const AccuracyStudyOptions& options, StudyProgress& progress);

}  // namespace hapticd::analysis
