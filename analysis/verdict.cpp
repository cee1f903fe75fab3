#include "analysis/verdict.hpp"

#include <cmath>
#include <limits>

#include "world/text.hpp"

namespace hapticd::analysis {

namespace {

std::string_view overflow_kind(double value) { return std::isnan(value) ? "is NaN" : "overflowed to inf"; }

int severity(VerdictState state) {
  switch (state) {
    case VerdictState::stable:
      return 0;
    case VerdictState::marginal:
      return 1;
    case VerdictState::unstable:
      return 2;
    case VerdictState::cannot_assess:
      return 3;
  }
  return 3;
}

Verdict cannot_assess(std::string reason) { return {VerdictState::cannot_assess, std::move(reason)}; }

}  // namespace

std::string_view to_string(VerdictState state) noexcept {
  switch (state) {
    case VerdictState::stable:
      return "stable";
    case VerdictState::marginal:
      return "marginal";
    case VerdictState::unstable:
      return "unstable";
    case VerdictState::cannot_assess:
      return "cannot_assess";
  }
  return "cannot_assess";
}

std::string short_number(double value) {
  return world::text::format_significant(value, world::text::precision::coarse);
}

void NumericRecord::check_finite(std::string_view what, double value) {
  if (!std::isfinite(value)) require(false, std::string(what) + " " + std::string(overflow_kind(value)));
}

void NumericRecord::check_finite(std::string_view what, const Eigen::MatrixXd& matrix) {
  for (const double x : matrix.reshaped()) {
    if (!std::isfinite(x)) {
      require(false, "an entry of " + std::string(what) + " " + std::string(overflow_kind(x)));
      return;
    }
  }
}

void NumericRecord::check_finite(std::string_view what, std::span<const std::complex<double>> values) {
  for (const auto& z : values) {
    if (!std::isfinite(z.real()) || !std::isfinite(z.imag())) {
      require(false, "a value of " + std::string(what) + " is not finite (" + short_number(z.real()) + " + " +
                         short_number(z.imag()) + "j)");
      return;
    }
  }
}

void NumericRecord::require(bool ok, std::string_view reason) {
  if (!ok && reason_.empty()) reason_ = reason;
}

Verdict judge_radius(double radius, double tolerance, double period_s, const NumericRecord& record,
                     std::string_view rounding_source) {
  if (!record.clean()) return cannot_assess(record.reason());
  if (!std::isfinite(radius))
    return cannot_assess("the spectral radius " + std::string(overflow_kind(radius)));
  if (!std::isfinite(tolerance) || !(period_s > 0.0))
    return cannot_assess("the rounding bound is not finite");
  const double distance = std::abs(radius - 1.0);
  if (distance <= tolerance) {
    const double hidden_per_second = std::exp(std::log1p(tolerance) / period_s);
    if (tolerance > max_radius_tolerance || hidden_per_second > max_hidden_growth_per_second) {
      std::string source =
          rounding_source.empty() ? std::string() : " (" + std::string(rounding_source) + ")";
      return cannot_assess("the spectral radius " + short_number(radius) + " is known only to +-" +
                           short_number(tolerance) + source +
                           ", too coarse to tell growth from decay (a verdict needs +-" +
                           short_number(max_radius_tolerance) + " and at most 1 % hidden growth per second)");
    }
    return {VerdictState::marginal, {}};
  }
  return {radius < 1.0 ? VerdictState::stable : VerdictState::unstable, {}};
}

const Verdict& worse(const Verdict& a, const Verdict& b) noexcept {
  return severity(b.state) > severity(a.state) ? b : a;
}

void check_zoh(std::string_view what, const world::ContinuousStateSpace& continuous,
               const world::DiscreteStateSpace& discrete, NumericRecord& record) {
  const std::string name(what);
  NumericRecord local;
  const Spectrum modes = spectrum(name + "'s A", continuous.a, local);
  local.check_finite(name + "'s B", continuous.b);
  local.check_finite(name + "'s e^(A T)", discrete.ad);
  local.check_finite(name + "'s int e^(A s) ds B", discrete.bd);
  if (local.clean()) {
    const double t = discrete.period_s;
    const double scale = modes.radius * t;
    const double rounding = 64.0 * std::numeric_limits<double>::epsilon() * scale;
    local.require(rounding <= max_radius_tolerance,
                  "the fastest mode of " + name + " turns or decays by " + short_number(scale) +
                      " per period: its exact discretization e^(A T) is rounded to +-" +
                      short_number(rounding) + ", too coarse for a verdict (+-" +
                      short_number(max_radius_tolerance) + ")");
    const Eigen::Index n = continuous.a.rows();
    const double det = discrete.ad.determinant();
    const double expected = std::exp(continuous.a.trace() * t);
    local.require(std::abs(det - expected) <= 1e-6 * std::max(1.0, expected),
                  "the exact discretization of " + name + " is wrong: det e^(A T) = " + short_number(det) +
                      ", not e^(tr(A) T) = " + short_number(expected));
    const Eigen::MatrixXd lhs = continuous.a * discrete.bd;
    const Eigen::MatrixXd rhs = (discrete.ad - Eigen::MatrixXd::Identity(n, n)) * continuous.b;
    const double size =
        (continuous.a.cwiseAbs() * discrete.bd.cwiseAbs()).maxCoeff() +
        ((discrete.ad - Eigen::MatrixXd::Identity(n, n)).cwiseAbs() * continuous.b.cwiseAbs()).maxCoeff();
    local.require((lhs - rhs).cwiseAbs().maxCoeff() <= 1e-6 * size,
                  "the exact discretization of " + name + " is wrong: A Bd differs from (Ad - I) B");
  }
  if (!local.clean()) record.require(false, local.reason());
}

Spectrum spectrum(std::string_view what, const Eigen::MatrixXd& matrix, NumericRecord& record) {
  Spectrum s;
  NumericRecord entries;
  entries.check_finite(what, matrix);
  if (!entries.clean()) {  // Eigen's QR iteration on inf/NaN yields NaN or garbage: do not run it
    record.require(false, entries.reason());
    s.radius = std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  if (matrix.size() == 0) return s;
  const Eigen::EigenSolver<Eigen::MatrixXd> solver(matrix, false);
  if (solver.info() != Eigen::Success) {
    record.require(false, "the eigenvalues of " + std::string(what) + " did not converge");
    s.radius = std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  const Eigen::VectorXcd& ev = solver.eigenvalues();
  s.eigenvalues.assign(ev.data(), ev.data() + ev.size());
  NumericRecord values;
  values.check_finite("the eigenvalues of " + std::string(what), s.eigenvalues);
  if (!values.clean()) {
    record.require(false, values.reason());
    s.radius = std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  for (const auto& z : s.eigenvalues) s.radius = std::max(s.radius, std::abs(z));
  return s;
}

}  // namespace hapticd::analysis
