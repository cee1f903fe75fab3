#include "world/scene_catalog.hpp"

#include <cmath>
#include <exception>

#include "world/scene_registry.hpp"
#include "world/text.hpp"

namespace hapticd::world {

namespace {

using text::format_significant;
using text::join;
constexpr int digits = text::precision::message;

template <class... Entries>
std::vector<SceneDescription> describe_all(SceneList<Entries...> /*registry*/) {
  return {Entries::describe()...};
}

std::string format_value(const ParameterValue& value) {
  if (const double* x = std::get_if<double>(&value)) return format_significant(*x, digits);
  if (const bool* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  return '\'' + std::get<std::string>(value) + '\'';
}

std::optional<ParameterValue> validate_number(const ParameterSpec& p, const ParameterValue& value) {
  std::optional<double> x;
  if (const double* d = std::get_if<double>(&value)) {
    x = *d;
  } else if (const std::string* s = std::get_if<std::string>(&value)) {
    for (const auto& word : p.accepted) {
      if (*s == word) return value;
    }
    x = units::parse_finite(*s);
  }
  if (!x || !std::isfinite(*x)) return std::nullopt;
  if (p.minimum && (p.minimum_exclusive ? !(*x > *p.minimum) : !(*x >= *p.minimum))) return std::nullopt;
  if (p.maximum && !(*x <= *p.maximum)) return std::nullopt;
  if (p.type == ParameterType::integer && std::trunc(*x) != *x) return std::nullopt;
  return ParameterValue{*x};
}

std::optional<ParameterValue> validate_choice(const ParameterSpec& p, const ParameterValue& value) {
  const std::string* s = std::get_if<std::string>(&value);
  if (s == nullptr) return std::nullopt;
  if (p.canonical != nullptr) {
    if (auto canonical = p.canonical(*s)) return ParameterValue{std::move(*canonical)};
    return std::nullopt;
  }
  for (const auto& a : p.accepted) {
    if (*s == a) return value;
  }
  return std::nullopt;
}

/// Returns the canonical value, or nothing when not accepted.
std::optional<ParameterValue> validate(const ParameterSpec& p, const ParameterValue& value) {
  switch (p.type) {
    case ParameterType::number:
    case ParameterType::integer:
      return validate_number(p, value);
    case ParameterType::choice:
      return validate_choice(p, value);
    case ParameterType::boolean:
      if (std::holds_alternative<bool>(value)) return value;
      if (const std::string* s = std::get_if<std::string>(&value)) {
        if (*s == "true") return ParameterValue{true};
        if (*s == "false") return ParameterValue{false};
      }
      return std::nullopt;
    case ParameterType::text:
      // The task scenes' vectors ("1,1"): the factory parses them, naming the parameter.
      if (std::holds_alternative<std::string>(value)) return value;
      return std::nullopt;
    case ParameterType::duration:
    case ParameterType::table:
      break;  // no scene takes these
  }
  return std::nullopt;
}

/// A task-space scene on one axis, or a one-axis scene on several.
std::optional<SceneError> wrong_space(const SceneDescription& scene, int axes) {
  if (scene.space == SceneSpace::any) return std::nullopt;
  if (scene.space == SceneSpace::task && axes == 1)
    return SceneError{scene.name +
                      " is a task-space scene for a device with several axes; this device has one "
                      "axis; accepted: " +
                      scene_names_for(1)};
  if (scene.space == SceneSpace::one_axis && axes > 1)
    return SceneError{scene.name + " renders on one axis; this device has " + std::to_string(axes) +
                      " axes; accepted: " + scene_names_for(axes)};
  return std::nullopt;
}

/// Refuses a given parameter the scene does not have, naming the ones it has.
std::optional<SceneError> unknown_parameter(const SceneDescription& scene, const ParameterSet& given) {
  for (const auto& entry : given) {
    const std::string& key = entry.first;
    bool known = false;
    for (const auto& p : scene.parameters) known = known || p.name == key;
    if (known) continue;
    std::vector<std::string> names;
    for (const auto& p : scene.parameters) names.push_back(p.name);
    return SceneError{"unknown parameter '" + key + "' for scene " + scene.name +
                          "; accepted: " + (names.empty() ? std::string("none") : join(names)),
                      key};
  }
  return std::nullopt;
}

}  // namespace

std::string_view to_string(StabilityRule rule) noexcept {
  switch (rule) {
    case StabilityRule::none:
      return "none";
    case StabilityRule::linear:
      return "linear";
    case StabilityRule::hulin_wall:
      return "hulin_wall";
    case StabilityRule::task_wall:
      return "task_wall";
    case StabilityRule::per_axis:
      return "per_axis";
  }
  return "none";
}

std::string_view to_string(SceneSpace space) noexcept {
  switch (space) {
    case SceneSpace::one_axis:
      return "one-axis";
    case SceneSpace::task:
      return "task";
    case SceneSpace::any:
      return "any";
  }
  return "one-axis";
}

std::string_view scene_type_name(ParameterType type) noexcept {
  return type == ParameterType::choice ? "enum" : to_string(type);
}

const std::vector<SceneDescription>& scene_catalog() {
  static const std::vector<SceneDescription> catalog = describe_all(SceneRegistry{});
  return catalog;
}

const SceneDescription* find_scene(std::string_view name) noexcept {
  for (const auto& s : scene_catalog()) {
    if (s.name == name) return &s;
  }
  return nullptr;
}

std::string scene_names() {
  std::vector<std::string> names;
  for (const auto& s : scene_catalog()) names.push_back(s.name);
  return join(names);
}

std::string scene_names_for(int axes) {
  std::vector<std::string> names;
  for (const auto& s : scene_catalog()) {
    if (s.space == SceneSpace::any || (s.space == SceneSpace::task) == (axes > 1)) names.push_back(s.name);
  }
  return join(names);
}

std::string accepted_text(const ParameterSpec& p, Motion motion) {
  const std::string& unit = p.unit_on(motion);
  const auto show = [](double x) { return format_significant(x, digits); };
  switch (p.type) {
    case ParameterType::number: {
      std::string out = "a finite number";
      if (p.minimum) out += (p.minimum_exclusive ? " > " : " >= ") + show(*p.minimum);
      if (p.maximum) out += (p.minimum ? " and <= " : " <= ") + show(*p.maximum);
      if (!unit.empty()) out += " (" + unit + ")";
      for (const auto& word : p.accepted) out += " or " + word;
      return out;
    }
    case ParameterType::integer: {
      std::string out = "an integer";
      if (p.minimum && p.maximum) {
        out += " " + show(*p.minimum) + ".." + show(*p.maximum);
      } else if (p.minimum) {
        out += " >= " + show(*p.minimum);
      }
      if (!unit.empty()) out += " (" + unit + ")";
      return out;
    }
    case ParameterType::choice:
      return "one of " + join(p.accepted);
    case ParameterType::boolean:
      return "true or false";
    case ParameterType::text:
      return "comma-separated numbers, one per axis" + (unit.empty() ? std::string() : " (" + unit + ")");
    case ParameterType::duration:
    case ParameterType::table:
      break;
  }
  return {};
}

double number_of(const ParameterSet& parameters, std::string_view name) {
  return std::get<double>(parameters.find(name)->second);
}

const std::string& text_of(const ParameterSet& parameters, std::string_view name) {
  return std::get<std::string>(parameters.find(name)->second);
}

std::vector<ChannelDescription> describe_channels(std::span<const std::string_view> names, Motion motion) {
  const std::string pos = motion == Motion::rotary ? "rad" : "m";
  const std::string vel = motion == Motion::rotary ? "rad/s" : "m/s";
  std::vector<ChannelDescription> out;
  for (const std::string_view n : names) {
    std::string unit;
    if (n.ends_with("velocity")) {
      unit = vel;
    } else if (n == "armed") {
      unit = "1";
    } else if (n == "passivity_energy") {
      unit = "J";
    } else if (n == "passivity_damping") {
      unit = motion == Motion::rotary ? "N m s/rad" : "N s/m";
    } else {
      unit = pos;
    }
    out.push_back({std::string(n), unit});
  }
  return out;
}

PlanResult plan_scene(std::string_view name, const ParameterSet& given, double period_s, Motion motion,
                      int axes) {
  const SceneDescription* description = find_scene(name);
  if (description == nullptr) {
    return SceneError{"unknown scene '" + std::string(name) + "'; accepted: " + scene_names_for(axes)};
  }
  if (!(std::isfinite(period_s) && period_s > 0.0)) {
    return SceneError{"period: " + format_significant(period_s, digits) +
                      " is not accepted; a finite number > 0 (s)"};
  }
  if (axes < 1 || axes > max_axes) {
    return SceneError{"axes: " + std::to_string(axes) + " is not accepted; 1 to " + std::to_string(max_axes)};
  }
  if (auto error = wrong_space(*description, axes)) return *error;
  motion = description->fixed_motion.value_or(motion);
  if (auto error = unknown_parameter(*description, given)) return *error;

  ScenePlan plan;
  plan.scene = description->name;
  plan.description = description;
  for (const auto& p : description->parameters) {
    const auto it = given.find(p.name);
    if (it == given.end()) {
      plan.parameters[p.name] = p.default_value.value_or(ParameterValue{});
      continue;
    }
    auto canonical = validate(p, it->second);
    if (!canonical) {
      return SceneError{
          p.name + ": " + format_value(it->second) + " is not accepted; " + accepted_text(p, motion), p.name};
    }
    plan.parameters[p.name] = std::move(*canonical);
  }

  try {
    description->build(plan, {period_s, motion, axes});
  } catch (const std::exception& e) {
    return SceneError{plan.scene + ": " + e.what()};
  }
  return plan;
}

}  // namespace hapticd::world
