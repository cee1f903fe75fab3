#pragma once
/// \file
/// Identification of the device model from a periodic excitation (the chirp
/// scene), as Diaz & Gil fit their cable (section II, Fig. 4): the measured
/// frequency response, then a least-squares fit of the rigid model
/// (Diaz & Gil eq. 2: mass or inertia, viscous damping) or of the two-mass
/// model (eq. 5-9: m_m, m_d, b_m, b_d, k_c, b_c), each with the delay the
/// device adds (in periods, fractional) and Coulomb friction, with 95 %
/// confidence intervals from the linearized fit and a word where the data
/// cannot tell two parameters apart.
///
/// The model is the exact sampled one the stability gate uses
/// (critical_stiffness.hpp's DelayedZoh): Y_k = G_u(e^{j w_k T}) U_k +
/// F_c G_h(e^{j w_k T}) S_k, G_u from the motor force (with the delay), G_h
/// from a force on the mass (rigid) or body (two-mass) without delay, S_k the
/// spectrum of -sign(velocity): Coulomb friction as a known waveform of
/// unknown level. The fit minimizes sum_k |Y_k - model_k|^2 over the excited
/// bins (output error; encoder quantization is white, so equal weights).

#include <complex>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/least_squares.hpp"
#include "world/plant.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::analysis {

enum class IdentifiedPlant { rigid, two_mass };
/// What held the device during the run: nothing (free), a hand holding it
/// still (the body locked, Diaz & Gil's cable experiment), a hand holding it
/// through a spring-damper (an unknown stiffness to the frame, fitted; its
/// damping cannot be told from the device's).
enum class HandCondition { free, hold, spring };
std::string_view to_string(IdentifiedPlant plant) noexcept;  ///< "rigid", "two-mass"
std::string_view to_string(HandCondition hand) noexcept;     ///< "free", "hold", "spring"
std::optional<IdentifiedPlant> parse_identified_plant(std::string_view text) noexcept;
std::optional<HandCondition> parse_hand_condition(std::string_view text) noexcept;

/// The measured frequency response at the harmonics of the excitation.
struct FrequencyResponse {
  double period_s = 0.0;
  std::int64_t sweep_steps = 0;  ///< samples per excitation period N
  int sweeps = 0;                ///< periods averaged
  std::vector<double> frequency_hz;
  std::vector<std::complex<double>> force;          ///< U_k, N (or N m)
  std::vector<std::complex<double>> position;       ///< Y_k, m (or rad)
  std::vector<std::complex<double>> friction_sign;  ///< S_k: spectrum of -sign(v)
  /// Standard deviation of Y_k / U_k over the sweeps, relative to its mean (0 with one sweep).
  std::vector<double> spread;
  std::complex<double> response(std::size_t k) const { return position[k] / force[k]; }
  std::size_t size() const noexcept { return frequency_hz.size(); }
};

/// From a record of a periodic excitation with `sweep_steps` samples per
/// period: the first `skip` periods are dropped (the transient), a free
/// device's constant drift (y[n + N] - y[n] the same for every n) is taken
/// out, the remaining periods are averaged sample by sample, and the DFT of
/// that period is kept at the bins within [f_low, f_high]. Throws
/// std::invalid_argument naming what is missing (fewer than one period after
/// the skip, no bin in the band, non-finite samples).
FrequencyResponse measure_frequency_response(std::span<const double> position, std::span<const double> force,
                                             double period_s, std::int64_t sweep_steps, double f_low,
                                             double f_high, int skip = 1);

struct IdentifiedParameter {
  std::string name;  ///< the loopback driver's key where there is one: mass, damping, motor_mass, ...
  std::string unit;
  double value = 0.0;
  double half_width = 0.0;  ///< 95 % confidence
  std::string note;         ///< e.g. "includes the hand's damping"
};

/// Two parameters the data cannot tell apart: |correlation| > 0.99 and at
/// least one of them known only to worse than 5 % (95 %): the data fixes a
/// combination of them, not each.
struct Confounded {
  std::string first, second;
  double correlation = 0.0;
  std::string sum_name;  ///< "motor_damping + body_damping" when they share a unit and add up; else empty
  double sum = 0.0;
  double sum_half_width = 0.0;
};

struct Identification {
  IdentifiedPlant plant_kind = IdentifiedPlant::rigid;
  HandCondition hand = HandCondition::free;
  std::vector<IdentifiedParameter> parameters;
  std::vector<Confounded> confounded;
  std::vector<std::string> notes;
  LeastSquaresFit fit;
  /// The fitted plant (inputs [motor, hand]; with the hand's spring when it
  /// held one): the device model for the stability gate only when `complete`.
  world::LinearPlant plant;
  world::Sensor sensor = world::Sensor::motor;
  bool complete = false;  ///< free hand: every parameter of the device model was identified
  double delay_periods = 0.0;
  double coulomb = 0.0;
  double fit_error = 0.0;                    ///< rms |Y - Y_fit| / rms |Y| over the bins
  std::vector<std::complex<double>> fitted;  ///< fitted force -> position response at each bin

  const IdentifiedParameter* find(std::string_view name) const noexcept;
  double value(std::string_view name) const;  ///< throws std::out_of_range if absent
};

/// Fits `kind` with the hand as it was. Throws std::invalid_argument when the
/// condition identifies nothing (a hand holding a rigid device still; the
/// body sensed while the hand holds it) or the data cannot start a fit (no
/// cable mode in the band for a two-mass fit: the message says what band to excite).
Identification identify(const FrequencyResponse& data, IdentifiedPlant kind, HandCondition hand,
                        world::Motion motion, world::Sensor sensor = world::Sensor::motor);

/// The model's force -> position response at f (the fitted curve, for figures).
std::complex<double> identified_response(const Identification& identification, double frequency_hz,
                                         double period_s);

}  // namespace hapticd::analysis
