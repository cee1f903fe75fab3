#include "analysis/relay_experiment.hpp"

#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Dense>

namespace hapticd::analysis {

std::optional<RelayEstimate> estimate_relay(std::span<const double> position, double period_s,
                                            double relay_amplitude) {
  if (!(period_s > 0.0) || !(relay_amplitude > 0.0) || position.size() < 8) return std::nullopt;
  double mean = 0.0;
  for (double y : position) {
    if (!std::isfinite(y)) return std::nullopt;
    mean += y;
  }
  mean /= static_cast<double>(position.size());

  std::vector<double> up;  // upward crossings, in samples (fractional)
  for (std::size_t i = 1; i < position.size(); ++i) {
    const double a = position[i - 1] - mean, b = position[i] - mean;
    if (a < 0.0 && b >= 0.0) up.push_back(static_cast<double>(i - 1) + a / (a - b));
  }
  if (up.size() < 3) return std::nullopt;
  const int cycles = static_cast<int>(up.size()) - 1;
  const double samples_per_cycle = (up.back() - up.front()) / cycles;
  const double w = 2.0 * std::numbers::pi / (samples_per_cycle * period_s);

  const auto first = static_cast<Eigen::Index>(std::ceil(up.front()));
  const auto last = static_cast<Eigen::Index>(std::floor(up.back()));
  const Eigen::Index n = last - first + 1;
  Eigen::MatrixXd basis(n, 3);
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t = static_cast<double>(first + i) * period_s;
    basis(i, 0) = 1.0;
    basis(i, 1) = std::cos(w * t);
    basis(i, 2) = std::sin(w * t);
    y(i) = position[static_cast<std::size_t>(first + i)];
  }
  const Eigen::Vector3d fit = basis.colPivHouseholderQr().solve(y);
  const double amplitude = std::hypot(fit(1), fit(2));
  if (!(amplitude > 0.0)) return std::nullopt;

  RelayEstimate e;
  e.amplitude = amplitude;
  e.ultimate_gain = 4.0 * relay_amplitude / (std::numbers::pi * amplitude);
  e.gain_margin_db = 20.0 * std::log10(e.ultimate_gain);
  e.frequency_rad_per_s = w;
  e.frequency_hz = w / (2.0 * std::numbers::pi);
  e.cycles = cycles;
  return e;
}

}  // namespace hapticd::analysis
