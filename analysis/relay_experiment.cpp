#include "analysis/relay_experiment.hpp"

#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/Dense>
#include <unsupported/Eigen/FFT>

#include "analysis/optimize.hpp"

namespace hapticd::analysis {

namespace {

/// K_u from the first harmonic at w over samples [first, first + n).
std::optional<RelayEstimate> fit_first_harmonic(std::span<const double> position, double period_s,
                                                double relay_amplitude, double w, Eigen::Index first,
                                                Eigen::Index n, int cycles) {
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

bool finite_input(std::span<const double> position, double period_s, double relay_amplitude) {
  if (!(period_s > 0.0) || !(relay_amplitude > 0.0) || position.size() < 8) return false;
  for (double y : position) {
    if (!std::isfinite(y)) return false;
  }
  return true;
}

}  // namespace

std::optional<RelayEstimate> estimate_relay(std::span<const double> position, double period_s,
                                            double relay_amplitude) {
  if (!finite_input(position, period_s, relay_amplitude)) return std::nullopt;
  double mean = 0.0;
  for (double y : position) mean += y;
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
  return fit_first_harmonic(position, period_s, relay_amplitude, w, first, last - first + 1, cycles);
}

std::optional<RelayEstimate> estimate_relay_at(std::span<const double> position, double period_s,
                                               double relay_amplitude, double frequency_hz) {
  if (!finite_input(position, period_s, relay_amplitude) || !(frequency_hz > 0.0)) return std::nullopt;
  const double samples_per_cycle = 1.0 / (frequency_hz * period_s);
  const auto cycles = static_cast<int>(std::floor(static_cast<double>(position.size()) / samples_per_cycle));
  if (cycles < 2) return std::nullopt;
  const auto n = static_cast<Eigen::Index>(std::llround(cycles * samples_per_cycle));
  return fit_first_harmonic(position, period_s, relay_amplitude, 2.0 * std::numbers::pi * frequency_hz, 0,
                            std::min<Eigen::Index>(n, static_cast<Eigen::Index>(position.size())), cycles);
}

namespace {

using cd = std::complex<double>;

/// The record cut into Hann-windowed, mean-free segments of length L with half overlap.
struct Segments {
  std::size_t length = 0;
  std::vector<std::vector<double>> force, position;
  std::vector<double> window;
};

Segments segment(std::span<const double> position, std::span<const double> force) {
  Segments s;
  std::size_t length = 64;
  while (length * 2 <= position.size() / 2 && length < 65536) length *= 2;
  s.length = length;
  s.window.resize(length);
  for (std::size_t i = 0; i < length; ++i) {
    s.window[i] =
        0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(length));
  }
  auto cut = [&](std::span<const double> x, std::size_t start) {
    double mean = 0.0;
    for (std::size_t i = 0; i < length; ++i) mean += x[start + i];
    mean /= static_cast<double>(length);
    std::vector<double> out(length);
    for (std::size_t i = 0; i < length; ++i) out[i] = (x[start + i] - mean) * s.window[i];
    return out;
  };
  for (std::size_t start = 0; start + length <= position.size(); start += length / 2) {
    s.force.push_back(cut(force, start));
    s.position.push_back(cut(position, start));
  }
  return s;
}

/// sum_n x[n] e^{-j w n}, w in rad per sample.
cd dtft(const std::vector<double>& x, double w) {
  const cd step = std::polar(1.0, -w);
  cd phasor = 1.0;
  cd sum = 0.0;
  for (std::size_t n = 0; n < x.size(); ++n) {
    sum += x[n] * phasor;
    phasor *= step;
    if ((n & 1023u) == 1023u) phasor = std::polar(1.0, -w * static_cast<double>(n + 1));  // no drift
  }
  return sum;
}

struct Averaged {
  double uu = 0.0, yy = 0.0;
  cd yu = 0.0;
};

Averaged averaged_at(const Segments& s, double w) {
  Averaged a;
  for (std::size_t k = 0; k < s.force.size(); ++k) {
    const cd u = dtft(s.force[k], w);
    const cd y = dtft(s.position[k], w);
    a.uu += std::norm(u);
    a.yy += std::norm(y);
    a.yu += y * std::conj(u);
  }
  return a;
}

}  // namespace

std::optional<RelaySpectrum> relay_spectrum(std::span<const double> position, std::span<const double> force,
                                            double period_s) {
  if (!(period_s > 0.0) || position.size() != force.size() || position.size() < 128) return std::nullopt;
  for (std::size_t i = 0; i < position.size(); ++i) {
    if (!std::isfinite(position[i]) || !std::isfinite(force[i])) return std::nullopt;
  }
  const Segments s = segment(position, force);
  const std::size_t length = s.length;
  // Coarse: the averaged periodograms on the FFT grid.
  Eigen::FFT<double> fft;
  std::vector<double> uu(length / 2, 0.0), yy(length / 2, 0.0);
  std::vector<cd> spectrum;
  for (std::size_t k = 0; k < s.force.size(); ++k) {
    fft.fwd(spectrum, s.force[k]);
    for (std::size_t b = 0; b < length / 2; ++b) uu[b] += std::norm(spectrum[b]);
    fft.fwd(spectrum, s.position[k]);
    for (std::size_t b = 0; b < length / 2; ++b) yy[b] += std::norm(spectrum[b]);
  }
  std::size_t peak = 2;
  for (std::size_t b = 2; b + 1 < length / 2; ++b) {
    if (uu[b] * yy[b] > uu[peak] * yy[peak]) peak = b;
  }
  if (!(uu[peak] > 0.0)) return std::nullopt;
  // Fine: between the neighbouring bins, on the segments' DTFT.
  const double bin = 2.0 * std::numbers::pi / static_cast<double>(length);
  const auto negative_product = [&](double w) {
    const Averaged a = averaged_at(s, w);
    return -(a.uu * a.yy);
  };
  const Minimum m = golden_section_minimize(negative_product, (static_cast<double>(peak) - 1.0) * bin,
                                            (static_cast<double>(peak) + 1.0) * bin, 1e-6 * bin);
  const Averaged a = averaged_at(s, m.x);
  if (!(a.uu > 0.0) || std::abs(a.yu) == 0.0) return std::nullopt;
  RelaySpectrum r;
  r.frequency_hz = m.x / (2.0 * std::numbers::pi * period_s);
  r.response = a.yu / a.uu;
  r.ultimate_gain = 1.0 / std::abs(r.response);
  r.gain_margin_db = 20.0 * std::log10(r.ultimate_gain);
  r.phase_deg = std::arg(r.response) * 180.0 / std::numbers::pi;
  if (r.phase_deg > 0.0) r.phase_deg -= 360.0;
  r.segments = static_cast<int>(s.force.size());
  r.bin_hz = 1.0 / (static_cast<double>(length) * period_s);
  return r;
}

RelayAnalysis analyze_relay(std::span<const double> position, std::span<const double> force, double period_s,
                            double relay_amplitude) {
  RelayAnalysis a;
  a.spectrum = relay_spectrum(position, force, period_s);
  const std::size_t half = position.size() / 2;
  const auto first = relay_spectrum(position.first(half), force.first(half), period_s);
  const auto second = relay_spectrum(position.subspan(half), force.subspan(half), period_s);
  if (a.spectrum && first && second) {
    a.first_half_hz = first->frequency_hz;
    a.second_half_hz = second->frequency_hz;
    const auto agrees = [&](const RelaySpectrum& part) {
      return std::abs(part.frequency_hz / a.spectrum->frequency_hz - 1.0) < 0.03 &&
             std::abs(part.gain_margin_db - a.spectrum->gain_margin_db) < 1.0;
    };
    a.steady = agrees(*first) && agrees(*second);
  }
  a.describing_function =
      a.spectrum ? estimate_relay_at(position, period_s, relay_amplitude, a.spectrum->frequency_hz)
                 : estimate_relay(position, period_s, relay_amplitude);
  return a;
}

}  // namespace hapticd::analysis
