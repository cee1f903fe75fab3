#pragma once
/// \file
/// Closed form of the second-order body behind every linear scene, driven by
/// the held inputs the scene actually sees (the reference of the accuracy
/// study, analysis/accuracy_study.hpp):
///   e'' + 2 sigma e' + w_n^2 e = g0 + gp [0 <= t < tp],   e(0) = e0, e'(0) = 0.
/// With sigma = 0, g0 = gp = 0 this is Freudenberg 2.3-2.4: e = w - z0 =
/// -z0 cos(w_n t). The damped counterpart uses the free response phi and the
/// impulse response h of s^2 + 2 sigma s + w_n^2:
///   phi(t) = e^{-sigma t} (cos(w_d t) + sigma/w_d sin(w_d t)),   (phi(0) = 1, phi'(0) = 0)
///   h(t)   = e^{-sigma t} sin(w_d t) / w_d,                      (h(0) = 0, h'(0) = 1)
/// w_d = sqrt(w_n^2 - sigma^2) (cosh/sinh when overdamped, 1 and t when
/// critically damped). Then phi' = -w_n^2 h, and the step response to a unit
/// forcing is (1 - phi)/w_n^2 with derivative h, so
///   e(t)  = e0 phi(t) + g0 (1 - phi(t))/w_n^2 + gp P(t),
///   e'(t) = -e0 w_n^2 h(t) + g0 h(t) + gp P'(t),
///   P(t)  = (1 - phi(t))/w_n^2 for t < tp, (phi(t - tp) - phi(t))/w_n^2 after,
///   P'(t) = h(t) for t < tp, h(t) - h(t - tp) after.
/// The pulse difference is formed from e^{lambda t} (e^{-lambda tp} - 1) with
/// expm1, so it keeps its digits when w_n tp is small.

namespace hapticd::analysis {

struct SecondOrderStep {
  double natural_frequency = 1.0;  ///< w_n, rad/s, > 0
  double decay = 0.0;              ///< sigma = zeta w_n = b / (2 J), 1/s, >= 0
  double initial = 0.0;            ///< e0 (e'(0) = 0)
  double forcing = 0.0;            ///< g0, held from t = 0 on
  double pulse = 0.0;              ///< gp, held over [0, tp)
  double pulse_width = 0.0;        ///< tp, s (0: no pulse)

  double position(double t) const noexcept;  ///< e(t)
  double velocity(double t) const noexcept;  ///< e'(t)
};

/// phi(t) and h(t) above, for w_n > 0, sigma >= 0, t >= 0.
struct FreeResponse {
  double phi = 1.0;
  double h = 0.0;
};
FreeResponse free_response(double natural_frequency, double decay, double t) noexcept;

}  // namespace hapticd::analysis
