#include "drivers/parameter.hpp"

#include <cmath>

#include <nlohmann/json.hpp>

#include "world/text.hpp"
#include "world/units.hpp"

namespace hapticd::drivers {

namespace {

using world::text::format_number;
using world::text::join;

std::string range_text(const ParameterSpec& spec, bool seconds) {
  auto show = [seconds](double v) { return seconds ? world::units::format_duration(v) : format_number(v); };
  if (spec.minimum && spec.maximum) {
    return "in " + std::string(spec.minimum_exclusive ? "(" : "[") + show(*spec.minimum) + ", " +
           show(*spec.maximum) + "]";
  }
  if (spec.minimum) return (spec.minimum_exclusive ? "> " : ">= ") + show(*spec.minimum);
  if (spec.maximum) return "<= " + show(*spec.maximum);
  return {};
}

bool in_range(const ParameterSpec& spec, double v) {
  if (spec.minimum && (spec.minimum_exclusive ? !(v > *spec.minimum) : !(v >= *spec.minimum))) return false;
  return !(spec.maximum && v > *spec.maximum);
}

std::optional<double> as_number(const ParameterValue& raw) {
  if (const auto* d = std::get_if<double>(&raw)) return *d;
  if (const auto* s = std::get_if<std::string>(&raw)) return world::units::parse_finite(*s);
  return std::nullopt;
}

}  // namespace

ParameterSpec motion_parameter(std::string help) {
  return ParameterSpec::choice("motion", {"rotary", "linear"}, std::move(help)).defaults_to("rotary");
}

ParameterSpec mass_parameter(std::string help) {
  namespace r = world::parameter_range;
  return ParameterSpec::number("mass", "kg m^2 | kg", std::move(help))
      .at_least(r::min_mass)
      .at_most(r::max_mass);
}

ParameterSpec damping_parameter(std::string help) {
  namespace r = world::parameter_range;
  return ParameterSpec::number("damping", "N m s/rad | N s/m", std::move(help))
      .defaults_to(0.0)
      .at_least(0.0)
      .at_most(r::max_damping);
}

std::string to_text(const ParameterValue& value) {
  if (const auto* d = std::get_if<double>(&value)) return format_number(*d);
  if (const auto* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  return "\"" + std::get<std::string>(value) + "\"";
}

std::string accepted_text(const ParameterSpec& spec) {
  const std::string unit = spec.unit.empty() ? "" : " " + spec.unit;
  switch (spec.type) {
    case ParameterType::number: {
      const std::string range = range_text(spec, false);
      std::string words;
      for (const auto& word : spec.accepted) words += " or " + word;
      return "a number" + (range.empty() ? "" : " " + range) + unit + words;
    }
    case ParameterType::integer: {
      const std::string range = range_text(spec, false);
      return "a whole number" + (range.empty() ? "" : " " + range) + unit;
    }
    case ParameterType::boolean:
      return "true or false";
    case ParameterType::text:
      return "text";
    case ParameterType::choice:
      return "one of " + join(spec.accepted);
    case ParameterType::duration: {
      const std::string range = range_text(spec, true);
      return "a duration (s, ms or us)" + (range.empty() ? "" : " " + range);
    }
    case ParameterType::table:
      return "a table of key = value pairs, or the same as one line of text";
  }
  return {};
}

namespace {

/// The canonical value of `raw` for `spec`, or a one-line reason.
std::variant<ParameterValue, std::string> check(const ParameterSpec& spec, const ParameterValue& raw) {
  const std::string nope = "is not accepted; accepted: " + accepted_text(spec);
  switch (spec.type) {
    case ParameterType::number:
    case ParameterType::integer: {
      if (const auto* s = std::get_if<std::string>(&raw)) {
        for (const auto& word : spec.accepted) {
          if (word == *s) return raw;  // a word the number takes ("auto")
        }
      }
      const auto v = as_number(raw);
      if (!v || !std::isfinite(*v)) return nope;
      if (spec.type == ParameterType::integer && std::trunc(*v) != *v) return nope;
      if (!in_range(spec, *v)) return "is out of range; accepted: " + accepted_text(spec);
      return ParameterValue(*v);
    }
    case ParameterType::duration: {
      std::optional<double> v;
      if (const auto* d = std::get_if<double>(&raw)) v = *d;
      if (const auto* s = std::get_if<std::string>(&raw)) v = world::units::parse_duration_s(*s);
      if (!v || !std::isfinite(*v)) return nope;
      if (!in_range(spec, *v)) return "is out of range; accepted: " + accepted_text(spec);
      return ParameterValue(*v);
    }
    case ParameterType::boolean:
      if (std::holds_alternative<bool>(raw)) return raw;
      return nope;
    case ParameterType::text:
    case ParameterType::table:
      if (std::holds_alternative<std::string>(raw)) return raw;
      return nope;
    case ParameterType::choice: {
      const auto* s = std::get_if<std::string>(&raw);
      if (s == nullptr) return nope;
      if (spec.canonical != nullptr) {
        if (auto canonical = spec.canonical(*s)) return ParameterValue(std::move(*canonical));
        return nope;
      }
      for (const auto& a : spec.accepted) {
        if (a == *s) return raw;
      }
      return nope;
    }
  }
  return nope;
}

}  // namespace

DriverParameters::DriverParameters(std::string driver, const std::vector<ParameterSpec>& specs,
                                   const std::map<std::string, ParameterValue, std::less<>>& given)
    : driver_(std::move(driver)) {
  auto key_of = [this](std::string_view name) { return "device." + driver_ + "." + std::string(name); };
  for (const auto& [key, raw] : given) {
    const ParameterSpec* spec = nullptr;
    std::string entry;  // the key inside a table parameter
    for (const auto& s : specs) {
      if (key == s.name) spec = &s;
      if (s.type == ParameterType::table && key.size() > s.name.size() + 1 && key.starts_with(s.name) &&
          key[s.name.size()] == '.') {
        spec = &s;
        entry = key.substr(s.name.size() + 1);
      }
    }
    if (spec == nullptr) {
      std::vector<std::string> names;
      names.reserve(specs.size());
      for (const auto& s : specs) names.push_back(s.name);
      throw ParameterError(
          key, key_of(key) + " is not a parameter of the " + driver_ + " driver; accepted: " + join(names));
    }
    if (!entry.empty()) {
      const auto* text = std::get_if<std::string>(&raw);
      tables_[spec->name].emplace_back(entry, text != nullptr ? *text : to_text(raw));
      given_.push_back(spec->name);
      continue;
    }
    auto checked = check(*spec, raw);
    if (const auto* reason = std::get_if<std::string>(&checked)) {
      throw ParameterError(key, key_of(key) + " = " + to_text(raw) + " " + *reason);
    }
    values_[spec->name] = std::get<ParameterValue>(checked);
    given_.push_back(spec->name);
  }
  for (const auto& s : specs) {
    if (values_.contains(s.name) || tables_.contains(s.name)) continue;
    if (s.type == ParameterType::table) continue;  // an empty table
    if (!s.default_value) {
      throw ParameterError(s.name, key_of(s.name) + " is required; accepted: " + accepted_text(s));
    }
    values_[s.name] = *s.default_value;
  }
}

const ParameterValue& DriverParameters::value(std::string_view name, ParameterType type) const {
  const auto it = values_.find(name);
  if (it == values_.end()) {
    throw std::logic_error("driver " + driver_ + " has no " + std::string(to_string(type)) + " parameter " +
                           std::string(name));
  }
  return it->second;
}

double DriverParameters::number(std::string_view name) const {
  return std::get<double>(value(name, ParameterType::number));
}
std::int64_t DriverParameters::integer(std::string_view name) const {
  return static_cast<std::int64_t>(std::get<double>(value(name, ParameterType::integer)));
}
bool DriverParameters::boolean(std::string_view name) const {
  return std::get<bool>(value(name, ParameterType::boolean));
}
const std::string& DriverParameters::text(std::string_view name) const {
  return std::get<std::string>(value(name, ParameterType::text));
}
double DriverParameters::duration_s(std::string_view name) const {
  return std::get<double>(value(name, ParameterType::duration));
}

std::vector<std::pair<std::string, std::string>> DriverParameters::table(std::string_view name) const {
  std::vector<std::pair<std::string, std::string>> out;
  if (const auto it = values_.find(name); it != values_.end()) {
    if (const auto* line = std::get_if<std::string>(&it->second); line != nullptr && !line->empty()) {
      out.emplace_back(std::string(), *line);
    }
  }
  if (const auto it = tables_.find(name); it != tables_.end()) {
    out.insert(out.end(), it->second.begin(), it->second.end());
  }
  return out;
}

bool DriverParameters::given(std::string_view name) const {
  for (const auto& g : given_) {
    if (g == name) return true;
  }
  return false;
}

nlohmann::json DriverParameters::to_json() const {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& entry : values_) {
    std::visit([&out, &entry](const auto& x) { out[entry.first] = x; }, entry.second);
  }
  for (const auto& [name, entries] : tables_) {
    std::string text;
    for (const auto& [k, v] : entries) text += (text.empty() ? "" : " ") + k + "=" + v;
    out[name] = text;
  }
  return out;
}

nlohmann::json to_json(const ParameterSpec& spec) {
  nlohmann::json j{{"name", spec.name},
                   {"type", std::string(to_string(spec.type))},
                   {"unit", spec.unit},
                   {"help", spec.help},
                   {"required", !spec.default_value && spec.type != ParameterType::table}};
  if (spec.default_value) std::visit([&](const auto& x) { j["default"] = x; }, *spec.default_value);
  if (!spec.default_note.empty()) j["default_note"] = spec.default_note;
  if (spec.minimum) {
    j["minimum"] = *spec.minimum;
    if (spec.minimum_exclusive) j["minimum_exclusive"] = true;
  }
  if (spec.maximum) j["maximum"] = *spec.maximum;
  if (!spec.accepted.empty()) j["accepted"] = spec.accepted;
  return j;
}

}  // namespace hapticd::drivers
