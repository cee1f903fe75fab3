#pragma once
/// \file
/// Ultimate gain and frequency from a relay experiment (Diaz & Gil V,
/// Astrom & Hagglund): a relay of amplitude h drives the device into a limit
/// cycle; the force is a square wave whose first harmonic has amplitude
/// 4h/pi, so by the describing function K_u = 4 h / (pi a), a being the
/// first-harmonic amplitude of the position at the oscillation frequency.

#include <complex>
#include <optional>
#include <span>

namespace hapticd::analysis {

struct RelayEstimate {
  double ultimate_gain = 0.0;        ///< K_u = 4h/(pi a), N/m
  double gain_margin_db = 0.0;       ///< 20 log10(K_u)
  double frequency_rad_per_s = 0.0;  ///< oscillation frequency
  double frequency_hz = 0.0;
  double amplitude = 0.0;  ///< a, first-harmonic position amplitude, m
  int cycles = 0;          ///< whole cycles used
};

/// From position samples (steady state, period T) and the relay amplitude h:
/// the frequency from the mean spacing of upward crossings of the mean
/// (linearly interpolated), the amplitude from a least-squares fit of
/// a0 + a cos(w t) + b sin(w t) over those whole cycles. Nothing if fewer
/// than two whole cycles are present or the input is not finite/positive.
std::optional<RelayEstimate> estimate_relay(std::span<const double> position, double period_s,
                                            double relay_amplitude);

/// The describing-function estimate at a given oscillation frequency: the
/// first-harmonic amplitude a of the position from a least-squares fit of
/// a0 + a cos(w t) + b sin(w t) over the whole cycles in the record, K_u =
/// 4 h / (pi a). Used with the spectral peak's frequency where the position
/// crosses its mean more than twice a cycle (a cable mode ringing after each
/// switch). Nothing for fewer than two whole cycles or non-finite input.
std::optional<RelayEstimate> estimate_relay_at(std::span<const double> position, double period_s,
                                               double relay_amplitude, double frequency_hz);

/// Diaz & Gil V: "Oscillation frequencies were found by determining the
/// maximum peak of the average power spectral density of both signals. Gain
/// margins were obtained by evaluating the estimated empirical transfer
/// function at that frequency."
struct RelaySpectrum {
  double frequency_hz = 0.0;  ///< the peak of P_uu(f) P_yy(f), refined between FFT bins
  /// Empirical transfer function P_yu / P_uu at the peak: the sampled
  /// response G(e^{j w T}) from the recorded force to the position, m/N.
  std::complex<double> response;
  double ultimate_gain = 0.0;   ///< 1 / |response|, N/m
  double gain_margin_db = 0.0;  ///< 20 log10(ultimate_gain)
  double phase_deg = 0.0;       ///< arg(response) in (-360, 0]
  int segments = 0;             ///< Welch segments averaged
  double bin_hz = 0.0;          ///< FFT bin width of a segment (before refinement)
};

/// Welch's averaged spectra (Hann window, segments of a power of two with
/// half overlap, each segment's mean removed) of the force and the position,
/// the peak of their product above the second bin, refined by a
/// golden-section search on the segments' DTFT, and the cross spectrum over
/// the force's there. Nothing if the record is shorter than 128 samples, the
/// sizes differ, a value is not finite or the force never changes.
std::optional<RelaySpectrum> relay_spectrum(std::span<const double> position, std::span<const double> force,
                                            double period_s);

/// Both estimates of one steady-state record, and whether it was steady.
struct RelayAnalysis {
  /// The spectral peak of each half of the record agrees with the whole's
  /// (frequency within 3 %, gain within 1 dB): a limit cycle, not a
  /// transient or a switch between two cycles during the run.
  bool steady = false;
  double first_half_hz = 0.0, second_half_hz = 0.0;
  /// 4 h / (pi a) at the spectral peak's frequency (estimate_relay_at), or
  /// with the frequency from the crossings when there is no spectrum.
  std::optional<RelayEstimate> describing_function;
  std::optional<RelaySpectrum> spectrum;  ///< ETFE at the spectral peak (Diaz & Gil)
};
RelayAnalysis analyze_relay(std::span<const double> position, std::span<const double> force, double period_s,
                            double relay_amplitude);

}  // namespace hapticd::analysis
