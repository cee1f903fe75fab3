#pragma once
/// \file
/// `relay` (Diaz & Gil V): the on-off controller of the relay experiment,
///   F = -h sign(y - reference),
/// with an optional hysteresis band eps: switch to -h only when the error
/// exceeds +eps, to +h only when it falls below -eps, keep the last output in
/// between. The variant without hysteresis carries no memory of its output.
/// After reset the band variant outputs 0 until the error leaves the band; the
/// variant without hysteresis outputs -h sign(e) at once (a relay has no
/// equilibrium other than y == reference: loading it is a step of h by design).
///
/// The experiment's extra loop delay t_d (Diaz & Gil eq. 25, C(z) = K z^-d)
/// is a delay line of d samples on the output, as the wall has; a relay
/// without delay has none. A relay given a duration stops by itself: after
/// that many steps it outputs 0 for good (a reset, e.g. after a cleared
/// fault, does not restart it), so an experiment ends even when the client
/// that started it is gone.

#include <array>
#include <cstdint>
#include <span>
#include <string_view>
#include <type_traits>

#include "world/delay_line.hpp"
#include "world/scene.hpp"

namespace hapticd::world {

enum class RelayHysteresis { none, band };
enum class RelayDelay { none, samples };

/// 8 ms (Table II's longest delay) at a 62.5 us period; 128 ms at 1 ms.
inline constexpr std::size_t max_relay_delay_samples = 128;

struct RelayParameters {
  double amplitude = 1.0;           ///< h, N (or N m)
  double hysteresis = 0.0;          ///< eps, m (or rad), >= 0
  double reference = 0.0;           ///< m (or rad)
  int delay_samples = 0;            ///< d: 0 for RelayDelay::none, 1..max_relay_delay_samples otherwise
  std::int64_t duration_steps = 0;  ///< steps until it stops by itself; 0: never
};

template <RelayHysteresis H, RelayDelay D = RelayDelay::none>
class RelayScene {
  static constexpr bool has_band = H == RelayHysteresis::band;
  static constexpr bool delayed = D == RelayDelay::samples;
  using Line = DelayLine<max_relay_delay_samples>;

 public:
  static constexpr RelayHysteresis hysteresis_kind = H;
  static constexpr RelayDelay delay_kind = D;
  static constexpr std::size_t channel_count = 1;
  static constexpr std::array<std::string_view, channel_count> channel_names{"error"};

  /// Off the RT path. For RelayHysteresis::none, parameters.hysteresis is
  /// ignored, for RelayDelay::none delay_samples (plan_scene picks the variant).
  explicit RelayScene(const RelayParameters& parameters) noexcept
      : amplitude_(parameters.amplitude),
        reference_(parameters.reference),
        duration_steps_(parameters.duration_steps),
        line_(make_line(parameters.delay_samples)) {
    if constexpr (has_band) band_ = parameters.hysteresis;
  }

  void reset(double measured_position) noexcept {
    error_ = measured_position - reference_;
    if constexpr (has_band) last_ = 0.0;
    if constexpr (delayed) line_.reset();
  }

  double step(double measured_position) noexcept {
    const double error = measured_position - reference_;
    error_ = error;
    if (duration_steps_ > 0) {
      if (steps_ >= duration_steps_) return 0.0;  // finished: stopped by itself
      ++steps_;
    }
    const double out = decide(error);
    if constexpr (delayed) {
      return line_.push(out);
    } else {
      return out;
    }
  }

  void channels(std::span<double> out) const noexcept {
    if (!out.empty()) out[0] = error_;
  }

  double amplitude() const noexcept { return amplitude_; }
  std::size_t delay_samples() const noexcept {
    if constexpr (delayed) {
      return line_.delay();
    } else {
      return 0;
    }
  }
  /// True once a relay with a duration has run it out (it outputs 0 from then on).
  bool finished() const noexcept { return duration_steps_ > 0 && steps_ >= duration_steps_; }

 private:
  static auto make_line(int delay_samples) noexcept {
    if constexpr (delayed) {
      return Line(static_cast<std::size_t>(delay_samples));
    } else {
      return detail::Absent<2>{};
    }
  }

  double decide(double error) noexcept {
    if constexpr (has_band) {
      if (error > band_) {
        last_ = -amplitude_;
      } else if (error < -band_) {
        last_ = amplitude_;
      }
      return last_;
    } else {
      return error > 0.0 ? -amplitude_ : (error < 0.0 ? amplitude_ : 0.0);
    }
  }

  double amplitude_;
  double reference_;
  double error_ = 0.0;
  std::int64_t duration_steps_;
  std::int64_t steps_ = 0;
  [[no_unique_address]] std::conditional_t<has_band, double, detail::Absent<0>> band_{};
  [[no_unique_address]] std::conditional_t<has_band, double, detail::Absent<1>> last_{};
  [[no_unique_address]] std::conditional_t<delayed, Line, detail::Absent<2>> line_;
};

static_assert(Scene<RelayScene<RelayHysteresis::none>>);
static_assert(Scene<RelayScene<RelayHysteresis::band>>);
static_assert(Scene<RelayScene<RelayHysteresis::none, RelayDelay::samples>>);
static_assert(Scene<RelayScene<RelayHysteresis::band, RelayDelay::samples>>);

/// `relay` in the scene registry (world/scene_registry.hpp); relay_scene.cpp describes it.
struct RelayEntry {
  using alternatives = std::tuple<RelayScene<RelayHysteresis::none>, RelayScene<RelayHysteresis::band>,
                                  RelayScene<RelayHysteresis::none, RelayDelay::samples>,
                                  RelayScene<RelayHysteresis::band, RelayDelay::samples>>;
  static SceneDescription describe();
};

}  // namespace hapticd::world
