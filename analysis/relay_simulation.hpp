#pragma once
/// \file
/// The relay experiment of Diaz & Gil V simulated as hapticd runs it, to
/// quantify the relay's own bias and to tell which phase crossover a relay
/// settled on.
///
/// The relay does not measure K_CR exactly even on a perfect model: the
/// describing function keeps only the first harmonic (the higher harmonics of
/// a square wave through a plant with delay and damping move the position's
/// zero crossings, where the relay switches, by a fraction of a degree of the
/// fundamental), and a sampled relay switches only at samples. A fraction of
/// a degree matters because the loop phase of a mass with little damping is
/// nearly flat near -180 deg: the oscillation settles where the phase is
/// -180 deg plus that fraction, ~10 % below the crossover in frequency and,
/// with |G| ~ 1 / (m w^2), twice that in gain. simulate_relay() runs the very
/// relay scene of world/ against the exact zero-order-hold plant, with the
/// device's delay, encoder quantization and torque limit, so the same
/// estimators on its record give that bias for this device, delay and relay.

#include <cstdint>
#include <optional>
#include <vector>

#include "analysis/critical_stiffness.hpp"
#include "analysis/relay_experiment.hpp"
#include "world/plant.hpp"

namespace hapticd::analysis {

/// One relay run: the device model and the relay scene's settings.
struct SampledRelay {
  world::LinearPlant plant;  ///< inputs [motor force, hand force]; the hand is left free
  world::Sensor sensor = world::Sensor::motor;
  double period_s = 1e-3;
  int device_delay = 0;       ///< output delay the device itself adds, periods
  double resolution = 0.0;    ///< encoder step (floor quantization, as the loopback device); 0: none
  double torque_limit = 0.0;  ///< 0: none
  double amplitude = 1.0;     ///< relay h
  double hysteresis = 0.0;    ///< relay eps
  int delay_samples = 0;      ///< relay t_d in periods (the relay scene's delay line)
  /// The relay's reference lies this far below the position where the run
  /// starts (at rest): the initial condition.
  double start_offset = 0.0;
};

struct RelayRecord {
  std::vector<double> position;  ///< what the relay read, per period
  std::vector<double> force;     ///< what it commanded (after the torque limit)
};

/// Runs `steps` periods from rest. Throws std::invalid_argument for a
/// period <= 0, negative delays or a delay beyond the relay's line.
RelayRecord simulate_relay(const SampledRelay& relay, std::int64_t steps);

/// Total loop delay of the run: device delay + relay delay, in seconds.
double loop_delay_s(const SampledRelay& relay) noexcept;

/// The crossover an oscillation at `frequency_hz` sits on: the nearest in
/// log frequency, if within `tolerance` (a factor, e.g. 1.25); else nothing.
std::optional<std::size_t> matching_crossover(const std::vector<PhaseCrossover>& crossovers,
                                              double frequency_hz, double tolerance = 1.25);

/// Index of the crossover that sets K_CR (the smallest -1/H); nothing if none.
std::optional<std::size_t> critical_crossover(const std::vector<PhaseCrossover>& crossovers);

/// Every phase crossover of the model's loop, as critical_stiffness() scans them.
std::vector<PhaseCrossover> loop_crossovers(const world::LinearPlant& plant, world::Sensor sensor,
                                            double period_s, double delay_s);

/// The relay's bias on the model: the relay simulated, estimated over
/// [steady_from, steps), against the model's exact K_CR.
struct RelayBias {
  CriticalStiffness model;                 ///< exact, at the loop delay
  std::vector<PhaseCrossover> crossovers;  ///< all of the model's, ascending in frequency
  RelayAnalysis simulated;
  /// Crossover the simulated relay settled on (matching_crossover), if any.
  std::optional<std::size_t> locked;
  /// simulated spectral K over K_CR (dB) and f over the crossover's; NaN when
  /// either is missing or the relay settled elsewhere than on K_CR's crossover.
  double spectrum_gain_db = 0.0;
  double spectrum_frequency_ratio = 1.0;
  double describing_gain_db = 0.0;
  double describing_frequency_ratio = 1.0;
  bool usable() const;  ///< both biases finite
};
RelayBias relay_bias(const SampledRelay& relay, std::int64_t steps, std::int64_t steady_from);

}  // namespace hapticd::analysis
