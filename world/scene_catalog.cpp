#include "world/scene_catalog.hpp"

#include <cmath>
#include <cstdint>
#include <exception>
#include <sstream>

#include "world/integrator.hpp"

namespace hapticd::world {

namespace {

std::vector<std::string> integrator_list() {
  std::vector<std::string> out;
  out.reserve(all_integrators.size());
  for (const Integrator i : all_integrators) out.emplace_back(to_string(i));
  return out;
}

ParameterDescription number(std::string name, std::string unit, std::string rotary_unit, double def,
                            std::string help, std::optional<double> minimum, std::optional<double> maximum) {
  ParameterDescription p;
  p.name = std::move(name);
  p.type = ParameterType::number;
  p.unit = std::move(unit);
  p.rotary_unit = std::move(rotary_unit);
  p.default_value = def;
  p.help = std::move(help);
  p.minimum = minimum;
  p.maximum = maximum;
  return p;
}

ParameterDescription enumeration(std::string name, std::string def, std::vector<std::string> accepted,
                                 std::string help) {
  ParameterDescription p;
  p.name = std::move(name);
  p.type = ParameterType::enumeration;
  p.default_value = std::move(def);
  p.accepted = std::move(accepted);
  p.help = std::move(help);
  return p;
}

std::vector<ParameterDescription> spring_parameters(bool rotary) {
  namespace d = scene_defaults;
  namespace r = parameter_range;
  const std::string k_unit = rotary ? "N m/rad" : "N/m";
  const std::string b_unit = rotary ? "N m s/rad" : "N s/m";
  std::vector<ParameterDescription> out;
  out.push_back(number("stiffness", k_unit, k_unit, rotary ? d::wheel_stiffness : d::mass_stiffness,
                       "spring k between device and virtual body", 0.0, r::max_stiffness));
  if (rotary) {
    out.push_back(number("inertia", "kg m^2", "kg m^2", d::wheel_inertia, "virtual wheel inertia J_w",
                         r::min_mass, r::max_mass));
  } else {
    out.push_back(number("mass", "kg", "kg", d::mass_mass, "virtual mass m", r::min_mass, r::max_mass));
  }
  ParameterDescription damping =
      number("damping", b_unit, b_unit, 0.0,
             "damper b; 'auto' = T k, which makes forward Euler a lossless oscillator (Freudenberg 2.24)",
             0.0, r::max_damping);
  damping.accepted = {"auto"};
  out.push_back(std::move(damping));
  out.push_back(enumeration("damping_reference", "relative", {"relative", "absolute"},
                            "relative: b on theta_w_dot - y_dot (2.19-2.22, needs a velocity estimate); "
                            "absolute: b on theta_w_dot against the fixed frame (footnote 2)"));
  out.push_back(enumeration("integrator", "exact", integrator_list(), "discretization of the virtual body"));
  return out;
}

ParameterDescription samples(std::string name, double def, std::string help, double maximum) {
  ParameterDescription p;
  p.name = std::move(name);
  p.type = ParameterType::integer;
  p.unit = p.rotary_unit = "samples";
  p.default_value = def;
  p.help = std::move(help);
  p.minimum = 0.0;
  p.maximum = maximum;
  return p;
}

std::vector<SceneDescription> build_catalog() {
  namespace d = scene_defaults;
  namespace r = parameter_range;
  std::vector<SceneDescription> out;
  out.push_back({"spring-wheel", "Freudenberg 2.1-2.4, 2.16-2.24",
                 "virtual wheel J_w on a torsional spring k (and damper b) to the device",
                 spring_parameters(true)});
  out.push_back({"spring-mass", "Freudenberg 2, 2.19-2.24 (linear units)",
                 "virtual mass m on a spring k (and damper b) to the device", spring_parameters(false)});
  {
    SceneDescription wall{"wall",
                          "Hulin et al. 2006, eq. (1), section 7",
                          "unilateral PD wall: F = -K (y - x_w) - B v while penetrating, delayed d samples",
                          {}};
    wall.parameters.push_back(
        number("stiffness", "N/m", "N m/rad", d::wall_stiffness, "wall stiffness K", 0.0, r::max_stiffness));
    wall.parameters.push_back(number("damping", "N s/m", "N m s/rad", d::wall_damping,
                                     "wall damping B on the backward-difference velocity", 0.0,
                                     r::max_damping));
    wall.parameters.push_back(
        number("position", "m", "rad", 0.0, "wall surface x_w", -r::max_position, r::max_position));
    wall.parameters.push_back(
        enumeration("side", "upper", {"upper", "lower"}, "upper: the wall occupies y > x_w; lower: y < x_w"));
    wall.parameters.push_back(samples("delay", static_cast<double>(d::hulin_delay_samples),
                                      "output delay d in periods (Hulin d)",
                                      static_cast<double>(max_wall_delay_samples)));
    out.push_back(std::move(wall));
  }
  {
    SceneDescription relay{"relay",
                           "Diaz & Gil, section V (relay experiment)",
                           "F = -h sign(y - reference), optional hysteresis band",
                           {}};
    relay.parameters.push_back(
        number("amplitude", "N", "N m", d::relay_amplitude, "relay amplitude h", 0.0, r::max_force));
    relay.parameters.push_back(
        number("hysteresis", "m", "rad", 0.0, "hysteresis half-width eps", 0.0, r::max_position));
    relay.parameters.push_back(
        number("reference", "m", "rad", 0.0, "reference position", -r::max_position, r::max_position));
    relay.parameters.push_back(samples("delay", 0.0, "extra loop delay t_d in periods (Diaz & Gil eq. 25)",
                                       static_cast<double>(max_relay_delay_samples)));
    relay.parameters.push_back(number("duration", "s", "s", 0.0,
                                      "stop by itself (output 0) after this long; 0: run until replaced", 0.0,
                                      r::max_duration_s));
    out.push_back(std::move(relay));
  }
  {
    SceneDescription chirp{"chirp",
                           "Diaz & Gil II, Fig. 4 (swept sine for identification)",
                           "F = A sin(phi(t)): exponential sweep f0 -> f1 every `sweep` seconds, repeated",
                           {}};
    const ChirpParameters c;
    chirp.parameters.push_back(
        number("amplitude", "N", "N m", c.amplitude, "force amplitude A (|F| <= A)", 0.0, r::max_force));
    chirp.parameters.back().minimum_exclusive = true;
    chirp.parameters.push_back(number("start_frequency", "Hz", "Hz", c.start_frequency,
                                      "sweep start frequency f0", 0.0, r::max_frequency_hz));
    chirp.parameters.back().minimum_exclusive = true;
    chirp.parameters.push_back(number("end_frequency", "Hz", "Hz", c.end_frequency,
                                      "sweep end frequency f1 (> f0, at most 1/(2T))", 0.0,
                                      r::max_frequency_hz));
    chirp.parameters.back().minimum_exclusive = true;
    chirp.parameters.push_back(number("sweep", "s", "s", c.sweep_s,
                                      "one sweep f0 -> f1 (the excitation's period)", 0.0,
                                      r::max_duration_s));
    chirp.parameters.back().minimum_exclusive = true;
    chirp.parameters.push_back(
        number("duration", "s", "s", c.duration_s, "then output 0 for good", 0.0, r::max_duration_s));
    chirp.parameters.back().minimum_exclusive = true;
    out.push_back(std::move(chirp));
  }
  out.push_back({"free", "Freudenberg 3 (released device)", "zero output", {}});
  return out;
}

std::string format_value(const ParameterValue& value) {
  std::ostringstream s;
  if (const double* x = std::get_if<double>(&value)) {
    s << *x;
  } else if (const bool* b = std::get_if<bool>(&value)) {
    s << (*b ? "true" : "false");
  } else {
    s << '\'' << std::get<std::string>(value) << '\'';
  }
  return s.str();
}

std::string format_number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& item : items) {
    if (!out.empty()) out += ", ";
    out += item;
  }
  return out;
}

