#pragma once
/// \file
/// The one rule every stability verdict in analysis/ (and the daemon's gate)
/// goes through: a verdict comes only from finite numbers precise enough to
/// decide it. An analysis records each intermediate it derives the verdict
/// from in a NumericRecord (a matrix entry that overflowed, a NaN root, a
/// term lost in rounding); judge_radius() turns a spectral radius into a
/// verdict and answers cannot_assess, with the first recorded reason, when the
/// record is not clean, the radius is not finite, or the radius is known too
/// coarsely to tell growth from decay. Nothing else sets a verdict.

#include <complex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Dense>

#include "world/state_space.hpp"

namespace hapticd::analysis {

enum class VerdictState { stable, marginal, unstable, cannot_assess };
/// "stable", "marginal", "unstable", "cannot_assess" (JSON and recordings).
std::string_view to_string(VerdictState state) noexcept;

/// Why the numbers behind a verdict are not usable; the first problem wins.
class NumericRecord {
 public:
  /// Records "<what> overflowed to inf" / "<what> is NaN" unless `value` is finite.
  void check_finite(std::string_view what, double value);
  /// Records "an entry of <what> overflowed to inf" / "... is NaN" unless all are finite.
  void check_finite(std::string_view what, const Eigen::MatrixXd& matrix);
  void check_finite(std::string_view what, std::span<const std::complex<double>> values);
  /// Records `reason` unless `ok` (precision lost: the numbers are finite but meaningless).
  void require(bool ok, std::string_view reason);
  bool clean() const noexcept { return reason_.empty(); }
  const std::string& reason() const noexcept { return reason_; }

 private:
  std::string reason_;
};

struct Verdict {
  VerdictState state = VerdictState::cannot_assess;
  std::string reason = "not analyzed";  ///< why it cannot be assessed; empty otherwise
  /// Does not grow: stable or marginal. Never true for cannot_assess.
  bool stable() const noexcept { return state == VerdictState::stable || state == VerdictState::marginal; }
  bool marginal() const noexcept { return state == VerdictState::marginal; }
  bool assessed() const noexcept { return state != VerdictState::cannot_assess; }
};

/// A radius known to +-tolerance decides nothing when the tolerance exceeds
/// this: the daemon's gate accepts a closed loop up to 1 + 1e-7 (the double
/// root of the free drift is computed only to ~sqrt(eps)), so a verdict must
/// resolve |lambda| at least that finely.
inline constexpr double max_radius_tolerance = 1e-7;
/// ... nor when the growth it could hide, (1 + tolerance)^(1/T), exceeds 1 %
/// per second (short periods).
inline constexpr double max_hidden_growth_per_second = 1.01;

/// The verdict on a discrete system whose spectral radius is `radius`,
/// computed to +-`tolerance` (rounding), sampled every `period_s`:
/// cannot_assess if `record` is not clean, radius or tolerance are not
/// finite, or the tolerance is too coarse (above) while the radius lies
/// within it of 1; else marginal if |radius - 1| <= tolerance, stable below,
/// unstable above. `rounding_source` names what sets the tolerance, for the reason.
Verdict judge_radius(double radius, double tolerance, double period_s, const NumericRecord& record,
                     std::string_view rounding_source = {});

/// The worse of two verdicts on parts of one system: cannot_assess, then
/// unstable, then marginal, then stable (the first's reason on a tie).
const Verdict& worse(const Verdict& a, const Verdict& b) noexcept;

struct Spectrum {
  std::vector<std::complex<double>> eigenvalues;
  double radius = 0.0;  ///< max |eigenvalue|; NaN if the matrix or an eigenvalue is not finite
};
/// Eigenvalues of `matrix` (named `what` in the record), recording a
/// non-finite entry (the eigenvalues are then not computed) or eigenvalue.
Spectrum spectrum(std::string_view what, const Eigen::MatrixXd& matrix, NumericRecord& record);

/// Checks an exact (ZOH) discretization Ad = e^(A T), Bd = int_0^T e^(As) ds B
/// of `what` before a verdict rests on it, recording the first failure:
///  - entries finite;
///  - the identities of the exact map: det Ad = e^(tr(A) T) (Jacobi) and
///    A Bd = (Ad - I) B, to 1e-6 relative (gross failures: a 1e-100 kg mass
///    gave Ad = 0, Bd = 0);
///  - its rounding, about 64 eps per unit of rho(A) T (the fastest mode's
///    angle or decay per period; the integrators' tolerance in
///    integrator_stability.hpp is this for the spring), at most
///    max_radius_tolerance (a 1e-20 kg mass with b = 3.5 N s/m: rho T = 3.5e17,
///    and K_CR came out 1.04e7 N/m instead of 2 b / T = 7000 N/m).
void check_zoh(std::string_view what, const world::ContinuousStateSpace& continuous,
               const world::DiscreteStateSpace& discrete, NumericRecord& record);

/// "%.3g" for reasons and messages ("1e+11", "0.35").
std::string short_number(double value);

}  // namespace hapticd::analysis
