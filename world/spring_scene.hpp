#pragma once
/// \file
/// `spring-wheel` / `spring-mass` (Freudenberg 2.1-2.4, 2.16-2.22): a virtual
/// body of inertia J_w (kg m^2) or mass m (kg) tied to the device by a spring
/// k with an optional damper b. State x = [theta_w, theta_w_dot].
///
/// Sign convention: the value returned by step() is the force/torque ON THE
/// DEVICE; the spring pulls the device toward the virtual body:
///   F = k (theta_w - y) + b (theta_w_dot - y_dot)      (relative damping)
///   F = k (theta_w - y)                                (none / absolute)
/// Freudenberg's T_q of 2.18/2.22 is the torque on the virtual wheel, -F.
///
/// The type shows what the scene uses:
///  - SpringScene<SpringDamping::none>:     b == 0, one input (y), no estimator.
///  - SpringScene<SpringDamping::absolute>: b acts on theta_w_dot against the
///    fixed frame (Freudenberg footnote 2, Fig. 9): b only in A, one input.
///  - SpringScene<SpringDamping::relative>: b on the relative motion (2.19-2.22):
///    inputs [y, y_dot], y_dot from a BackwardDifference member.

#include <array>
#include <span>
#include <string_view>
#include <type_traits>

#include "world/integrator.hpp"
#include "world/kinematics.hpp"
#include "world/passivity_scene.hpp"
#include "world/scene.hpp"
#include "world/state_space.hpp"
#include "world/velocity_estimator.hpp"

namespace hapticd::world {

enum class SpringDamping { none, absolute, relative };

struct SpringParameters {
  double stiffness = 1.0;  ///< k, N m/rad (or N/m), >= 0
  double inertia = 1.0;    ///< J_w, kg m^2 (or m, kg), > 0
  double damping = 0.0;    ///< b, N m s/rad (or N s/m), >= 0; must be 0 for SpringDamping::none
  Integrator integrator = Integrator::exact;
};

/// Continuous model x' = A x + B u of the virtual body for the damping kind:
/// A = [[0,1],[-k/J,-b/J]]; B = [[0],[k/J]] (none, absolute) or
/// B = [[0,0],[k/J,b/J]] with u = [y, y_dot] (relative).
ContinuousStateSpace spring_continuous_model(const SpringParameters& parameters, SpringDamping kind);

template <SpringDamping D>
class SpringScene {
  static constexpr bool relative = D == SpringDamping::relative;

 public:
  static constexpr SpringDamping damping_kind = D;
  static constexpr bool has_velocity_estimator = relative;
  static constexpr bool has_damping_term = relative;  ///< b appears in the output law
  static constexpr std::size_t input_count = relative ? 2 : 1;
  static constexpr std::size_t channel_count = relative ? 3 : 2;
  static constexpr std::array<std::string_view, channel_count> channel_names = [] {
    if constexpr (relative) {
      return std::array<std::string_view, 3>{"virtual_position", "virtual_velocity", "device_velocity"};
    } else {
      return std::array<std::string_view, 2>{"virtual_position", "virtual_velocity"};
    }
  }();

  /// Off the RT path (discretizes with Eigen). Throws std::invalid_argument on
  /// period <= 0, inertia <= 0, negative or non-finite values, or b != 0 with
  /// SpringDamping::none.
  SpringScene(const SpringParameters& parameters, double period_s);

  void reset(double measured_position) noexcept {
    position_ = measured_position;
    velocity_ = 0.0;
    if constexpr (relative) estimator_.reset(measured_position);
  }

  double step(double y) noexcept {
    // Deviation form of x[n+1] = Ad x[n] + Bd u[n]: every integrator keeps
    // [y, 0] an equilibrium for a held y (Ad e1 + Bd_y = e1, checked when
    // planning), so x[n+1] = [y, 0] + Ad (x[n] - [y, 0]) + Bd_v y_dot. Same
    // numbers, but no cancellation when y is large (multi-turn wheels).
    const double stretch = position_ - y;
    const double w_dot = velocity_;
    if constexpr (relative) {
      const double y_dot = estimator_.update(y);
      position_ = y + (ad_[0] * stretch + ad_[1] * w_dot + bd_velocity_[0] * y_dot);
      velocity_ = ad_[2] * stretch + ad_[3] * w_dot + bd_velocity_[1] * y_dot;
      return stiffness_ * stretch + damping_ * (w_dot - y_dot);
    } else {
      position_ = y + (ad_[0] * stretch + ad_[1] * w_dot);
      velocity_ = ad_[2] * stretch + ad_[3] * w_dot;
      return stiffness_ * stretch;
    }
  }

  void channels(std::span<double> out) const noexcept {
    if (out.size() < channel_count) return;
    out[0] = position_;
    out[1] = velocity_;
    if constexpr (relative) out[2] = estimator_.velocity();
  }

  /// s[n+1] = a s + b y, F = c s + d y. s = [theta_w, theta_w_dot] (none,
  /// absolute) or [theta_w, theta_w_dot, y[n-1]] (relative). No output delay.
  DiscreteLinearScene linear_model() const;