std::string accepted_text(const ParameterDescription& p, Motion motion) {
  const std::string& unit = motion == Motion::rotary ? p.rotary_unit : p.unit;
  switch (p.type) {
    case ParameterType::number: {
      std::string text = "a finite number";
      if (p.minimum) text += (p.minimum_exclusive ? " > " : " >= ") + format_number(*p.minimum);
      if (p.maximum) text += (p.minimum ? " and <= " : " <= ") + format_number(*p.maximum);
      if (!unit.empty()) text += " (" + unit + ")";
      for (const auto& word : p.accepted) text += " or " + word;
      return text;
    }
    case ParameterType::integer: {
      std::string text = "an integer";
      if (p.minimum && p.maximum) {
        text += " " + format_number(*p.minimum) + ".." + format_number(*p.maximum);
      } else if (p.minimum) {
        text += " >= " + format_number(*p.minimum);
      }
      if (!unit.empty()) text += " (" + unit + ")";
      return text;
    }
    case ParameterType::enumeration:
      return "one of " + join(p.accepted);
    case ParameterType::boolean:
      return "true or false";
  }
  return {};
}

/// Returns the canonical value, or nothing when not accepted.
std::optional<ParameterValue> validate(const ParameterDescription& p, const ParameterValue& value) {
  switch (p.type) {
    case ParameterType::number:
    case ParameterType::integer: {
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
    case ParameterType::enumeration: {
      const std::string* s = std::get_if<std::string>(&value);
      if (s == nullptr) return std::nullopt;
      if (p.name == "integrator") {
        if (const auto i = parse_integrator(*s)) return ParameterValue{std::string(to_string(*i))};
        return std::nullopt;
      }
      for (const auto& a : p.accepted) {
        if (*s == a) return value;
      }
      return std::nullopt;
    }
    case ParameterType::boolean: {
      if (std::holds_alternative<bool>(value)) return value;
      if (const std::string* s = std::get_if<std::string>(&value)) {
        if (*s == "true") return ParameterValue{true};
        if (*s == "false") return ParameterValue{false};
      }
      return std::nullopt;
    }
  }
  return std::nullopt;
}

double num(const ParameterSet& set, std::string_view name) {
  return std::get<double>(set.find(name)->second);
}
const std::string& text(const ParameterSet& set, std::string_view name) {
  return std::get<std::string>(set.find(name)->second);
}

std::vector<ChannelDescription> describe(std::span<const std::string_view> names, Motion motion) {
  const std::string pos = motion == Motion::rotary ? "rad" : "m";
  const std::string vel = motion == Motion::rotary ? "rad/s" : "m/s";
  std::vector<ChannelDescription> out;
  for (const std::string_view n : names) {
    std::string unit;
    if (n.ends_with("velocity")) {
      unit = vel;
    } else if (n == "armed") {
      unit = "1";
    } else {
      unit = pos;
    }
    out.push_back({std::string(n), unit});
  }
  return out;
}

template <class S>
void finish(ScenePlan& plan, S scene, Motion motion) {
  if constexpr (requires { scene.linear_model(); }) plan.linear = scene.linear_model();
  plan.channels = describe(S::channel_names, motion);
  plan.scene_object = std::move(scene);
}

void build_spring(ScenePlan& plan, double period_s, Motion motion) {
  ParameterSet& p = plan.parameters;
  SpringParameters sp;
  sp.stiffness = num(p, "stiffness");
  sp.inertia = motion == Motion::rotary ? num(p, "inertia") : num(p, "mass");
  if (const auto* s = std::get_if<std::string>(&p["damping"])) {
    (void)s;  // only "auto" passes validation
    sp.damping = period_s * sp.stiffness;
    p["damping"] = sp.damping;
    plan.notes.push_back("damping auto = T k = " + format_number(sp.damping) +
                         (motion == Motion::rotary ? " N m s/rad" : " N s/m") + " (Freudenberg 2.24)");
  } else {
    sp.damping = num(p, "damping");
  }
  sp.integrator = *parse_integrator(text(p, "integrator"));
  if (sp.damping == 0.0) {
    finish(plan, SpringScene<SpringDamping::none>(sp, period_s), motion);
  } else if (text(p, "damping_reference") == "absolute") {
    finish(plan, SpringScene<SpringDamping::absolute>(sp, period_s), motion);
  } else {
    finish(plan, SpringScene<SpringDamping::relative>(sp, period_s), motion);
  }
}

void build_wall(ScenePlan& plan, double period_s, Motion motion) {
  const ParameterSet& p = plan.parameters;
  WallParameters wp;
  wp.stiffness = num(p, "stiffness");
  wp.damping = num(p, "damping");
  wp.position = num(p, "position");
  wp.side = text(p, "side") == "upper" ? WallSide::upper : WallSide::lower;
  wp.delay_samples = static_cast<int>(num(p, "delay"));
  const bool damped = wp.damping != 0.0;
  const bool delayed = wp.delay_samples != 0;
  if (damped && delayed) {
    finish(plan, WallScene<WallDamping::backward_difference, WallDelay::samples>(wp, period_s), motion);
  } else if (damped) {
    finish(plan, WallScene<WallDamping::backward_difference, WallDelay::none>(wp, period_s), motion);
  } else if (delayed) {
    finish(plan, WallScene<WallDamping::none, WallDelay::samples>(wp, period_s), motion);
  } else {
    finish(plan, WallScene<WallDamping::none, WallDelay::none>(wp, period_s), motion);
  }
}

void build_relay(ScenePlan& plan, double period_s, Motion motion) {
  const ParameterSet& p = plan.parameters;
  RelayParameters rp{num(p, "amplitude"), num(p, "hysteresis"), num(p, "reference")};
  rp.delay_samples = static_cast<int>(num(p, "delay"));
  rp.duration_steps = static_cast<std::int64_t>(std::llround(num(p, "duration") / period_s));
  if (num(p, "duration") > 0.0 && rp.duration_steps < 1) rp.duration_steps = 1;
  const bool band = rp.hysteresis != 0.0;
  using H = RelayHysteresis;
  using D = RelayDelay;
  if (rp.delay_samples == 0) {
    band ? finish(plan, RelayScene<H::band>(rp), motion) : finish(plan, RelayScene<H::none>(rp), motion);
  } else if (band) {
    finish(plan, RelayScene<H::band, D::samples>(rp), motion);
  } else {
    finish(plan, RelayScene<H::none, D::samples>(rp), motion);
  }
}

void build_chirp(ScenePlan& plan, double period_s, Motion motion) {
  const ParameterSet& p = plan.parameters;
  const ChirpParameters cp{num(p, "amplitude"), num(p, "start_frequency"), num(p, "end_frequency"),
                           num(p, "sweep"), num(p, "duration")};
  finish(plan, ChirpScene(cp, period_s), motion);
}

}  // namespace

