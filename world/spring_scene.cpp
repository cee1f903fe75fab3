#include "world/spring_scene.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "world/scene_catalog.hpp"
#include "world/task_scenes.hpp"
#include "world/text.hpp"

namespace hapticd::world {

namespace {

void check(const SpringParameters& p, double period_s, SpringDamping kind) {
  if (!(std::isfinite(period_s) && period_s > 0.0)) throw std::invalid_argument("period must be > 0");
  if (!(std::isfinite(p.stiffness) && p.stiffness >= 0.0))
    throw std::invalid_argument("stiffness must be >= 0");
  if (!(std::isfinite(p.inertia) && p.inertia > 0.0)) throw std::invalid_argument("inertia must be > 0");
  if (!(std::isfinite(p.damping) && p.damping >= 0.0)) throw std::invalid_argument("damping must be >= 0");
  if (kind == SpringDamping::none && p.damping != 0.0) {
    throw std::invalid_argument("SpringScene<none> needs damping == 0");
  }
}

}  // namespace

ContinuousStateSpace spring_continuous_model(const SpringParameters& p, SpringDamping kind) {
  const double k_over_j = p.stiffness / p.inertia;
  const double b_over_j = kind == SpringDamping::none ? 0.0 : p.damping / p.inertia;
  ContinuousStateSpace sys;
  sys.a = Eigen::MatrixXd::Zero(2, 2);
  sys.a(0, 1) = 1.0;
  sys.a(1, 0) = -k_over_j;
  sys.a(1, 1) = -b_over_j;
  sys.b = Eigen::MatrixXd::Zero(2, kind == SpringDamping::relative ? 2 : 1);
  sys.b(1, 0) = k_over_j;
  if (kind == SpringDamping::relative) sys.b(1, 1) = b_over_j;
  return sys;
}

template <SpringDamping D>
SpringScene<D>::SpringScene(const SpringParameters& parameters, double period_s)
    : stiffness_(parameters.stiffness), inertia_(parameters.inertia), estimator_([&] {
        check(parameters, period_s, D);
        if constexpr (relative) {
          return BackwardDifference(period_s);
        } else {
          return detail::Absent<1>{};
        }
      }()) {
  const DiscreteStateSpace d =
      discretize(spring_continuous_model(parameters, D), period_s, parameters.integrator);
  for (Eigen::Index r = 0; r < 2; ++r) {
    for (Eigen::Index c = 0; c < 2; ++c) ad_[static_cast<std::size_t>(r * 2 + c)] = d.ad(r, c);
    if constexpr (relative) bd_velocity_[static_cast<std::size_t>(r)] = d.bd(r, 1);
  }
  // step() relies on [y, 0] being an equilibrium of the discretized model.
  const Eigen::Vector2d e1 = Eigen::Vector2d::UnitX();
  const double residual = (d.ad * e1 + d.bd.col(0) - e1).cwiseAbs().maxCoeff();
  if (!(residual <= 1e-9 * (1.0 + d.ad.cwiseAbs().maxCoeff()))) {
    throw std::logic_error("discretized spring does not keep [y, 0] at rest");
  }
  if constexpr (relative) damping_ = parameters.damping;
}

template <SpringDamping D>
DiscreteLinearScene SpringScene<D>::linear_model() const {
  DiscreteLinearScene m;
  const Eigen::Index q = relative ? 3 : 2;
  m.a = Eigen::MatrixXd::Zero(q, q);
  m.b = Eigen::MatrixXd::Zero(q, 1);
  m.c = Eigen::MatrixXd::Zero(1, q);
  m.d = Eigen::MatrixXd::Zero(1, 1);
  m.a(0, 0) = ad_[0];
  m.a(0, 1) = ad_[1];
  m.a(1, 0) = ad_[2];
  m.a(1, 1) = ad_[3];
  m.c(0, 0) = stiffness_;
  m.d(0, 0) = -stiffness_;
  if constexpr (relative) {
    // y_dot[n] = (y[n] - s2[n]) / T with s2 = y[n-1].
    const double inv_t = estimator_.inverse_period();
    const auto bd_full = bd();
    for (Eigen::Index r = 0; r < 2; ++r) {
      const double b_y = bd_full[static_cast<std::size_t>(r) * 2];
      const double b_v = bd_full[static_cast<std::size_t>(r) * 2 + 1];
      m.b(r, 0) = b_y + b_v * inv_t;
      m.a(r, 2) = -b_v * inv_t;
    }
    m.b(2, 0) = 1.0;
    m.c(0, 1) = damping_;
    m.c(0, 2) = damping_ * inv_t;
    m.d(0, 0) = -stiffness_ - damping_ * inv_t;
  } else {
    m.b(0, 0) = 1.0 - ad_[0];
    m.b(1, 0) = -ad_[2];
  }
  m.output_delay_samples = 0;
  return m;
}

template <SpringDamping D>
std::array<double, 2 * SpringScene<D>::input_count> SpringScene<D>::bd() const noexcept {
  std::array<double, 2 * input_count> out{};
  out[0] = 1.0 - ad_[0];
  out[input_count] = -ad_[2];
  if constexpr (relative) {
    out[1] = bd_velocity_[0];
    out[3] = bd_velocity_[1];
  }
  return out;
}

template class SpringScene<SpringDamping::none>;
template class SpringScene<SpringDamping::absolute>;
template class SpringScene<SpringDamping::relative>;

// The registry entries (world/scene_registry.hpp): spring-wheel is the
// rotary wheel of Freudenberg 2.1, spring-mass the same law in linear units.

namespace {

using P = ParameterSpec;

std::optional<std::string> canonical_integrator(std::string_view name) {
  if (const auto i = parse_integrator(name)) return std::string(to_string(*i));
  return std::nullopt;
}

std::vector<std::string> integrator_list() {
  std::vector<std::string> out;
  out.reserve(all_integrators.size());
  for (const Integrator i : all_integrators) out.emplace_back(to_string(i));
  return out;
}

std::vector<ParameterSpec> spring_parameters(bool rotary) {
  namespace d = scene_defaults;
  namespace r = parameter_range;
  const std::string k_unit = rotary ? "N m/rad" : "N/m";
  const std::string b_unit = rotary ? "N m s/rad" : "N s/m";
  std::vector<ParameterSpec> out;
  out.push_back(P::number("stiffness", k_unit, "spring k between device and virtual body")
                    .defaults_to(rotary ? d::wheel_stiffness : d::mass_stiffness)
                    .at_least(0.0)
                    .at_most(r::max_stiffness));
  out.push_back(
      rotary ? P::number("inertia", "kg m^2", "virtual wheel inertia J_w").defaults_to(d::wheel_inertia)
             : P::number("mass", "kg", "virtual mass m").defaults_to(d::mass_mass));
  out.back().at_least(r::min_mass).at_most(r::max_mass);
  out.push_back(
      P::number("damping", b_unit,
                "damper b; 'auto' = T k, which makes forward Euler a lossless oscillator (Freudenberg 2.24)")
          .defaults_to(0.0)
          .at_least(0.0)
          .at_most(r::max_damping)
          .or_word("auto"));
  out.push_back(P::choice("damping_reference", {"relative", "absolute"},
                          "relative: b on theta_w_dot - y_dot (2.19-2.22, needs a velocity estimate); "
                          "absolute: b on theta_w_dot against the fixed frame (footnote 2)")
                    .defaults_to("relative"));
  out.push_back(P::choice("integrator", integrator_list(), "discretization of the virtual body")
                    .defaults_to("exact")
                    .canonical_by(canonical_integrator));
  for (auto& option : passivity_parameters(rotary ? Motion::rotary : Motion::linear))
    out.push_back(std::move(option));
  return out;
}

/// The variant that carries only what b and its reference need.
void build_spring(ScenePlan& plan, const SceneContext& context) {
  ParameterSet& p = plan.parameters;
  const bool rotary = context.motion == Motion::rotary;
  SpringParameters sp;
  sp.stiffness = number_of(p, "stiffness");
  sp.inertia = number_of(p, rotary ? "inertia" : "mass");
  if (std::holds_alternative<std::string>(p["damping"])) {  // "auto", the only word accepted
    sp.damping = context.period_s * sp.stiffness;
    p["damping"] = sp.damping;
    plan.notes.push_back(
        "damping auto = T k = " + text::format_quantity(sp.damping, rotary ? "N m s/rad" : "N s/m") +
        " (Freudenberg 2.24)");
  } else {
    sp.damping = number_of(p, "damping");
  }
  sp.integrator = *parse_integrator(text_of(p, "integrator"));
  const PassivityOptions passivity = passivity_options(p, context.period_s);
  const double t = context.period_s;
  if (sp.damping == 0.0) {
    set_scene(plan, SpringScene<SpringDamping::none>(sp, t), context.motion, passivity);
  } else if (text_of(p, "damping_reference") == "absolute") {
    set_scene(plan, SpringScene<SpringDamping::absolute>(sp, t), context.motion, passivity);
  } else {
    set_scene(plan, SpringScene<SpringDamping::relative>(sp, t), context.motion, passivity);
  }
}

/// axis_<key>: each axis' value, comma-separated; "" gives `fallback` on
/// every axis. Each within [low, high] (unit), else refused naming the key.
AxisVector axis_values(const ParameterSet& p, const std::string& key, Eigen::Index axes, double fallback,
                       double low, double high, const std::string& what, const std::string& unit) {
  AxisVector out =
      parse_axis_vector(key, text_of(p, key), static_cast<int>(axes), AxisVector::Constant(axes, fallback));
  for (Eigen::Index i = 0; i < axes; ++i) {
    if (!(out(i) >= low && out(i) <= high))
      throw std::invalid_argument(
          key + ": each axis' " + what + " from " + text::format_significant(low, text::precision::message) +
          " to " + text::format_significant(high, text::precision::message) + " " + unit + ", one per axis");
  }
  return out;
}

constexpr std::array<const char*, 3> own_axis_keys{"axis_stiffness", "axis_mass", "axis_damping"};

bool axes_differ(const ParameterSet& p) {
  return std::any_of(own_axis_keys.begin(), own_axis_keys.end(),
                     [&](const char* key) { return !text_of(p, key).empty(); });
}

/// What the gate judges on axis i: spring-mass with that axis' k, m and b.
PerAxisJudgement per_axis_judgement(const ParameterSet& p, const std::array<SpringParameters, max_axes>& axes,
                                    Eigen::Index n) {
  PerAxisJudgement per{"spring-mass", p};
  for (const char* key : own_axis_keys) per.parameters.erase(key);  // spring-mass has one of each
  if (!axes_differ(p)) return per;
  for (Eigen::Index i = 0; i < n; ++i) {
    ParameterSet own = per.parameters;
    const auto& a = axes[static_cast<std::size_t>(i)];
    own["stiffness"] = a.stiffness;
    own["mass"] = a.inertia;
    own["damping"] = a.damping;
    per.axes.push_back(std::move(own));
  }
  return per;
}

/// Each axis' k, m and b: its own (axis_stiffness, axis_mass, axis_damping)
/// or the common one; damping auto is T k_i on each axis (Freudenberg 2.24).
std::array<SpringParameters, max_axes> axis_spring_parameters(ParameterSet& p, const SpringParameters& common,
                                                              bool auto_damping,
                                                              const SceneContext& context) {
  namespace r = parameter_range;
  const Eigen::Index n = context.axes;
  const AxisVector k =
      axis_values(p, "axis_stiffness", n, common.stiffness, 0.0, r::max_stiffness, "k", "N/m");
  const AxisVector m = axis_values(p, "axis_mass", n, common.inertia, r::min_mass, r::max_mass, "mass", "kg");
  const bool own_damping = !text_of(p, "axis_damping").empty();
  const AxisVector b = axis_values(p, "axis_damping", n, common.damping, 0.0, r::max_damping, "b", "N s/m");
  std::array<SpringParameters, max_axes> axes;
  axes.fill(common);
  for (Eigen::Index i = 0; i < n; ++i) {
    auto& a = axes[static_cast<std::size_t>(i)];
    a.stiffness = k(i);
    a.inertia = m(i);
    a.damping = own_damping ? b(i) : auto_damping ? context.period_s * k(i) : common.damping;
  }
  std::fill(axes.begin() + n, axes.end(), axes[0]);  // built, never stepped: of the same kind
  return axes;
}

void build_axis_springs(ScenePlan& plan, const SceneContext& context) {
  ParameterSet& p = plan.parameters;
  const bool auto_damping = std::holds_alternative<std::string>(p["damping"]);
  SpringParameters sp;
  sp.stiffness = number_of(p, "stiffness");
  sp.inertia = number_of(p, "mass");
  sp.damping = auto_damping ? context.period_s * sp.stiffness : number_of(p, "damping");
  sp.integrator = *parse_integrator(text_of(p, "integrator"));
  const bool own_damping = !text_of(p, "axis_damping").empty();
  if (auto_damping) {
    p["damping"] = sp.damping;
    if (!own_damping)
      plan.notes.push_back("damping auto = T k = " + text::format_quantity(sp.damping, "N s/m") +
                           " on every axis (Freudenberg 2.24)" +
                           (text_of(p, "axis_stiffness").empty() ? "" : ", T k_i with axis_stiffness"));
  }
  if (own_damping) plan.notes.push_back("damping: each axis its own (axis_damping); damping unused");
  const auto axes = axis_spring_parameters(p, sp, auto_damping, context);
  const Eigen::Index n = context.axes;
  const double t = context.period_s;
  const bool undamped =
      std::all_of(axes.begin(), axes.begin() + n, [](const auto& a) { return a.damping == 0.0; });
  if (undamped) {
    set_task_scene(plan, AxisSpringsScene<SpringDamping::none>(axes, t, n));
  } else if (text_of(p, "damping_reference") == "absolute") {
    set_task_scene(plan, AxisSpringsScene<SpringDamping::absolute>(axes, t, n));
  } else {
    set_task_scene(plan, AxisSpringsScene<SpringDamping::relative>(axes, t, n));
  }
  // Judged per axis: spring-mass with these parameters (auto resolved) on each.
  plan.per_axis = per_axis_judgement(p, axes, n);
}

constexpr const char* spring_hint =
    "try damping=auto, i.e. b = T k (Freudenberg 2.24), or another integrator";

}  // namespace

SceneDescription SpringWheelEntry::describe() {
  return {.name = "spring-wheel",
          .reference = "Freudenberg 2.1-2.4, 2.16-2.24",
          .summary = "virtual wheel J_w on a torsional spring k (and damper b) to the device",
          .parameters = spring_parameters(true),
          .fixed_motion = Motion::rotary,
          .stability = StabilityRule::linear,
          .unstable_hint = spring_hint,
          .build = build_spring};
}

SceneDescription AxisSpringsEntry::describe() {
  // spring-mass' parameters without the passivity option (one observer per axis is not built).
  std::vector<ParameterSpec> parameters;
  for (auto& spec : spring_parameters(false)) {
    if (!spec.name.starts_with("passivity")) parameters.push_back(std::move(spec));
  }
  const auto own = [](const char* key, const char* unit, const char* summary) {
    ParameterSpec spec = ParameterSpec::text(key, summary).defaults_to("");
    spec.unit = unit;
    return spec;
  };
  parameters.insert(parameters.begin() + 1,
                    own("axis_stiffness", "N/m",
                        "each axis' spring k, comma-separated (\"400,100\"), 0 to the stiffness range each; "
                        "empty: stiffness on every axis"));
  parameters.insert(parameters.begin() + 3,
                    own("axis_mass", "kg",
                        "each axis' virtual mass, comma-separated (\"0.5,2\"); empty: mass on every axis"));
  parameters.insert(parameters.begin() + 5,
                    own("axis_damping", "N s/m",
                        "each axis' damper b, comma-separated; empty: damping on every axis (auto: T k_i)"));
  return {
      .name = "axis-springs",
      .reference = "Freudenberg 2, 2.19-2.24 on each axis (issue 22)",
      .summary = "spring-mass on each axis of a Cartesian stage: axis i's virtual mass on a spring to x_i",
      .parameters = std::move(parameters),
      .fixed_motion = Motion::linear,
      .stability = StabilityRule::per_axis,
      .unstable_hint = spring_hint,
      .build = build_axis_springs,
      .space = SceneSpace::task};
}

template <SpringDamping D>
std::array<SpringScene<D>, max_axes> AxisSpringsScene<D>::make_springs(const AxisParameters& parameters,
                                                                       double period_s) {
  return [&]<std::size_t... i>(std::index_sequence<i...>) {
    return std::array<SpringScene<D>, max_axes>{SpringScene<D>(parameters[i], period_s)...};
  }
  (std::make_index_sequence<max_axes>{});
}

template <SpringDamping D>
AxisSpringsScene<D>::AxisSpringsScene(const AxisParameters& parameters, double period_s, Eigen::Index axes)
    : axes_(axes), springs_(make_springs(parameters, period_s)) {
  if (axes < 1 || axes > max_axes)
    throw std::invalid_argument("axis-springs: 1 to " + std::to_string(max_axes) + " axes");
}

template <SpringDamping D>
AxisSpringsScene<D>::AxisSpringsScene(const SpringParameters& parameters, double period_s, Eigen::Index axes)
    : AxisSpringsScene(
          [&] {
            AxisParameters every;
            every.fill(parameters);
            return every;
          }(),
          period_s, axes) {}

template class AxisSpringsScene<SpringDamping::none>;
template class AxisSpringsScene<SpringDamping::absolute>;
template class AxisSpringsScene<SpringDamping::relative>;

SceneDescription SpringMassEntry::describe() {
  return {.name = "spring-mass",
          .reference = "Freudenberg 2, 2.19-2.24 (linear units)",
          .summary = "virtual mass m on a spring k (and damper b) to the device",
          .parameters = spring_parameters(false),
          .fixed_motion = Motion::linear,
          .stability = StabilityRule::linear,
          .unstable_hint = spring_hint,
          .build = build_spring};
}

}  // namespace hapticd::world
