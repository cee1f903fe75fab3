#pragma once
/// \file
/// Ultimate gain and frequency from a relay experiment (Diaz & Gil V,
/// Astrom & Hagglund): a relay of amplitude h drives the device into a limit
/// cycle; the force is a square wave whose first harmonic has amplitude
/// 4h/pi, so by the describing function K_u = 4 h / (pi a), a being the
/// first-harmonic amplitude of the position at the oscillation frequency.

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

}  // namespace hapticd::analysis
