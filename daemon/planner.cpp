#include "daemon/planner.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "analysis/closed_loop.hpp"
#include "analysis/wall_stability.hpp"

namespace hapticd::daemon {

namespace {

// A double eigenvalue at z = 1 (the free drift of device plus virtual body
// when nothing damps it) is computed only to about sqrt(machine epsilon).
// Growing modes of interest here sit 1e-6 and more above 1 (forward Euler
// at 1 Hz, T = 1 ms: 2e-5), so this tolerance separates the two.
constexpr double drift_tolerance = 1e-7;
// The scene alone is a small, well-conditioned matrix: marginal means 1 to
// rounding (the exact and trapezoid schemes on an undamped spring).
constexpr double scene_tolerance = 1e-12;

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

/// Pole radii live next to 1: show enough digits to see the difference.
std::string radius(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.9f", v);
  return b;
}

std::string stiffness_unit(const world::ScenePlan& plan) {
  if (const auto* d = world::find_scene(plan.scene)) {
    for (const auto& p : d->parameters) {
      if (p.name == "stiffness") return p.unit;
    }
  }
  return "N/m";
}

}  // namespace

std::string DeviceModel::describe() const {
  const bool rotary = info.motion == drivers::Motion::rotary;
  std::string s =
      rotary ? "J = " + num(info.effective_mass) + " kg m^2" : "m = " + num(info.effective_mass) + " kg";
  if (info.viscous_damping > 0) {
    s += ", b = " + num(info.viscous_damping) + (rotary ? " N m s/rad" : " N s/m");
  }
  s += ", T = " + num(period_s * 1e3) + " ms, d = " + std::to_string(info.delay_periods);
  if (plant.dynamics.a.rows() == 4) s += ", two-mass (" + std::string(world::to_string(sensor)) + " sensing)";
  return s;
}

DeviceModel make_device_model(const drivers::Device& device, double period_s) {
  DeviceModel model;
  model.info = device.model();
  model.period_s = period_s;
  if (model.info.plant) {
    model.plant = *model.info.plant;
    model.sensor = model.info.sensor;
  } else {
    model.plant = world::RigidPlant{model.info.effective_mass, model.info.viscous_damping}.model();
  }
  return model;
}

StabilityVerdict check_stability(const world::ScenePlan& plan, const DeviceModel& device) {
  StabilityVerdict v;
  if (!plan.linear) {
    v.summary = "not a linear scene: no stability region applies (the torque limit holds)";
    return v;
  }
  v.checked = true;
  analysis::NumericRecord scene_record;
  const analysis::Spectrum held =
      analysis::spectrum("the scene's state matrix", plan.linear->a, scene_record);
  const auto closed = analysis::analyze_closed_loop(
      device.plant, device.sensor, *plan.linear, device.period_s, device.info.delay_periods, drift_tolerance);
  const analysis::Verdict& verdict = analysis::worse(
      analysis::judge_radius(held.radius, scene_tolerance, device.period_s, scene_record), closed.verdict);
  v.verdict = verdict.state;
  v.reason = verdict.reason;
  v.stable = verdict.stable();
  v.scene_radius = held.radius;
  v.closed_loop_radius = closed.pole_radius;
  if (!verdict.assessed()) {
    v.growth_per_second = std::numeric_limits<double>::quiet_NaN();
    v.summary = "stability cannot be assessed on this device (" + device.describe() + "): " + verdict.reason;
    return v;
  }
  const double worst = std::max(v.scene_radius, v.closed_loop_radius);
  v.growth_per_second = std::pow(worst, 1.0 / device.period_s);
  if (v.stable) {
    v.summary = "stable on this device: pole radius " + radius(v.closed_loop_radius) + " (released), " +
                radius(v.scene_radius) + " (held)";
  } else {
    v.summary = "unstable on this device (" + device.describe() + "): pole radius " + radius(worst) +
                ", amplitude grows x" + num(v.growth_per_second) + " per second";
  }
  return v;
}

namespace {

/// Largest stiffness in [0, requested] for which the plan is stable, other
/// parameters fixed (bisection; stability is monotone in K along this line
/// for the scenes here). Nothing if even a vanishing stiffness is unstable.
std::optional<double> largest_stable_stiffness(std::string_view scene, world::ParameterSet parameters,
                                               double requested, const DeviceModel& device) {
  auto stable_at = [&](double k) {
    parameters["stiffness"] = k;
    auto outcome = world::plan_scene(scene, parameters, device.period_s, device.motion());
    const auto* plan = std::get_if<world::ScenePlan>(&outcome);
    return plan != nullptr && check_stability(*plan, device).stable;
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

}  // namespace

PlanOutcome plan_on_device(std::string_view scene, const world::ParameterSet& parameters,
                           const DeviceModel& device, bool force) {
  auto outcome = world::plan_scene(scene, parameters, device.period_s, device.motion());
  if (const auto* error = std::get_if<world::SceneError>(&outcome)) {
    return PlanRefusal{true, error->message, nullptr, true, error->parameter};
  }
  PlannedScene planned{std::move(std::get<world::ScenePlan>(outcome)), {}, false};
  planned.stability = check_stability(planned.plan, device);
  if (planned.stability.stable) return planned;
  if (planned.stability.verdict == analysis::VerdictState::cannot_assess) {
    // Not forceable: a scene whose numbers overflow or lost precision renders
    // nothing the analysis could describe (it may emit NaN).
    PlanRefusal refusal;
    refusal.assessed = false;
    refusal.message = std::string(scene) + ": " + planned.stability.summary;
    refusal.data = {{"stability", to_json(planned.stability)}};
    return refusal;
  }
  if (force) {
    planned.forced = true;
    return planned;
  }

  PlanRefusal refusal;
  refusal.message = std::string(scene) + ": " + planned.stability.summary;
  nlohmann::json limit = nlohmann::json::object();
  const auto it = planned.plan.parameters.find("stiffness");
  if (it != planned.plan.parameters.end()) {
    const double requested = std::get<double>(it->second);
    const auto k = largest_stable_stiffness(scene, planned.plan.parameters, requested, device);
    const std::string unit = stiffness_unit(planned.plan);
    if (k) {
      refusal.message += "; the largest stable stiffness with these parameters is " + num(*k) + " " + unit;
      limit["stiffness"] = *k;
    } else {
      refusal.message += "; no stiffness > 0 is stable with these parameters";
      if (scene.starts_with("spring")) {
        refusal.message += " (try damping=auto, i.e. b = T k (Freudenberg 2.24), or another integrator)";
      }
    }
  }
  // The wall on a rigid device without mechanical damping is exactly Hulin's
  // problem: say what his region allows.
  if (scene == "wall" && device.plant.dynamics.a.rows() == 2 && device.info.viscous_damping == 0.0) {
    const int d =
        static_cast<int>(std::get<double>(planned.plan.parameters.at("delay"))) + device.info.delay_periods;
    const auto verdict = analysis::analyze_wall(device.info.effective_mass, device.period_s, d,
                                                std::get<double>(planned.plan.parameters.at("stiffness")),
                                                std::get<double>(planned.plan.parameters.at("damping")));
    refusal.message += ". Hulin: " + analysis::refusal_message(verdict);
    limit["k_max"] = verdict.k_max;
    limit["b_at_k_max"] = verdict.b_at_k_max;
    if (verdict.damping_range)
      limit["damping_range"] = {verdict.damping_range->lower, verdict.damping_range->upper};
  }
  refusal.data = {{"limit", limit}, {"stability", to_json(planned.stability)}};
  return refusal;
}

std::string refusal_text(const PlanRefusal& refusal, std::string_view how) {
  if (refusal.invalid || !refusal.assessed) return refusal.message;
  return refusal.message + ". " + std::string(how) + " to load it anyway; the torque limit still holds";
}

nlohmann::json to_json(const StabilityVerdict& v) {
  // NaN (not assessed) and inf (growth that overflows) as null, explicitly.
  const auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  return {{"checked", v.checked},
          {"verdict", v.checked ? nlohmann::json(analysis::to_string(v.verdict)) : nlohmann::json(nullptr)},
          {"reason", v.reason.empty() ? nlohmann::json(nullptr) : nlohmann::json(v.reason)},
          {"stable", v.stable},
          {"scene_radius", number(v.scene_radius)},
          {"closed_loop_radius", number(v.closed_loop_radius)},
          {"growth_per_second", number(v.growth_per_second)},
          {"summary", v.summary}};
}

nlohmann::json to_json(const world::ParameterSet& parameters, std::string_view scene) {
  const world::SceneDescription* description = world::find_scene(scene);
  const auto is_integer = [&](const std::string& name) {
    if (description == nullptr) return false;
    for (const auto& p : description->parameters) {
      if (p.name == name) return p.type == world::ParameterType::integer;
    }
    return false;
  };
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [name, value] : parameters) {
    const auto* number = std::get_if<double>(&value);
    if (number != nullptr && is_integer(name) && std::isfinite(*number)) {
      out[name] = static_cast<std::int64_t>(std::llround(*number));
    } else {
      std::visit([&, n = name](const auto& v) { out[n] = v; }, value);
    }
  }
  return out;
}

const std::string& unit_on(const world::ParameterDescription& parameter, world::Motion motion) {
  return motion == world::Motion::rotary && !parameter.rotary_unit.empty() ? parameter.rotary_unit
                                                                           : parameter.unit;
}

nlohmann::json parameter_units(std::string_view scene, world::Motion motion) {
  nlohmann::json out = nlohmann::json::object();
  if (const auto* description = world::find_scene(scene)) {
    for (const auto& p : description->parameters) out[p.name] = unit_on(p, motion);
  }
  return out;
}

world::ParameterSet parameters_from_json(const nlohmann::json& object) {
  if (!object.is_object()) throw std::invalid_argument("params must be an object of name: value");
  world::ParameterSet out;
  for (const auto& [name, value] : object.items()) {
    if (value.is_number()) {
      out[name] = value.get<double>();
    } else if (value.is_boolean()) {
      out[name] = value.get<bool>();
    } else if (value.is_string()) {
      out[name] = value.get<std::string>();
    } else {
      throw std::invalid_argument("parameter '" + name + "': expected a number, boolean or string");
    }
  }
  return out;
}

std::string to_text(const world::ParameterValue& value) {
  if (const auto* d = std::get_if<double>(&value)) {
    char b[32];
    std::snprintf(b, sizeof b, "%.10g", *d);
    return b;
  }
  if (const auto* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  return std::get<std::string>(value);
}

}  // namespace hapticd::daemon
