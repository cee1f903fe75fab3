#pragma once
/// \file
/// Passivity of a sampled virtual environment (Colgate & Schenkel 1997). A
/// device with physical damping b, under a zero-order hold, rendering
/// F = -H(z) x (F the force ON the device, x its position: hapticd's sign,
/// so H = -G for a scene whose linear model is F = G x), is passive iff for
/// every 0 < w <= pi/T
///   b >= (T/2) Re{(1 - e^{-jwT}) H(e^{jwT})} / (1 - cos wT).           (CS)
/// Passive means stable against ANY passive human (no model of the hand):
/// stricter than Hulin's stability region, which assumes the hand is absent.
///
/// The required damping is the supremum of the right side over w. With
/// theta = w T, (1 - e^{-j theta}) / (1 - cos theta) = 1 + j cot(theta/2), so
/// the right side is f(theta) = (T/2) [Re H - (1 + cos theta) Im H / sin theta]
/// (cot(theta/2) = (1 + cos theta) / sin theta), and Im H / sin theta is
/// computed without a division (below), so theta -> 0 is its finite limit.
///  - Wall, H(z) = z^-d (K + B (1 - z^-1)/T): the stiffness term is the
///    Dirichlet kernel, (cos d theta - cos (d+1) theta) / (1 - cos theta)
///    = sin((2d+1) theta/2) / sin(theta/2) = 1 + 2 sum_{k=1..d} cos k theta,
///    and the damping term (1 - e^{-j theta})^2 = -4 sin^2(theta/2) e^{-j theta}
///    gives -2 cos((d+1) theta), so
///      f(theta) = (K T / 2) (1 + 2 sum_{k=1..d} cos k theta) - B cos((d+1) theta):
///    a cosine sum, no division anywhere. d = 0: K T/2 + B (at Nyquist).
///  - Any linear scene (the springs): H(z) = -z^-d (C (zI - A)^-1 B + D).
///    With c = cos theta, s = sin theta, M = c I - A, P = M^2 + s^2 I:
///    Im G / s = -C P^-1 B and Re G = C M P^-1 B + D (one real solve, exact at
///    theta = 0), and sin(d theta)/s = U_{d-1}(c) (Chebyshev, by recurrence).
/// The supremum: a grid over [0, pi] (4096 points or 64 per period of the
/// delay's cos d theta, plus points crowding each pole of H), every local
/// maximum of the grid refined by bisecting the closed-form derivative
/// f'(theta) (f is even about 0 and pi, so both ends are critical points and
/// are candidates), to |d theta| ~ 1e-16: the value there is exact to
/// rounding. A pole of H on the unit circle (an undamped virtual body) makes
/// the supremum infinite; one outside (an unstable virtual body) too: both are
/// `unbounded`, with the reason, never a NaN.

#include <optional>
#include <string>
#include <vector>

#include "analysis/verdict.hpp"
#include "world/spring_scene.hpp"
#include "world/state_space.hpp"