  /// J: what the scene holds with the device at y (before step(y)): the
  /// spring's 1/2 k (theta_w - y)^2 and the body's 1/2 J_w theta_w_dot^2.
  double stored_energy(double y) const noexcept {
    const double stretch = position_ - y;
    return 0.5 * (stiffness_ * stretch * stretch + inertia_ * velocity_ * velocity_);
  }

  double virtual_position() const noexcept { return position_; }
  double virtual_velocity() const noexcept { return velocity_; }
  /// Ad row-major (for analysis and tests).
  const std::array<double, 4>& ad() const noexcept { return ad_; }
  /// Bd row-major, 2 x input_count (column y rebuilt as e1 - Ad e1, see step()).
  std::array<double, 2 * input_count> bd() const noexcept;

 private:
  std::array<double, 4> ad_{};
  [[no_unique_address]] std::conditional_t<relative, std::array<double, 2>, detail::Absent<2>> bd_velocity_{};
  double stiffness_;
  double inertia_;
  double position_ = 0.0;
  double velocity_ = 0.0;
  [[no_unique_address]] std::conditional_t<relative, double, detail::Absent<0>> damping_{};
  [[no_unique_address]] std::conditional_t<relative, BackwardDifference, detail::Absent<1>> estimator_;
};

extern template class SpringScene<SpringDamping::none>;
extern template class SpringScene<SpringDamping::absolute>;
extern template class SpringScene<SpringDamping::relative>;

static_assert(Scene<SpringScene<SpringDamping::none>>);
static_assert(Scene<SpringScene<SpringDamping::absolute>>);
static_assert(Scene<SpringScene<SpringDamping::relative>>);

/// `spring-wheel` and `spring-mass` in the scene registry
/// (world/scene_registry.hpp); spring_scene.cpp describes them.
/// Each variant plain, and with the passivity option on (world/passivity_scene.hpp).
struct SpringWheelEntry {
  using alternatives = std::tuple<SpringScene<SpringDamping::none>, SpringScene<SpringDamping::absolute>,
                                  SpringScene<SpringDamping::relative>,
                                  PassivityControlledScene<SpringScene<SpringDamping::none>>,
                                  PassivityControlledScene<SpringScene<SpringDamping::absolute>>,
                                  PassivityControlledScene<SpringScene<SpringDamping::relative>>>;
  static SceneDescription describe();
};
struct SpringMassEntry {
  using alternatives = SpringWheelEntry::alternatives;
  static SceneDescription describe();
};

/// `axis-springs` (issue 22): today's spring-mass on each task axis of a
/// Cartesian stage, axis i's virtual mass tied to x_i alone, so the force
/// on axis i is axis i's spring-mass force. Every axis takes the same law
/// with its own k, m and b when given (axis_stiffness, axis_mass,
/// axis_damping); the springs beyond the
/// device's axes are built and never stepped (no allocation). The gate
/// judges it per axis, exactly (StabilityRule::per_axis).
template <SpringDamping D>
class AxisSpringsScene {
 public:
  static constexpr std::size_t channel_count = 0;
  static constexpr std::array<std::string_view, channel_count> channel_names{};
  using AxisParameters = std::array<SpringParameters, max_axes>;
  /// Throws std::invalid_argument as SpringScene, or for axes outside 1..max_axes.
  AxisSpringsScene(const SpringParameters& parameters, double period_s, Eigen::Index axes);
  /// Axis i with parameters[i] (the entries beyond `axes` are built, never stepped).
  AxisSpringsScene(const AxisParameters& parameters, double period_s, Eigen::Index axes);
  void reset(const AxisVector& x) noexcept {
    for (Eigen::Index i = 0; i < axes_; ++i) springs_[static_cast<std::size_t>(i)].reset(x(i));
  }
  void step(const AxisVector& x, AxisVector& force) noexcept {
    force.resize(axes_);
    for (Eigen::Index i = 0; i < axes_; ++i) force(i) = springs_[static_cast<std::size_t>(i)].step(x(i));
  }
  void channels(std::span<double> /*out*/) const noexcept {}
  const SpringScene<D>& axis(std::size_t i) const { return springs_.at(i); }

 private:
  static std::array<SpringScene<D>, max_axes> make_springs(const AxisParameters& parameters, double period_s);
  Eigen::Index axes_;
  std::array<SpringScene<D>, max_axes> springs_;
};

extern template class AxisSpringsScene<SpringDamping::none>;
extern template class AxisSpringsScene<SpringDamping::absolute>;
extern template class AxisSpringsScene<SpringDamping::relative>;

struct AxisSpringsEntry {
  using alternatives = std::tuple<>;
  using task_alternatives =
      std::tuple<AxisSpringsScene<SpringDamping::none>, AxisSpringsScene<SpringDamping::absolute>,
                 AxisSpringsScene<SpringDamping::relative>>;
  static SceneDescription describe();
};

}  // namespace hapticd::world
