#include "daemon/planner.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <variant>

#include "world/text.hpp"

namespace hapticd::daemon {

std::string DeviceModel::describe() const { return gate().describe(); }

analysis::GateDevice DeviceModel::gate() const {
  analysis::GateDevice device;
  device.plant = plant;
  device.sensor = sensor;
  device.period_s = period_s;
  device.delay_samples = info.delay_periods;
  device.mass = info.effective_mass;
  device.damping = info.viscous_damping;
  device.motion = motion();
  for (const auto& axis : info.axes) device.axes.push_back({axis.mass, axis.damping});
  device.axis_names = axis_names;
  if (const auto& p = info.pantograph) {
    device.pantograph = world::PantographKinematics(p->geometry);
    device.workspace = {p->x_min, p->x_max, p->y_min, p->y_max};
  }
  return device;
}

DeviceModel make_device_model(const drivers::Device& device, double period_s) {
  return make_device_model(device.model(), period_s);
}

DeviceModel make_device_model(drivers::DeviceModel info, double period_s) {
  DeviceModel model;
  model.info = std::move(info);
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
  return analysis::check_scene_stability(plan, device.gate());
}

namespace {
/// The passivity controller's deadband, unless given: up to one encoder count
/// a period of this device (world/passivity_observer.hpp says why). Readings
/// move by whole counts, so 1.5 counts keeps one count in whatever the
/// rounding of the difference.
/// And the device's delay, so that the observer pairs each force with the
/// period it acted in (a CiA 402 drive applies it at the next SYNC).
world::ParameterSet with_device_passivity(const world::ParameterSet& parameters, const DeviceModel& device) {
  const auto mode = parameters.find("passivity");
  const auto* text = mode == parameters.end() ? nullptr : std::get_if<std::string>(&mode->second);
  if (text == nullptr || *text == "off") return parameters;
  world::ParameterSet out = parameters;
  const int delay = device.info.delay_periods;
  if (delay > 0) out.emplace("passivity_device_delay", static_cast<double>(delay));
  const double resolution = device.info.position_resolution;
  if (*text == "controller" && std::isfinite(resolution) && resolution > 0.0 && device.period_s > 0.0)
    out.emplace("passivity_velocity_deadband", std::min(1.5 * resolution / device.period_s, 1e3));
  return out;
}
}  // namespace

PlanOutcome plan_on_device(std::string_view scene, const world::ParameterSet& parameters,
                           const DeviceModel& device, bool force) {
  auto outcome = analysis::gate_scene(scene, with_device_passivity(parameters, device), device.gate(), force);
  if (auto* accepted = std::get_if<analysis::GateAccepted>(&outcome)) {
    return PlannedScene{std::move(accepted->plan), std::move(accepted->stability), accepted->forced};
  }
  const auto& refused = std::get<analysis::GateRefusal>(outcome);
  if (refused.invalid) return PlanRefusal{true, refused.message, nullptr, true, refused.parameter};
  if (!refused.assessed)
    return PlanRefusal{false, refused.message, {{"stability", to_json(*refused.stability)}}, false};
  nlohmann::json limit = nlohmann::json::object();
  if (refused.stiffness_limit) limit["stiffness"] = *refused.stiffness_limit;
  if (refused.hulin) {
    limit["k_max"] = refused.hulin->k_max;
    limit["b_at_k_max"] = refused.hulin->b_at_k_max;
    if (refused.hulin->damping_range) {
      limit["damping_range"] = {refused.hulin->damping_range->lower, refused.hulin->damping_range->upper};
    }
  }
  return PlanRefusal{false, refused.message, {{"limit", limit}, {"stability", to_json(*refused.stability)}}};
}

std::string refusal_text(const PlanRefusal& refusal, std::string_view how) {
  if (refusal.invalid || !refusal.assessed) return refusal.message;
  return refusal.message + ". " + std::string(how) + " to load it anyway; the torque limit still holds";
}

namespace {
/// Colgate & Schenkel's answer beside the stability verdict (docs/protocol.md).
nlohmann::json passivity_json(const StabilityVerdict& v) {
  if (!v.checked) return nullptr;
  const auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  const analysis::PassivityBound& b = v.passivity;
  return {{"state", analysis::to_string(b.state)},
          {"required_damping", b.bounded() ? number(b.required_damping) : nlohmann::json(nullptr)},
          {"device_damping", number(v.device_damping)},
          {"frequency_hz", b.assessed() ? number(b.frequency_hz) : nlohmann::json(nullptr)},
          {"summary", v.passivity_summary}};
}
}  // namespace

nlohmann::json to_json(const StabilityVerdict& v) {
  // NaN (not assessed) and inf (growth that overflows) as null, explicitly.
  const auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  // A factor above this is null: 2e+303 is no number to compute with (one
  // more multiplication overflows); growth_per_second_log10 and
  // doubling_time_s say it, finite.
  constexpr double max_growth_per_second = 1e15;
  const double growth = v.growth_per_second <= max_growth_per_second ? v.growth_per_second : NAN;
  return {
      {"checked", v.checked},
      {"verdict", v.checked ? nlohmann::json(analysis::to_string(v.verdict)) : nlohmann::json(nullptr)},
      {"reason", v.reason.empty() ? nlohmann::json(nullptr) : nlohmann::json(v.reason)},
      {"stable", v.stable},
      {"scene_radius", number(v.scene_radius)},
      {"closed_loop_radius", number(v.closed_loop_radius)},
      {"growth_per_second", number(growth)},
      {"growth_per_second_log10", number(v.growth_per_second_log10)},
      {"doubling_time_s", number(v.doubling_time_s)},
      {"summary", v.summary},
      {"passive", v.checked && v.passivity.assessed() ? nlohmann::json(v.passive) : nlohmann::json(nullptr)},
      {"passivity", passivity_json(v)}};
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

nlohmann::json parameter_units(std::string_view scene, world::Motion motion) {
  nlohmann::json out = nlohmann::json::object();
  if (const auto* description = world::find_scene(scene)) {
    for (const auto& p : description->parameters) out[p.name] = p.unit_on(motion);
  }
  return out;
}

namespace {

nlohmann::json parameter_json(const world::ParameterSpec& p, world::Motion motion) {
  nlohmann::json entry{{"name", p.name},
                       {"type", world::scene_type_name(p.type)},
                       {"unit", p.unit_on(motion)},
                       {"help", p.help}};
  if (p.default_value) std::visit([&](const auto& v) { entry["default"] = v; }, *p.default_value);
  if (const auto* number = p.default_value ? std::get_if<double>(&*p.default_value) : nullptr;
      number != nullptr && p.type == world::ParameterType::integer) {
    entry["default"] = static_cast<std::int64_t>(std::llround(*number));
  }
  if (!p.accepted.empty()) entry["accepted"] = p.accepted;
  if (p.minimum) {
    entry["minimum"] = *p.minimum;
    if (p.minimum_exclusive) entry["minimum_exclusive"] = true;
  }
  if (p.maximum) entry["maximum"] = *p.maximum;
  return entry;
}

}  // namespace

nlohmann::json scene_catalog_json(world::Motion motion, int axes) {
  nlohmann::json scenes = nlohmann::json::array();
  for (const auto& d : world::scene_catalog()) {
    // The scenes this device takes (a task-space scene needs several axes).
    if (d.space != world::SceneSpace::any && (d.space == world::SceneSpace::task) != (axes > 1)) continue;
    const world::Motion units = d.fixed_motion.value_or(motion);
    nlohmann::json params = nlohmann::json::array();
    for (const auto& p : d.parameters) params.push_back(parameter_json(p, units));
    scenes.push_back({{"name", d.name},
                      {"reference", d.reference},
                      {"summary", d.summary},
                      {"parameters", params},
                      {"motion", d.fixed_motion ? nlohmann::json(world::to_string(*d.fixed_motion))
                                                : nlohmann::json("device")},
                      {"stability", world::to_string(d.stability)}});
    if (axes > 1) scenes.back()["space"] = world::to_string(d.space);
  }
  return scenes;
}

namespace {

std::string cell(const std::string& text) { return world::text::markdown_cell(text); }

std::string markdown_range(const world::ParameterSpec& p) {
  namespace text = world::text;
  const auto show = [](double x) { return text::format_significant(x, text::precision::message); };
  std::string out;
  switch (p.type) {
    case world::ParameterType::number:
    case world::ParameterType::integer:
      if (p.minimum) out = (p.minimum_exclusive ? "> " : "") + show(*p.minimum);
      if (p.maximum) out += (out.empty() ? "<= " : " to ") + show(*p.maximum);
      for (const auto& word : p.accepted) out += ", or `" + word + "`";
      return out;
    case world::ParameterType::choice: {
      std::vector<std::string> quoted;
      for (const auto& a : p.accepted) quoted.push_back("`" + a + "`");
      return text::join(quoted);
    }
    case world::ParameterType::boolean:
      return "`true`, `false`";
    case world::ParameterType::text:
      return "comma-separated numbers, one per axis";
    default:
      return out;
  }
}

std::string markdown_default(const world::ParameterSpec& p) {
  if (!p.default_value) return "required";
  if (const auto* d = std::get_if<double>(&*p.default_value)) {
    return world::text::format_significant(*d, world::text::precision::message);
  }
  if (const auto* b = std::get_if<bool>(&*p.default_value)) return *b ? "`true`" : "`false`";
  if (std::get<std::string>(*p.default_value).empty()) return "empty";
  return "`" + std::get<std::string>(*p.default_value) + "`";
}

std::string markdown_unit(const world::ParameterSpec& p, const world::SceneDescription& scene) {
  if (scene.fixed_motion) return p.unit_on(*scene.fixed_motion);
  const std::string& linear = p.unit_on(world::Motion::linear);
  const std::string& rotary = p.unit_on(world::Motion::rotary);
  return linear == rotary ? linear : linear + " (" + rotary + ")";
}

std::string markdown_stability(world::StabilityRule rule) {
  switch (rule) {
    case world::StabilityRule::none:
      return "not judged (no linear model: the torque limit holds)";
    case world::StabilityRule::linear:
      return "its linear model, held and closed with the released device";
    case world::StabilityRule::hulin_wall:
      return "its linear model, held and closed with the released device; Hulin's region on a rigid "
             "undamped device";
    case world::StabilityRule::task_wall:
      return "Hulin's one-axis wall along each judged direction, with the mass and damping the device has "
             "there (m_n = 1 / (n^T J M^-1 J^T n)); on a pantograph its worst case over the workspace (a "
             "bound)";
    case world::StabilityRule::per_axis:
      return "the one-axis scene on each axis of a Cartesian stage with that axis' own mass and damping "
             "(exact: the axes decouple); refused naming the axis and its limit";
  }
  return {};
}

}  // namespace

std::string scene_catalog_markdown() {
  std::string out =
      "<!-- scene parameters: generated by `hapticd --list-scenes --format markdown` from the scenes'\n"
      "     own descriptions (world/<name>_scene.cpp); the test scenes_doc checks it is current -->\n";
  for (const auto& d : world::scene_catalog()) {
    out += "\n### " + d.name + "\n\n" + d.summary + ". Reference: " + d.reference + ".\n\n";
    out += "Units: " +
           (d.space == world::SceneSpace::task
                ? std::string("linear, in task space, on a device with several axes")
            : d.fixed_motion ? std::string(world::to_string(*d.fixed_motion)) + ", on any device"
                             : std::string("the device's; rotary in parentheses")) +
           ". Stability gate: " + markdown_stability(d.stability) + ".\n";
    if (d.parameters.empty()) {
      out += "\nNo parameters.\n";
      continue;
    }
    out += "\n| parameter | type | unit | default | accepted | meaning |\n|---|---|---|---|---|---|\n";
    for (const auto& p : d.parameters) {
      out += "| `" + p.name + "` | " + std::string(world::scene_type_name(p.type)) + " | " +
             cell(markdown_unit(p, d)) + " | " + markdown_default(p) + " | " + markdown_range(p) + " | " +
             cell(p.help) + " |\n";
    }
  }
  return out + "\n<!-- end of the generated scene parameters -->\n";
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
    return world::text::format_significant(*d, world::text::precision::parameter);
  }
  if (const auto* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  return std::get<std::string>(value);
}

}  // namespace hapticd::daemon
