#pragma once
/// \file
/// Integration schemes for the linear scenes. Each one turns x' = A x + B u
/// into x[n+1] = Ad x[n] + Bd u[n] with the input held over the period, once,
/// when parameters change; the RT step is then the same multiply-add for all.

#include <array>
#include <optional>
#include <string_view>

#include "world/state_space.hpp"

namespace hapticd::world {

enum class Integrator {
  forward_euler,        ///< Ad = I + T A, Bd = T B (Freudenberg 2.8)
  semi_implicit_euler,  ///< velocity rows first, then positions with the new velocity
  trapezoid,            ///< Tustin: (I - T A/2)^-1 (I + T A/2)
  rk4,                  ///< classic 4th-order Runge-Kutta; for linear A it is the 4th-order Taylor of e^{AT}
  exact,                ///< zero-order hold via the matrix exponential
};

inline constexpr std::array<Integrator, 5> all_integrators{
    Integrator::forward_euler, Integrator::semi_implicit_euler, Integrator::trapezoid, Integrator::rk4,
    Integrator::exact};

/// CLI/config/protocol name: "forward-euler", "semi-implicit-euler", "trapezoid", "rk4", "exact".
std::string_view to_string(Integrator integrator) noexcept;
std::optional<Integrator> parse_integrator(std::string_view name) noexcept;
/// "forward-euler, semi-implicit-euler, trapezoid, rk4, exact": for error messages.
std::string_view integrator_names() noexcept;

/// Discretizes with period T (seconds). semi_implicit_euler needs the
/// mechanical layout x = [positions; velocities] (first half positions).
DiscreteStateSpace discretize(const ContinuousStateSpace& sys, double period_s, Integrator integrator);

/// Zero-order-hold discretization: [Ad Bd; 0 I] = expm([A B; 0 0] T).
DiscreteStateSpace discretize_zoh(const ContinuousStateSpace& sys, double period_s);

/// expm(M) of a square matrix, computed on a diagonally balanced copy
/// D^-1 M D (powers of two, so the scaling itself is exact). Why: a
/// mechanical A = [[0, 1], [-k/m, -b/m]] T is far from normal when k/m is
/// large; scaling-and-squaring on it loses the rotation (k = 1e6, m = 1e-4,
/// T = 1 ms: cos(w T) wrong by 2e-6; k = 1e9, m = 1e-6, T = 10 ms: by 0.9),
/// while on the balanced copy the error stays near rounding. A row or column
/// that is zero off the diagonal is left unscaled (no permutation as in
/// LAPACK's dgebal): such matrices keep plain scaling-and-squaring accuracy.
Eigen::MatrixXd balanced_exp(const Eigen::MatrixXd& m);

}  // namespace hapticd::world
