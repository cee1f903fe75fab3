#pragma once
/// \file
/// Boost.Odeint on the accuracy study's continuous problem (the reference
/// ODE of analysis/step_response.hpp), as outside references on the same
/// axes: classic RK4 with the step T, and the adaptive Dormand-Prince 5(4)
/// stepper (runge_kutta_dopri5) with dense output, observed at the sample
/// instants n T. The state is integrated in units of the step (e / L,
/// e' / (w_n L), L = |z0| or F_h / K), so a tolerance is relative to the
/// step; the relative-damping pulse over [0, T) is integrated as its own
/// segment (its forcing is discontinuous at T).

#include "analysis/accuracy_study.hpp"

namespace hapticd::analysis {

/// method.kind is odeint_rk4 or odeint_dopri5. CPU time is measured on a
/// second run whose observer only forms the output (no closed form).
RunResult run_odeint(const AccuracyCase& c, const Method& method, const RunOptions& options,
                     StudyProgress& progress);

}  // namespace hapticd::analysis
