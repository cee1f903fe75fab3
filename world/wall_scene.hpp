#pragma once
/// \file
/// `wall` (Hulin et al. 2006): a unilateral virtual wall rendered as a
/// discrete PD law on the penetration:
///   in contact:  F = -K (y - x_w) - B v,   v[n] = (y[n] - y[n-1]) / T
///   outside:     F = 0
/// side `upper`: the wall occupies y > x_w (F pushes toward -y);
/// side `lower`: the wall occupies y < x_w (F pushes toward +y).
/// The PD acts only while penetrating, and the result is clamped so that the
/// wall never pulls the device into itself (a wall pushes, it cannot stick);
/// the clamp is active only while withdrawing faster than K pen / B.
/// The force applied at n is the law's value at n - d (delay line, d samples).
///
/// Safety: if reset() finds the device already inside the wall, the wall
/// stays disarmed (outputs 0) until the device has been outside once: loading
/// or re-positioning a wall must never produce a torque step of K * depth.
///
/// The type shows what is used: WallDamping::none has no estimator and no B;
/// WallDelay::none has no delay line.

#include <array>
#include <span>
#include <string_view>
#include <type_traits>

#include "world/delay_line.hpp"
#include "world/passivity_scene.hpp"
#include "world/scene.hpp"
#include "world/state_space.hpp"
#include "world/velocity_estimator.hpp"

namespace hapticd::world {

enum class WallSide { upper, lower };
enum class WallDamping { none, backward_difference };
enum class WallDelay { none, samples };

inline constexpr std::size_t max_wall_delay_samples = 16;

struct WallParameters {
  double stiffness = 9000.0;  ///< K, N/m (or N m/rad), >= 0
  double damping = 4.6;       ///< B, N s/m, >= 0; must be 0 for WallDamping::none
  double position = 0.0;      ///< x_w, m (or rad)
  WallSide side = WallSide::upper;
  int delay_samples = 1;  ///< d in 0..max_wall_delay_samples; 0 for WallDelay::none, >= 1 otherwise
};

template <WallDamping Damping, WallDelay Delay>
class WallScene {
  static constexpr bool damped = Damping == WallDamping::backward_difference;
  static constexpr bool delayed = Delay == WallDelay::samples;
  using Line = DelayLine<max_wall_delay_samples>;

 public:
  static constexpr WallDamping damping_kind = Damping;
  static constexpr WallDelay delay_kind = Delay;
  static constexpr bool has_velocity_estimator = damped;
  static constexpr bool has_delay_line = delayed;
  static constexpr std::size_t channel_count = damped ? 3 : 2;
  static constexpr std::array<std::string_view, channel_count> channel_names = [] {
    if constexpr (damped) {
      return std::array<std::string_view, 3>{"penetration", "armed", "device_velocity"};
    } else {
      return std::array<std::string_view, 2>{"penetration", "armed"};
    }
  }();

  /// Off the RT path. Throws std::invalid_argument when the parameters do not
  /// fit the variant (B != 0 for none, d out of range, period <= 0, ...).
  WallScene(const WallParameters& parameters, double period_s);

  void reset(double measured_position) noexcept {
    const double penetration = side_sign_ * (measured_position - position_);
    penetration_ = penetration;
    armed_ = !(penetration > 0.0);
    if constexpr (damped) estimator_.reset(measured_position);
    if constexpr (delayed) line_.reset();
  }

  double step(double y) noexcept {
    const double error = y - position_;
    const double penetration = side_sign_ * error;
    penetration_ = penetration;
    double force = 0.0;
    if constexpr (damped) {
      const double v = estimator_.update(y);
      force = -stiffness_ * error - damping_ * v;
    } else {
      force = -stiffness_ * error;
    }
    if (!(penetration > 0.0)) armed_ = true;
    // Only while penetrating an armed wall, and never pulling (side_sign * F <= 0).
    if (!armed_ || !(penetration > 0.0) || side_sign_ * force > 0.0) force = 0.0;
    if constexpr (delayed) {
      return line_.push(force);
    } else {
      return force;
    }
  }

  void channels(std::span<double> out) const noexcept {
    if (out.size() < channel_count) return;
    out[0] = penetration_;
    out[1] = armed_ ? 1.0 : 0.0;
    if constexpr (damped) out[2] = estimator_.velocity();
  }

  /// The in-contact PD law as an LTI system in the coordinate y - x_w:
  ///   s = [y[n-1]] (damped) or no state; F = -(K + B/T) y + (B/T) s;
  /// output_delay_samples = d. Closed with a rigid mass m (ZOH), the
  /// characteristic polynomial is Hulin eq. (1).
  DiscreteLinearScene linear_model() const;

  /// J: the spring energy 1/2 K p^2 the wall holds with the device at y
  /// (before step(y)); 0 outside or disarmed. The passivity observer counts
  /// it as the environment's own, not as absorbed energy.
  double stored_energy(double y) const noexcept {
    const double penetration = side_sign_ * (y - position_);
    return armed_ && penetration > 0.0 ? 0.5 * stiffness_ * penetration * penetration : 0.0;
  }

  bool armed() const noexcept { return armed_; }
  std::size_t delay_samples() const noexcept {
    if constexpr (delayed) {
      return line_.delay();
    } else {
      return 0;
    }
  }

 private:
  double stiffness_;
  double position_;
  double side_sign_;  ///< +1 upper (inside when y > x_w), -1 lower
  double penetration_ = 0.0;
  bool armed_ = true;
  [[no_unique_address]] std::conditional_t<damped, double, detail::Absent<0>> damping_{};
  [[no_unique_address]] std::conditional_t<damped, BackwardDifference, detail::Absent<1>> estimator_;
  [[no_unique_address]] std::conditional_t<delayed, Line, detail::Absent<2>> line_;
};

extern template class WallScene<WallDamping::none, WallDelay::none>;
extern template class WallScene<WallDamping::none, WallDelay::samples>;
extern template class WallScene<WallDamping::backward_difference, WallDelay::none>;
extern template class WallScene<WallDamping::backward_difference, WallDelay::samples>;

static_assert(Scene<WallScene<WallDamping::none, WallDelay::none>>);
static_assert(Scene<WallScene<WallDamping::backward_difference, WallDelay::samples>>);

/// `wall` in the scene registry (world/scene_registry.hpp); wall_scene.cpp describes it.
/// Each variant plain, and with the passivity option on (world/passivity_scene.hpp).
struct WallEntry {
  using alternatives =
      std::tuple<WallScene<WallDamping::none, WallDelay::none>,
                 WallScene<WallDamping::none, WallDelay::samples>,
                 WallScene<WallDamping::backward_difference, WallDelay::none>,
                 WallScene<WallDamping::backward_difference, WallDelay::samples>,
                 PassivityControlledScene<WallScene<WallDamping::none, WallDelay::none>>,
                 PassivityControlledScene<WallScene<WallDamping::none, WallDelay::samples>>,
                 PassivityControlledScene<WallScene<WallDamping::backward_difference, WallDelay::none>>,
                 PassivityControlledScene<WallScene<WallDamping::backward_difference, WallDelay::samples>>>;
  static SceneDescription describe();
};

}  // namespace hapticd::world
