#include "analysis/stability_gate.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "analysis/closed_loop.hpp"
#include "analysis/task_gate.hpp"
#include "analysis/wall_stability.hpp"
#include "world/text.hpp"

namespace hapticd::analysis {

namespace {

// A double eigenvalue at z = 1 (the free drift of device plus virtual body
// when nothing damps it) is computed only to about sqrt(machine epsilon).
// Growing modes of interest here sit 1e-6 and more above 1 (forward Euler
// at 1 Hz, T = 1 ms: 2e-5), so this tolerance separates the two.
constexpr double drift_tolerance = 1e-7;
// The scene alone is a small, well-conditioned matrix: marginal means 1 to
// rounding (the exact and trapezoid schemes on an undamped spring).
constexpr double scene_tolerance = 1e-12;

std::string num(double v) { return world::text::format_significant(v, world::text::precision::summary); }

/// Pole radii live next to 1: show enough digits to see the difference.
std::string radius(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.9f", v);
  return b;
}

/// 3 significant digits in s, ms or us.
std::string duration(double seconds) {
  char b[48];
  if (seconds >= 1.0) {
    std::snprintf(b, sizeof b, "%.3g s", seconds);
  } else if (seconds >= 1e-3) {
    std::snprintf(b, sizeof b, "%.3g ms", seconds * 1e3);
  } else {
    std::snprintf(b, sizeof b, "%.3g us", seconds * 1e6);
  }
  return b;
}

/// How fast the worst mode grows, for a person: the time it takes to double,
/// and the factor per second while that is a readable number (at most 1e6),
/// else per period; never a factor near overflow (2.1e+303 per second is a
/// mode that doubles about every period).
std::string growth_text(const SceneStability& v, double worst, double period_s) {
  if (!(v.doubling_time_s < std::numeric_limits<double>::infinity()))
    return "the amplitude does not decay (pole radius " + radius(worst) + ")";
  std::string text = "the amplitude doubles every " + duration(v.doubling_time_s);
  if (v.growth_per_second <= 1e6) return text + " (x" + num(v.growth_per_second) + " per second)";
  return text + " (x" + num(worst) + " per period of " + duration(period_s) + ")";
}

std::string stiffness_unit(const world::ScenePlan& plan) {
  if (const auto* d = world::find_scene(plan.scene)) {
    for (const auto& p : d->parameters) {
      if (p.name == "stiffness") return p.unit;
    }
  }
  return "N/m";
}

/// Largest stiffness in [0, requested] for which the plan is stable, other
/// parameters fixed (bisection; stability is monotone in K along this line
/// for the scenes here). Nothing if even a vanishing stiffness is unstable.
std::optional<double> largest_stable_stiffness(std::string_view scene, world::ParameterSet parameters,
                                               double requested, const GateDevice& device) {
  auto stable_at = [&](double k) {
    parameters["stiffness"] = k;
    auto outcome = world::plan_scene(scene, parameters, device.period_s, device.motion);
    const auto* plan = std::get_if<world::ScenePlan>(&outcome);
    return plan != nullptr && check_scene_stability(*plan, device).stable;
  };
  double lo = 0.0;
  double hi = requested;
  if (!stable_at(requested * 1e-6)) return std::nullopt;
  lo = requested * 1e-6;
  for (int i = 0; i < 60 && hi - lo > 1e-9 * requested; ++i) {
    const double mid = 0.5 * (lo + hi);
    (stable_at(mid) ? lo : hi) = mid;
  }
  return lo;
}

/// What the passivity controller changes in the gate's answer.
struct PassivityJudgement {
  bool applies = false;   ///< passivity = "controller" on a scene with a stiffness
  bool accepted = false;  ///< within the factor, and the controller's damper itself stable
  std::string text;       ///< the reason, for the reply (accepted) or the refusal
};

/// Whether the scene with its damping raised by all the controller may add
/// (passivity_max_damping) and no stiffness is stable on the device: the
/// controller must not be able to destabilise the device as a damper.
bool controller_damper_stable(std::string_view scene, world::ParameterSet parameters,
                              const GateDevice& device) {
  const auto damping = parameters.find("damping");
  const auto added = parameters.find("passivity_max_damping");
  if (damping == parameters.end() || added == parameters.end()) return true;
  parameters["damping"] = std::get<double>(damping->second) + std::get<double>(added->second);
  parameters["stiffness"] = 0.0;
  parameters["passivity"] = std::string("off");
  auto outcome = world::plan_scene(scene, parameters, device.period_s, device.motion);
  const auto* plan = std::get_if<world::ScenePlan>(&outcome);
  return plan != nullptr && check_scene_stability(*plan, device).stable;
}

PassivityJudgement judge_with_passivity(std::string_view scene, const world::ScenePlan& plan,
                                        const GateDevice& device) {
  PassivityJudgement j;
  const auto mode = plan.parameters.find("passivity");
  const auto stiffness = plan.parameters.find("stiffness");
  if (mode == plan.parameters.end() || stiffness == plan.parameters.end() ||
      std::get<std::string>(mode->second) != "controller") {
    return j;
  }
  j.applies = true;
  const double requested = std::get<double>(stiffness->second);
  const std::string unit = stiffness_unit(plan);
  const std::string factor = num(passivity_stiffness_factor);
  const auto fixed = largest_stable_stiffness(scene, plan.parameters, requested, device);
  if (!fixed) {
    j.text = "with the passivity controller up to " + factor + " x the fixed-gain limit, and there is none";
    return j;
  }
  const double allowed = passivity_stiffness_factor * *fixed;
  if (requested > allowed) {
    // The refusal has named the fixed-gain limit already.
    j.text = "with the passivity controller up to " + factor + " x that = " + num(allowed) + " " + unit;
    return j;
  }
  if (!controller_damper_stable(scene, plan.parameters, device)) {
    j.text =
        "passivity_max_damping: damping + passivity_max_damping is unstable as a damper on this device; "
        "the controller could destabilise it (lower passivity_max_damping)";
    return j;
  }
  j.accepted = true;
  j.text = "passivity: K = " + num(requested) + " " + unit + " is " + num(requested / *fixed) +
           " x the fixed-gain limit " + num(*fixed) + " " + unit +
           "; accepted with the passivity controller (Hannaford & Ryu 2002), up to " + factor + " x";
  return j;
}

/// Colgate & Schenkel for the plan's linear model on the device (see SceneStability).
void judge_passivity(const world::DiscreteLinearScene& scene, const GateDevice& device, SceneStability& v) {
  const std::string unit = device.motion == world::Motion::rotary ? " N m s/rad" : " N s/m";
  v.device_damping = device.damping;
  v.passivity = scene_passivity(scene, device.period_s, device.delay_samples);
  const PassivityBound& b = v.passivity;
  if (!std::isfinite(device.damping) || device.damping < 0.0) {
    v.passive = false;
    v.passivity_summary = "passivity cannot be assessed: the device's damping is not a finite number >= 0";
    return;
  }
  if (!b.assessed()) {
    v.passivity_summary = "passivity cannot be assessed: " + b.reason;
    return;
  }
  if (!b.bounded()) {
    v.passivity_summary = "not passive at any device damping: " + b.reason;
    return;
  }
  v.passive = device.damping >= b.required_damping;
  const std::string needs =
      "it needs b >= " + num(b.required_damping) + unit + " (Colgate & Schenkel, at " +
      (b.at_zero_frequency_limit ? std::string("w -> 0") : num(b.frequency_hz) + " Hz") +
      "), the device has " + num(device.damping) + unit;
  v.passivity_summary = (v.passive ? "passive on this device: " : "not passive on this device: ") + needs;
}

}  // namespace

std::string GateDevice::describe() const {
  const bool rotary = motion == world::Motion::rotary;
  std::string s = rotary ? "J = " + num(mass) + " kg m^2" : "m = " + num(mass) + " kg";
  if (damping > 0) s += ", b = " + num(damping) + (rotary ? " N m s/rad" : " N s/m");
  s += ", T = " + num(period_s * 1e3) + " ms, d = " + std::to_string(delay_samples);
  if (plant.dynamics.a.rows() == 4) s += ", two-mass (" + std::string(world::to_string(sensor)) + " sensing)";
  return s;
}

GateDevice rigid_device(double mass, double damping, double period_s, int delay_samples,
                        world::Motion motion) {
  GateDevice device;
  device.plant = world::RigidPlant{mass, damping}.model();
  device.period_s = period_s;
  device.delay_samples = delay_samples;
  device.mass = mass;
  device.damping = damping;
  device.motion = motion;
  return device;
}

SceneStability check_scene_stability(const world::ScenePlan& plan, const GateDevice& device) {
  if (plan.task_wall || plan.per_axis) {
    try {
      return plan.task_wall ? check_task_wall_stability(plan, device)
                            : check_per_axis_stability(plan, device);
    } catch (const std::invalid_argument& e) {
      SceneStability v;
      v.checked = true;
      v.verdict = VerdictState::cannot_assess;
      v.stable = false;
      v.reason = e.what();
      v.summary = "stability cannot be assessed on this device: " + v.reason;
      return v;
    }
  }
  SceneStability v;
  if (!plan.linear) {
    v.summary = "not a linear scene: no stability region applies (the torque limit holds)";
    return v;
  }
  v.checked = true;
  judge_passivity(*plan.linear, device, v);
  NumericRecord scene_record;
  // The plant was built from these: 1 / inf = 0 would make finite matrices
  // (a device that never moves) out of a non-finite number.
  scene_record.check_finite("the device's mass or inertia", device.mass);
  scene_record.check_finite("the device's damping", device.damping);
  const Spectrum held = spectrum("the scene's state matrix", plan.linear->a, scene_record);
  const auto closed = analyze_closed_loop(device.plant, device.sensor, *plan.linear, device.period_s,
                                          device.delay_samples, drift_tolerance);
  // A copy: worse() returns a reference to one of its arguments, and
  // judge_radius()'s is a temporary that ends with this statement.
  const Verdict verdict =
      worse(judge_radius(held.radius, scene_tolerance, device.period_s, scene_record), closed.verdict);
  v.verdict = verdict.state;
  v.reason = verdict.reason;
  v.stable = verdict.stable();
  v.scene_radius = held.radius;
  v.closed_loop_radius = closed.pole_radius;
  if (!verdict.assessed()) {
    v.growth_per_second = v.growth_per_second_log10 = v.doubling_time_s =
        std::numeric_limits<double>::quiet_NaN();
    v.summary = "stability cannot be assessed on this device (" + device.describe() + "): " + verdict.reason;
    return v;
  }
  const double worst = std::max(v.scene_radius, v.closed_loop_radius);
  v.growth_per_second = std::pow(worst, 1.0 / device.period_s);
  v.growth_per_second_log10 = std::log10(worst) / device.period_s;
  // log1p: a radius of 1 + 1e-12 keeps its digits.
  v.doubling_time_s = worst > 1.0 ? device.period_s * std::log(2.0) / std::log1p(worst - 1.0)
                                  : std::numeric_limits<double>::infinity();
  if (v.stable) {
    v.summary = "stable on this device: pole radius " + radius(v.closed_loop_radius) + " (released), " +
                radius(v.scene_radius) + " (held)";
  } else {
    v.summary = "unstable on this device (" + device.describe() + "): pole radius " + radius(worst) + ", " +
                growth_text(v, worst, device.period_s);
  }
  return v;
}

GateOutcome gate_scene(std::string_view scene, const world::ParameterSet& parameters,
                       const GateDevice& device, bool force) {
  auto outcome = world::plan_scene(scene, parameters, device.period_s, device.motion, device.axis_count());
  if (const auto* error = std::get_if<world::SceneError>(&outcome)) {
    GateRefusal invalid;
    invalid.invalid = true;
    invalid.message = error->message;
    invalid.parameter = error->parameter;
    return invalid;
  }
  if (std::get<world::ScenePlan>(outcome).task_wall)
    return gate_task_wall(std::move(std::get<world::ScenePlan>(outcome)), device, force);
  if (std::get<world::ScenePlan>(outcome).per_axis)
    return gate_per_axis(std::move(std::get<world::ScenePlan>(outcome)), device, force);
  GateAccepted accepted{std::move(std::get<world::ScenePlan>(outcome)), {}, false};
  accepted.stability = check_scene_stability(accepted.plan, device);
  if (accepted.stability.stable) return accepted;
  if (accepted.stability.verdict == VerdictState::cannot_assess) {
    // Not forceable: a scene whose numbers overflow or lost precision renders
    // nothing the analysis could describe (it may emit NaN).
    GateRefusal refusal;
    refusal.assessed = false;
    refusal.message = std::string(scene) + ": " + accepted.stability.summary;
    refusal.stability = accepted.stability;
    return refusal;
  }
  const PassivityJudgement passivity = judge_with_passivity(scene, accepted.plan, device);
  if (passivity.accepted) {
    accepted.plan.notes.push_back(passivity.text);
    accepted.stability.summary += "; " + passivity.text;
    accepted.passivity_held = true;
    return accepted;
  }
  if (force) {
    accepted.forced = true;
    return accepted;
  }

  // How the scene asks to be judged (its description, world/<name>_scene.cpp).
  const world::SceneDescription& rules = *accepted.plan.description;
  GateRefusal refusal;
  refusal.stability = accepted.stability;
  refusal.message = std::string(scene) + ": " + accepted.stability.summary;
  const auto it = accepted.plan.parameters.find("stiffness");
  if (it != accepted.plan.parameters.end()) {
    const double requested = std::get<double>(it->second);
    refusal.stiffness_limit = largest_stable_stiffness(scene, accepted.plan.parameters, requested, device);
    const std::string unit = stiffness_unit(accepted.plan);
    if (refusal.stiffness_limit) {
      refusal.message += "; the largest stable stiffness with these parameters is " +
                         num(*refusal.stiffness_limit) + " " + unit;
    } else {
      refusal.message += "; no stiffness > 0 is stable with these parameters";
      if (!rules.unstable_hint.empty()) refusal.message += " (" + rules.unstable_hint + ")";
    }
  }
  if (passivity.applies) refusal.message += "; " + passivity.text;
  // Hulin's wall on a rigid device without mechanical damping is exactly his
  // problem: say what his region allows.
  if (rules.stability == world::StabilityRule::hulin_wall && device.plant.dynamics.a.rows() == 2 &&
      device.damping == 0.0) {
    const int d =
        static_cast<int>(std::get<double>(accepted.plan.parameters.at("delay"))) + device.delay_samples;
    const auto verdict = analyze_wall(device.mass, device.period_s, d,
                                      std::get<double>(accepted.plan.parameters.at("stiffness")),
                                      std::get<double>(accepted.plan.parameters.at("damping")));
    refusal.message += ". Hulin: " + refusal_message(verdict);
    refusal.hulin = WallLimits{verdict.k_max, verdict.b_at_k_max, verdict.damping_range};
  }
  return refusal;
}

}  // namespace hapticd::analysis
