#pragma once
/// \file
/// Internal to the accuracy study: compares a method's output sample by
/// sample with the closed form, and times a step function on its own.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "analysis/accuracy_study.hpp"
#include "world/state_space.hpp"

namespace hapticd::analysis::detail {

/// Largest |F[n] - F(nT)| / scale up to each checkpoint, and the running
/// maximum at log-spaced n for the growth curve. Outputs n = 0 .. last().
class ErrorTracker {
 public:
  ErrorTracker(const AccuracyCase& c, const RunOptions& options, RunResult& result);

  /// Index of the last output compared (the duration in periods).
  long last() const noexcept { return last_; }
  /// Compares F[n]; returns false once the output is not finite (the rest is inf).
  bool observe(long n, double output);
  /// Fills the checkpoints not reached (after a non-finite output) with inf.
  void finish(long observed);

 private:
  const AccuracyCase& case_;
  SecondOrderStep reference_;
  double period_s_;
  double scale_;
  RunResult& result_;
  std::vector<long> checkpoint_index_;
  std::size_t next_checkpoint_ = 0;
  int per_decade_;
  int next_growth_ = 0;
  long next_growth_index_ = 1;
  long last_ = 0;
  double running_max_ = 0.0;
};

/// The scene's output law on a state: k e [+ b (e' - v[n])] for the springs
/// (v[0] = z0 / T, the backward difference of the step, then 0), the wall's
/// -K x - B x'.
double output_law(const AccuracyCase& c, double e, double e_dot, long n, double period_s);
/// b acts on the relative velocity (the catalog's default damping_reference).
bool relative_damping(const AccuracyCase& c);

/// The wall variant the catalog would build for the case, as the LTI law
/// in contact (WallScene::linear_model), for the closed-loop verdict.
world::DiscreteLinearScene wall_linear_model(const AccuracyCase& c, double period_s);

/// Fastest of three timings of `steps` calls of step(i), CPU seconds per call.
/// The outputs go to a small ring that is summed afterwards, so the calls
/// cannot be optimized away and add no dependency between steps.
template <class Step>
double time_per_step(Step&& step, long steps, CpuClock clock) {
  std::array<double, 256> ring{};
  double best = std::numeric_limits<double>::infinity();
  for (int repetition = 0; repetition < 3; ++repetition) {
    const double start = clock();
    for (long i = 0; i < steps; ++i) ring[static_cast<std::size_t>(i) & 255u] = step(i);
    best = std::min(best, (clock() - start) / static_cast<double>(steps));
  }
  volatile double sink = 0.0;
  for (const double x : ring) sink = sink + x;
  return best;
}

}  // namespace hapticd::analysis::detail