std::string_view to_string(ParameterType type) noexcept {
  switch (type) {
    case ParameterType::number:
      return "number";
    case ParameterType::integer:
      return "integer";
    case ParameterType::enumeration:
      return "enum";
    case ParameterType::boolean:
      return "bool";
  }
  return "?";
}

const std::vector<SceneDescription>& scene_catalog() {
  static const std::vector<SceneDescription> catalog = build_catalog();
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

PlanResult plan_scene(std::string_view name, const ParameterSet& given, double period_s, Motion motion) {
  const SceneDescription* description = find_scene(name);
  if (description == nullptr) {
    return SceneError{"unknown scene '" + std::string(name) + "'; accepted: " + scene_names()};
  }
  if (!(std::isfinite(period_s) && period_s > 0.0)) {
    return SceneError{"period: " + format_number(period_s) + " is not accepted; a finite number > 0 (s)"};
  }
  // The spring scenes have fixed motion: the wheel is rotary, the mass linear.
  if (description->name == "spring-wheel") motion = Motion::rotary;
  if (description->name == "spring-mass") motion = Motion::linear;

  for (const auto& [key, value] : given) {
    bool known = false;
    for (const auto& p : description->parameters) known = known || p.name == key;
    if (!known) {
      std::vector<std::string> names;
      for (const auto& p : description->parameters) names.push_back(p.name);
      return SceneError{"unknown parameter '" + key + "' for scene " + description->name +
                            "; accepted: " + (names.empty() ? std::string("none") : join(names)),
                        key};
    }
  }

  ScenePlan plan;
  plan.scene = description->name;
  for (const auto& p : description->parameters) {
    const auto it = given.find(p.name);
    if (it == given.end()) {
      plan.parameters[p.name] = p.default_value;
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
    if (plan.scene == "spring-wheel" || plan.scene == "spring-mass") {
      build_spring(plan, period_s, motion);
    } else if (plan.scene == "wall") {
      build_wall(plan, period_s, motion);
    } else if (plan.scene == "relay") {
      build_relay(plan, period_s, motion);
    } else if (plan.scene == "chirp") {
      build_chirp(plan, period_s, motion);
    } else {
      finish(plan, FreeScene{}, motion);
    }
  } catch (const std::exception& e) {
    return SceneError{plan.scene + ": " + e.what()};
  }
  return plan;
}

}  // namespace hapticd::world
