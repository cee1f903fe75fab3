#pragma once
/// \file
/// The stability gate: what the daemon does with a scene request on a
/// device, as a pure function (daemon/planner.hpp's plan_on_device is this
/// plus JSON), so that offline studies (`hapticctl report stability`) ask the
/// very same gate. It validates the parameters (world/scene_catalog), then
/// checks numerical and closed-loop stability with the device's mass or
/// inertia, period and delay: the scene alone with the device held, and the
/// closed loop with the device released and no hand on it (the worst case,
/// Hulin 2). Unstable sets are refused with the limit that would have held,
/// unless forced (to show an instability on purpose).

#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "analysis/passivity.hpp"
#include "analysis/polynomial.hpp"
#include "analysis/task_space.hpp"
#include "analysis/verdict.hpp"
#include "world/plant.hpp"
#include "world/scene_catalog.hpp"

namespace hapticd::analysis {

/// What the gate knows about the device.
struct GateDevice {
  world::LinearPlant plant;  ///< rigid from mass and damping, or the loopback's two-mass model
  world::Sensor sensor = world::Sensor::motor;
  double period_s = 1e-3;
  int delay_samples = 0;  ///< output delay the device adds, in periods
  double mass = 0.0;      ///< effective mass, kg, or inertia, kg m^2
  double damping = 0.0;   ///< viscous damping to ground, N s/m or N m s/rad
  world::Motion motion = world::Motion::rotary;
  /// A device with several axes (a Cartesian stage): each axis' mass and
  /// damping, and its name; empty for one axis. Task-space walls are judged
  /// along their directions with these (analysis/task_gate.hpp).
  std::vector<JointModel> axes;
  std::vector<std::string> axis_names;
  /// A pantograph: `axes` are its two motor joints (inertia, damping); its
  /// task-space walls are judged at their worst case over `workspace`
  /// (analysis/task_space.hpp: a bound, not exact).
  std::optional<world::PantographKinematics> pantograph;
  TaskBox workspace;
  /// 1, or the number of axes.
  int axis_count() const noexcept { return axes.empty() ? 1 : static_cast<int>(axes.size()); }
  /// "J = 0.01 kg m^2, b = 0 N m s/rad, T = 1 ms, d = 0" (or m = ... kg for a linear device).
  std::string describe() const;
};

/// A rigid device: the plant 1 / (m s^2 + b s) (Diaz & Gil eq. 2).
GateDevice rigid_device(double mass, double damping, double period_s, int delay_samples,
                        world::Motion motion);

/// The verdict that goes with a plan.
struct SceneStability {
  bool checked = false;  ///< false for scenes without a linear model (relay, free)
  /// The worse of the scene's and the closed loop's Verdict; stable is set
  /// from it only (never true for cannot_assess).
  VerdictState verdict = VerdictState::stable;
  std::string reason;  ///< why it cannot be assessed (an overflow, a NaN pole, lost precision); else empty
  bool stable = true;
  double scene_radius = 0.0;        ///< largest |eigenvalue| of the scene alone (device held)
  double closed_loop_radius = 0.0;  ///< largest |pole| with the device released (worst case, Hulin 2)
  double growth_per_second = 1.0;   ///< amplitude factor per second of the worst mode (may be inf)
  /// log10(worst radius) / T: finite even when the factor overflows (as
  /// `analyze integrator`'s); -inf for a zero radius, NaN when not assessed.
  double growth_per_second_log10 = 0.0;
  /// T ln 2 / ln(worst radius): the time the worst mode takes to double its
  /// amplitude; +inf when it does not grow, NaN when not assessed.
  double doubling_time_s = std::numeric_limits<double>::infinity();
  std::string summary;  ///< one sentence
  /// Colgate & Schenkel on the device's own damping (analysis/passivity.hpp):
  /// the linear scene's H(z) with the device's delay needs b >= required
  /// damping. Stricter than stable: passive holds against any passive hand.
  /// Computed for every linear scene, stable or not; passive is never true
  /// when the bound is unbounded or not assessed (a non-finite number).
  PassivityBound passivity{};
  double device_damping = 0.0;  ///< b the verdict used, N s/m or N m s/rad
  bool passive = false;
  std::string passivity_summary;  ///< one sentence, with the units of the device's motion
};

/// Stability of an already validated plan on the device.
SceneStability check_scene_stability(const world::ScenePlan& plan, const GateDevice& device);

struct GateAccepted {
  world::ScenePlan plan;
  SceneStability stability;
  bool forced = false;  ///< unstable, loaded on purpose with force
  /// Unstable with fixed gains, accepted because passivity = "controller"
  /// and the stiffness is within passivity_stiffness_factor of the limit.
  bool passivity_held = false;
};

/// With passivity = "controller", a scene whose fixed-gain law is unstable
/// on the device is accepted up to this factor of its largest stable
/// stiffness (the other parameters fixed), provided its damping plus all the
/// controller may add (passivity_max_damping) is itself stable. Chosen from
/// analysis/passivity_contact.hpp's runs on Hulin's device (m = 0.1 kg,
/// T = 1 ms, d = 1, B = 46 N s/m, a 200 N/m, 2 N s/m hand): at 2 x the
/// oscillation left while the hand holds the wall is about the size of the
/// static penetration (34 um vs 29 um); at 5 x it stays bounded, but at ten
/// times the static penetration (138 um vs 14 um), a buzz, not a wall.
/// tests/analysis/passivity_contact_test.cpp runs both.
inline constexpr double passivity_stiffness_factor = 2.0;

/// Hulin's region for a wall on a rigid, undamped device.
struct WallLimits {
  double k_max = 0.0;                     ///< N/m, the largest stable K over all damping
  double b_at_k_max = 0.0;                ///< N s/m
  std::optional<Interval> damping_range;  ///< N s/m stable at the requested K
};

struct GateRefusal {
  bool invalid = false;  ///< bad parameters (vs. valid but unstable)
  bool assessed = true;  ///< false: no stability verdict could be computed; force does not apply
  std::string message;   ///< one line: what was wrong and what would be accepted or hold
  /// The given parameter at fault (world::SceneError::parameter); empty when
  /// the set as a whole is refused (unstable, or it cannot be built).
  std::string parameter;
  /// Unstable sets only: the largest stable stiffness with the other
  /// parameters fixed, if the scene has a stiffness and one exists.
  std::optional<double> stiffness_limit;
  std::optional<WallLimits> hulin;
  std::optional<SceneStability> stability;  ///< absent when invalid
};

using GateOutcome = std::variant<GateAccepted, GateRefusal>;

/// Plans `scene` with `parameters` (missing ones take their defaults) for the
/// device. A set whose stability cannot be assessed is refused even when forced.
GateOutcome gate_scene(std::string_view scene, const world::ParameterSet& parameters,
                       const GateDevice& device, bool force);

}  // namespace hapticd::analysis
