#pragma once
/// \file
/// A scene with Hannaford & Ryu's passivity observer, and optionally its
/// controller, at the device port (world/passivity_observer.hpp; the scene
/// option `passivity = "observer" | "controller"` of wall, spring-wheel and
/// spring-mass). With the option off the scene is built without this
/// wrapper: no observer, no window, no extra channels.
///
/// What the observer sees, per period n (T the period):
///  - velocity v[n] = (y[n] - y[n-1]) / T: the mean velocity over the period
///    that just ended (T/2 late as a velocity at n), so T v is exactly the
///    displacement over it;
///  - force: the force that was held over that period, the scene's output of
///    n - 1 (after the scene's own delay line). T F v is then the work the
///    zero-order hold really did, and the hold's activity and the scene's
///    delay show as generated energy (for a sampled spring the controller
///    adds Colgate's K T / 2 while it moves);
///  - stored energy: what the scene holds at y[n] (the wall's 1/2 K p^2, the
///    springs' 1/2 k s^2 + 1/2 J w'^2), the environment's own, not credit.
/// The controller's damping force -alpha v[n] goes out with the scene's
/// force of n, so it acts T/2 + T after the velocity it is computed from,
/// and what it dissipated is booked from its held force and the next
/// period's displacement (PassivityCorrection::measured).
///
/// The engine's torque limit may cut the force after the scene; the observer
/// books the commanded force, so a saturated period is booked as the scene
/// meant it. Saturation only lowers |F|, and the limit is checked beside.

#include <array>
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "world/parameter.hpp"
#include "world/passivity_observer.hpp"
#include "world/scene.hpp"
#include "world/state_space.hpp"

namespace hapticd::world {

enum class PassivityMode { off, observer, controller };
std::string_view to_string(PassivityMode mode) noexcept;  ///< "off", "observer", "controller"
std::optional<PassivityMode> parse_passivity_mode(std::string_view name) noexcept;

/// The longest forgetting window a scene takes, in periods (the observer's storage).
inline constexpr std::size_t max_passivity_window = 256;
using ScenePassivityObserver = PassivityObserver<max_passivity_window>;

/// A scene whose energy at the device port the observer can balance.
template <class S>
concept StoresEnergy = Scene<S> && requires(const S& scene, double y) {
  { scene.stored_energy(y) }
  noexcept->std::same_as<double>;
};

template <StoresEnergy S>
class PassivityControlledScene {
 public:
  using inner_scene = S;
  static constexpr std::size_t channel_count = S::channel_count + 2;
  static constexpr std::array<std::string_view, channel_count> channel_names = [] {
    std::array<std::string_view, channel_count> out{};
    for (std::size_t i = 0; i < S::channel_count; ++i) out[i] = S::channel_names[i];
    out[S::channel_count] = "passivity_energy";
    out[S::channel_count + 1] = "passivity_damping";
    return out;
  }();

  /// Off the RT path; the observer's constructor checks the configuration.
  PassivityControlledScene(S scene, const PassivityObserverConfig& config)
      : scene_(std::move(scene)),
        observer_(config),
        inverse_period_(1.0 / config.period_s),
        scene_forces_(config.output_delay_periods) {}

  void reset(double y) noexcept {
    scene_.reset(y);
    observer_.reset(scene_.stored_energy(y));
    previous_y_ = y;
    scene_forces_.clear();
  }

  double step(double y) noexcept {
    const double velocity = (y - previous_y_) * inverse_period_;
    previous_y_ = y;
    // The scene's force held over the period that just ended: its output of
    // 1 + the device's delay steps ago.
    const PassivityStep control = observer_.step(scene_forces_.acting(), velocity, scene_.stored_energy(y));
    const double force = scene_.step(y);
    scene_forces_.push(force);
    return force + control.force;
  }

  void channels(std::span<double> out) const noexcept {
    if (out.size() < channel_count) return;
    scene_.channels(out.first(S::channel_count));
    out[S::channel_count] = observer_.energy();
    out[S::channel_count + 1] = observer_.damping();
  }

  /// The scene's own law: the gate judges it (and, with the controller, how
  /// far past the fixed-gain limit it may go; analysis/stability_gate.hpp).
  DiscreteLinearScene linear_model() const requires requires(const S& s) { s.linear_model(); }
  { return scene_.linear_model(); }

  const S& scene() const noexcept { return scene_; }
  const ScenePassivityObserver& observer() const noexcept { return observer_; }

 private:
  S scene_;
  ScenePassivityObserver observer_;
  double inverse_period_;
  double previous_y_ = 0.0;
  ForcesInFlight scene_forces_;  ///< N: the scene's, through the hold and the device's delay
};

/// The defaults of the scene options (docs/scenes.md says why each).
namespace passivity_defaults {
/// N s/m (N m s/rad): with Hulin's wall (B = 46 N s/m) on his device
/// (m = 0.1 kg, T = 1 ms, d = 1), B + 30 stays inside the largest damper
/// that device holds, 82.8 N s/m (`hapticctl analyze wall`); the gate
/// checks the sum on every device.
inline constexpr double max_damping = 30.0;
/// 100 periods (0.1 s at 1 kHz): longer than a contact's oscillation, short
/// enough that a held contact's credit is gone before the next push.
inline constexpr std::size_t window_periods = 100;
/// m/s (rad/s): one 1 um (1 urad) count per 1 ms period.
inline constexpr double velocity_floor = 1e-3;
}  // namespace passivity_defaults

/// The scene options of `passivity`, validated (plan_scene has checked the ranges).
struct PassivityOptions {
  PassivityMode mode = PassivityMode::off;
  PassivityObserverConfig observer{};
};

/// The parameters every scene with the option takes: in the units of the
/// scene's fixed motion, or (none) of the device's (defaults in docs/scenes.md).
std::vector<ParameterSpec> passivity_parameters(std::optional<Motion> fixed_motion);
/// From a plan's complete parameters, at this period.
PassivityOptions passivity_options(const ParameterSet& parameters, double period_s);

}  // namespace hapticd::world
