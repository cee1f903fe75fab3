#pragma once
/// \file
/// `chirp`: an excitation force for identifying the device (Diaz & Gil II,
/// Fig. 4: "a swept sine wave input ... applied to the motor"). An
/// exponential sweep from f0 to f1 over one sweep time Ts, repeated:
///   F[n] = A sin(phi(t)),  t = (n mod N) T,  N = Ts / T,
///   phi(t) = 2 pi f0 Ts / ln(f1/f0) (e^{ln(f1/f0) t / Ts} - 1),
/// whose instantaneous frequency f0 e^{ln(f1/f0) t/Ts} spends equal time per
/// octave. Each sweep repeats the last sample for sample (periodic
/// excitation: the response's spectrum is read at the harmonics of 1/Ts
/// without leakage). |F| <= A always. It ignores the position: no estimator,
/// no state but the step count, no linear model (it is not a feedback law).
/// After `duration` it outputs 0 for good (a reset, e.g. after a cleared
/// fault, does not restart it).

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

#include "world/scene.hpp"

namespace hapticd::world {

/// Longest sweep in periods: its mean is summed once, off the RT path.
inline constexpr std::int64_t max_chirp_sweep_steps = 10'000'000;

struct ChirpParameters {
  double amplitude = 1.0;        ///< A, N (or N m), > 0
  double start_frequency = 0.5;  ///< f0, Hz, > 0
  double end_frequency = 50.0;   ///< f1, Hz, > f0 and <= 1 / (2 T)
  double sweep_s = 10.0;         ///< Ts, s: at least 2 periods
  double duration_s = 40.0;      ///< s, > 0: then 0 for good
};

class ChirpScene {
 public:
  static constexpr std::size_t channel_count = 1;
  static constexpr std::array<std::string_view, channel_count> channel_names{"frequency"};

  /// Off the RT path. Throws std::invalid_argument naming the parameter when
  /// the values do not make a sweep at this period.
  ChirpScene(const ChirpParameters& parameters, double period_s);

  void reset(double /*measured_position*/) noexcept {}

  double step(double /*measured_position*/) noexcept;

  void channels(std::span<double> out) const noexcept {
    if (!out.empty()) out[0] = frequency_hz_;
  }

  /// Samples per sweep, N: the excitation's period.
  std::int64_t sweep_steps() const noexcept { return sweep_steps_; }
  std::int64_t duration_steps() const noexcept { return duration_steps_; }
  /// Steps of the fade in at the start and out at the end.
  std::int64_t fade_steps() const noexcept { return fade_steps_; }
  bool finished() const noexcept { return steps_ >= duration_steps_; }

 private:
  double amplitude_;
  double start_hz_;
  double growth_per_step_;  ///< ln(f1/f0) / N
  double phase_scale_;      ///< 2 pi f0 N T / ln(f1/f0)
  double mean_ = 0.0;       ///< mu, the mean of sin(phi) over a sweep
  double gain_ = 1.0;       ///< A / (1 + |mu|)
  std::int64_t fade_steps_ = 1;
  std::int64_t sweep_steps_;
  std::int64_t duration_steps_;
  std::int64_t steps_ = 0;
  double frequency_hz_ = 0.0;
};

static_assert(Scene<ChirpScene>);

/// `chirp` in the scene registry (world/scene_registry.hpp); chirp_scene.cpp describes it.
struct ChirpEntry {
  using alternatives = std::tuple<ChirpScene>;
  static SceneDescription describe();
};

}  // namespace hapticd::world
