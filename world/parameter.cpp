#include "world/parameter.hpp"

namespace hapticd::world {

std::string_view to_string(Motion motion) noexcept { return motion == Motion::rotary ? "rotary" : "linear"; }

std::string_view to_string(ParameterType type) noexcept {
  switch (type) {
    case ParameterType::number:
      return "number";
    case ParameterType::integer:
      return "integer";
    case ParameterType::boolean:
      return "bool";
    case ParameterType::text:
      return "text";
    case ParameterType::choice:
      return "choice";
    case ParameterType::duration:
      return "duration";
    case ParameterType::table:
      return "table";
  }
  return "number";
}

namespace {
ParameterSpec spec_of(std::string name, ParameterType type, std::string unit, std::string help) {
  ParameterSpec p;
  p.name = std::move(name);
  p.type = type;
  p.unit = std::move(unit);
  p.help = std::move(help);
  return p;
}
}  // namespace

ParameterSpec ParameterSpec::number(std::string name, std::string unit, std::string help) {
  return spec_of(std::move(name), ParameterType::number, std::move(unit), std::move(help));
}
ParameterSpec ParameterSpec::integer(std::string name, std::string unit, std::string help) {
  return spec_of(std::move(name), ParameterType::integer, std::move(unit), std::move(help));
}
ParameterSpec ParameterSpec::boolean(std::string name, std::string help) {
  return spec_of(std::move(name), ParameterType::boolean, {}, std::move(help));
}
ParameterSpec ParameterSpec::text(std::string name, std::string help) {
  return spec_of(std::move(name), ParameterType::text, {}, std::move(help));
}
ParameterSpec ParameterSpec::choice(std::string name, std::vector<std::string> accepted, std::string help) {
  ParameterSpec p = spec_of(std::move(name), ParameterType::choice, {}, std::move(help));
  p.accepted = std::move(accepted);
  return p;
}
ParameterSpec ParameterSpec::duration(std::string name, std::string help) {
  return spec_of(std::move(name), ParameterType::duration, "s", std::move(help));
}
ParameterSpec ParameterSpec::table(std::string name, std::string help) {
  return spec_of(std::move(name), ParameterType::table, {}, std::move(help));
}
ParameterSpec& ParameterSpec::defaults_to(ParameterValue value, std::string note) {
  default_value = std::move(value);
  default_note = std::move(note);
  return *this;
}
ParameterSpec& ParameterSpec::at_least(double value) {
  minimum = value;
  minimum_exclusive = false;
  return *this;
}
ParameterSpec& ParameterSpec::above(double value) {
  minimum = value;
  minimum_exclusive = true;
  return *this;
}
ParameterSpec& ParameterSpec::at_most(double value) {
  maximum = value;
  return *this;
}
ParameterSpec& ParameterSpec::on_rotary(std::string unit_on_rotary) {
  rotary_unit = std::move(unit_on_rotary);
  return *this;
}
ParameterSpec& ParameterSpec::or_word(std::string word) {
  accepted.push_back(std::move(word));
  return *this;
}
ParameterSpec& ParameterSpec::canonical_by(Canonical function) {
  canonical = function;
  return *this;
}

const std::string& ParameterSpec::unit_on(Motion motion) const noexcept {
  return motion == Motion::rotary && !rotary_unit.empty() ? rotary_unit : unit;
}

}  // namespace hapticd::world