namespace hapticd::analysis {

/// Delays the analysis accepts (its grid grows with d).
inline constexpr int max_passivity_delay_samples = 1000;

enum class PassivityState {
  bounded,        ///< the supremum is finite: required_damping
  unbounded,      ///< no device damping makes it passive (reason says why)
  cannot_assess,  ///< input or intermediates not finite or out of range (reason)
};
/// "bounded", "unbounded", "cannot_assess".
std::string_view to_string(PassivityState state) noexcept;

/// The supremum of (CS)'s right side over 0 < w <= pi/T.
struct PassivityBound {
  PassivityState state = PassivityState::cannot_assess;
  std::string reason = "not analyzed";  ///< unbounded / cannot_assess: why; bounded: empty
  /// N s/m (N m s/rad on a rotary device): the least device damping that makes
  /// the loop passive. +inf when unbounded; 0 when not assessed.
  double required_damping = 0.0;
  /// Where the supremum is reached (Hz). For unbounded: the frequency of the
  /// virtual body's mode on or outside the unit circle. 0 with
  /// at_zero_frequency_limit: the supremum is the limit w -> 0 (not attained).
  double frequency_hz = 0.0;
  bool at_zero_frequency_limit = false;
  bool assessed() const noexcept { return state != PassivityState::cannot_assess; }
  bool bounded() const noexcept { return state == PassivityState::bounded; }
};

/// A bound plus, with a device damping b, the answers on that device.
struct PassivityVerdict {
  PassivityBound bound;
  std::optional<double> device_damping;  ///< b as given
  /// b >= required_damping (false when unbounded or not assessed or no b).
  bool passive = false;
  /// The largest stiffness with the other parameters held that is passive on
  /// b (N/m or N m/rad); 0 if none. For the wall this is exact (below); for a
  /// spring it is the end of the passive interval starting at k = 0 found by
  /// a log scan (4 per decade from 1e-3 to 1e9) and bisection to 1e-9 relative.
  double max_stiffness = 0.0;
  bool max_stiffness_at_range_top = false;  ///< passive up to parameter_range's 1e9: a lower bound
};

/// The wall's supremum, normalized or not: sup over theta of
///   stiffness_term (1 + 2 sum_{k=1..d} cos k theta) - damping_term cos((d+1) theta).
/// In SI, stiffness_term = K T / 2 and damping_term = B (N s/m); in Hulin's
/// normalization (times T/m) alpha / 2 and beta, and the result is b T / m.
/// Both terms >= 0 and finite (not checked here: see wall_passivity).
struct WallSupremum {
  double value = 0.0;
  double theta = 0.0;  ///< w T where it is reached
};
WallSupremum wall_supremum(double stiffness_term, double damping_term, int delay_samples);

/// The wall H(z) = z^-d (K + B (1 - z^-1)/T) on any device: cannot_assess
/// (with the reason, as verdict.hpp) unless K, B >= 0 and T > 0 are finite and
/// 0 <= d <= max_passivity_delay_samples, or when the supremum overflows.
PassivityBound wall_passivity(double stiffness, double damping, double period_s, int delay_samples);

/// The largest stiffness_term s >= 0 with wall_supremum(s, damping_term, d)
/// <= device_term; 0 if none (damping_term >= device_term: the supremum at
/// s = 0 is damping_term, reached at theta = pi/(d+1)). The supremum is the
/// maximum of functions affine in s, so convex in s, and increasing from s = 0
/// (slope 1 at theta = pi/(d+1)): the answer lies in
/// [(b - B)/(2d+1), (b + B)/(2d+1)] and a Newton iteration on the envelope's
/// slope (safeguarded by bisection) finds it to 1e-13 relative.
double wall_max_stiffness_term(double damping_term, double device_term, int delay_samples);

/// The wall on a device of damping b (N s/m): the bound, passive, and the
/// largest passive K at this B: 2 s / T with s from wall_max_stiffness_term.
PassivityVerdict analyze_wall_passivity(double stiffness, double damping, double period_s, int delay_samples,
                                        std::optional<double> device_damping);

/// Hulin's plane: the largest alpha = K T^2/m passive at beta = B T/m on a
/// device of normalized damping device_beta = b T/m (2 s from the same solve).
double passive_alpha_max(double beta, double device_beta, int delay_samples);

struct PassivityBoundaryPoint {
  double beta = 0.0;
  double alpha = 0.0;
};
/// passive_alpha_max at beta = 0 and at count - 1 betas log-spaced from
/// device_beta * 1e-4 up to device_beta (where it reaches 0). Empty for
/// device_beta <= 0 (only alpha = beta = 0 is passive) or count < 2.
std::vector<PassivityBoundaryPoint> passivity_boundary(double device_beta, int delay_samples, int count);

/// Any linear scene (world::DiscreteLinearScene, F on the device = G x),
/// plus extra_delay_samples of device delay: H = -z^-(d_scene + extra) G.
/// The poles of H (eigenvalues of a that are controllable and observable)
/// decide first, through judge_radius (tolerance 1e-12 + 64 eps rho(a)):
/// on the unit circle: unbounded, "not passive at any device damping: the
/// virtual body's undamped mode at f Hz"; outside: unbounded, unstable.
PassivityBound scene_passivity(const world::DiscreteLinearScene& scene, double period_s,
                               int extra_delay_samples);

/// A spring scene as the catalog builds it: SpringDamping::none when b = 0,
/// else `reference` (relative or absolute).
struct SpringPassivityInput {
  world::SpringParameters parameters;  ///< k, J (or m), b, integrator
  bool damping_auto = false;           ///< b = T k (Freudenberg 2.24), also while max_stiffness varies k
  world::SpringDamping reference = world::SpringDamping::relative;
  double period_s = 1e-3;
  int delay_samples = 0;  ///< device delay (the scene has none of its own)
};
PassivityBound spring_passivity(const SpringPassivityInput& input);
/// The bound, passive on b, and the largest passive k (see PassivityVerdict).
PassivityVerdict analyze_spring_passivity(const SpringPassivityInput& input,
                                          std::optional<double> device_damping);

}  // namespace hapticd::analysis
