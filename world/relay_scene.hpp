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

#include <array>
#include <span>
#include <string_view>
#include <type_traits>

#include "world/scene.hpp"

namespace hapticd::world {

enum class RelayHysteresis { none, band };

struct RelayParameters {
  double amplitude = 1.0;   ///< h, N (or N m)
  double hysteresis = 0.0;  ///< eps, m (or rad), >= 0
  double reference = 0.0;   ///< m (or rad)
};

template <RelayHysteresis H>
class RelayScene {
  static constexpr bool has_band = H == RelayHysteresis::band;

 public:
  static constexpr RelayHysteresis hysteresis_kind = H;
  static constexpr std::size_t channel_count = 1;
  static constexpr std::array<std::string_view, channel_count> channel_names{"error"};

  /// Off the RT path. For RelayHysteresis::none, parameters.hysteresis is ignored
  /// (plan_scene picks the variant from it).
  explicit RelayScene(const RelayParameters& parameters) noexcept
      : amplitude_(parameters.amplitude), reference_(parameters.reference) {
    if constexpr (has_band) band_ = parameters.hysteresis;
  }

  void reset(double measured_position) noexcept {
    error_ = measured_position - reference_;
    if constexpr (has_band) last_ = 0.0;
  }

  double step(double measured_position) noexcept {
    const double error = measured_position - reference_;
    error_ = error;
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

  void channels(std::span<double> out) const noexcept {
    if (!out.empty()) out[0] = error_;
  }

  double amplitude() const noexcept { return amplitude_; }

 private:
  double amplitude_;
  double reference_;
  double error_ = 0.0;
  [[no_unique_address]] std::conditional_t<has_band, double, detail::Absent<0>> band_{};
  [[no_unique_address]] std::conditional_t<has_band, double, detail::Absent<1>> last_{};
};

static_assert(Scene<RelayScene<RelayHysteresis::none>>);
static_assert(Scene<RelayScene<RelayHysteresis::band>>);

}  // namespace hapticd::world
