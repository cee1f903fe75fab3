#pragma once
/// \file
/// The stiff and extreme cases of `hapticctl report stability` (issue 12).
/// For each case three independent answers:
///  - predicted: the analysis' pole radius r for the configuration that is
///    run (the scene alone, device held: the eigenvalues of the scene's
///    matrix; released: the closed loop with the plant, analyze_closed_loop,
///    leaving out the rigid-body drift poles at z = 1, which the run's
///    relative coordinate does not see), and growth per second r^(1/T);
///  - measured: a time-domain run of the real scene object (world/) on the
///    device's exact ZOH plant, from a small disturbance, over enough periods
///    to tell (see measure below), as ln(growth) per period;
///  - planned: what the daemon's gate does when asked (analysis/
///    stability_gate.hpp, the function plan_on_device wraps): refuses with
///    its reason, or accepts (the scene then runs under the torque limit).
/// A case disagrees when prediction and run differ in sign of ln r or by
/// more than the tolerance (agreement below), or when the gate accepts a set
/// the run shows growing. Cases with |r - 1| <= 1e-6 are marginal: the
/// growth is reported, not judged.

#include <optional>
#include <string>
#include <vector>

#include "analysis/stability_gate.hpp"
#include "analysis/study_progress.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::analysis {

enum class SweepMode {
  held,      ///< the hand holds the device: the scene alone on a step
  released,  ///< the device is let go: scene and plant in closed loop, hand force only for the wall
};

enum class MeasurementFault {
  none,
  encoder_jump,  ///< the position read jumps by fault_counts encoder counts at n0 (and stays shifted)
  nan,           ///< one NaN position at n0
  inf,           ///< one +Inf position at n0
};

struct SweepCase {
  std::string family;  ///< "w_n T", "k/J", "period", "delay", "inertia", "damping", "two-mass", "encoder",
                       ///< "non-finite"
  std::string name;    ///< what is extreme about it
  std::string scene;   ///< catalog name
  world::ParameterSet parameters;
  GateDevice device;
  SweepMode mode = SweepMode::released;
  double hand_force = 0.0;  ///< wall: the push that keeps the device in contact (N or N m)
  MeasurementFault fault = MeasurementFault::none;
  double fault_counts = 0.0;        ///< encoder_jump: counts
  double encoder_resolution = 0.0;  ///< m or rad per count
};

enum class SweepAgreement {
  agree,          ///< sign and size of the growth as predicted, and the gate consistent with the run
  disagree,       ///< beyond the tolerance: listed first, the command exits 1
  marginal,       ///< |r - 1| <= 1e-6: growth measured, not judged
  not_run,        ///< the scene cannot be built (bad parameters): the gate's refusal is the answer
  fault_handled,  ///< a NaN/Inf measurement: what the scene emits (the engine's guard zeroes it)
};
std::string_view to_string(SweepAgreement agreement) noexcept;

struct SweepResult {
  SweepCase input;
  // predicted
  bool predicted_assessed = false;    ///< finite poles
  double predicted_radius = 0.0;      ///< largest |pole| of the run's configuration (drift excluded)
  double predicted_log_growth = 0.0;  ///< ln r per period
  std::string predicted_verdict;      ///< "stable", "unstable", "marginal", "cannot assess: ..."
  // measured
  bool ran = false;
  long periods_run = 0;
  long fit_periods = 0;              ///< periods in the fitted window
  double measured_log_growth = 0.0;  ///< ln r per period, least squares on block maxima
  double tolerance = 0.0;            ///< allowed |measured - predicted| in ln r per period
  std::string run_note;              ///< how the run ended, faults seen, peak force
  double peak_force = 0.0;           ///< largest |F| commanded (N or N m)
  // planned
  std::string
      gate_decision;  ///< "accepted", "refused (unstable)", "refused (invalid)", "refused (cannot assess)"
  std::string gate_reason;
  bool gate_accepts = false;
  // verdict
  SweepAgreement agreement = SweepAgreement::agree;
  std::string why;  ///< for disagree: what differs
};

/// The rule, on r.predicted_radius, r.predicted_log_growth (ln r per period),
/// r.measured_log_growth (fitted over `window` periods) and r.gate_accepts:
/// marginal if |r - 1| <= 1e-6; else the tolerance is
/// 0.05 |ln r| + 4 / window (block maxima of an oscillation wander by up to a
/// factor e^4 over the fit); unstable: |measured - predicted| <= tolerance
/// (the growing mode dominates) and the gate must refuse; stable: measured
/// <= predicted + tolerance (the run decays at least as fast as the slowest
/// pole: a mode the disturbance does not excite may decay faster), or just
/// < 0 when the run hit its rounding floor too soon to fit (bound_only).
/// Sets r.agreement, r.tolerance and r.why.
void judge_growth(SweepResult& r, long window, bool bound_only);

/// ln r per period as growth per second: r^(1/T) as log10, finite even when r^(1/T) overflows.
double log10_growth_per_second(double log_growth_per_period, double period_s);

/// The case list: every family, `quick` a subset for the test suite.
std::vector<SweepCase> sweep_cases(bool quick);

struct SweepOptions {
  long max_periods = 4'000'000;  ///< longest run (marginal cases and slow growth)
};

/// One case: prediction, run, gate, agreement.
SweepResult run_sweep_case(const SweepCase& c, const SweepOptions& options);

/// All cases (disagreements first, then the input order); throws
/// StudyCancelled if `progress` asks to stop.
std::vector<SweepResult> run_stability_sweep(const std::vector<SweepCase>& cases, const SweepOptions& options,
                                             StudyProgress& progress);

}  // namespace hapticd::analysis
