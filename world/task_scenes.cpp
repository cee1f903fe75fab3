// The registry entries of the task-space walls (world/task_scenes.hpp):
// plane-wall, sphere, box. Their units are linear (a Cartesian stage: m, N).

#include "world/task_scenes.hpp"

#include <cmath>
#include <stdexcept>

#include "world/scene_catalog.hpp"
#include "world/text.hpp"
#include "world/units.hpp"

namespace hapticd::world {

AxisVector parse_axis_vector(std::string_view name, std::string_view text, int axes, const AxisVector& empty,
                             std::optional<double> bound) {
  const auto fail = [&] {
    const auto show = [](double x) { return text::format_significant(x, text::precision::message); };
    throw std::invalid_argument(std::string(name) + ": '" + std::string(text) + "' is not accepted; " +
                                std::to_string(axes) + " comma-separated " +
                                (bound ? "numbers from " + show(-*bound) + " to " + show(*bound) + " (m)"
                                       : std::string("finite numbers")) +
                                ", one per axis");
  };
  if (text.find_first_not_of(' ') == std::string_view::npos) return empty;
  AxisVector out(axes);
  int count = 0;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t end = std::min(text.find(',', begin), text.size());
    std::string_view item = text.substr(begin, end - begin);
    while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
    while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
    const auto value = units::parse_finite(item);
    if (!value || count == axes || (bound && !(std::abs(*value) <= *bound))) fail();
    out(count++) = *value;
    begin = end + 1;
  }
  if (count != axes) fail();
  return out;
}

namespace {

using P = ParameterSpec;
namespace d = scene_defaults;
namespace r = parameter_range;

/// The box's default half-width on every axis, m: a desk stage's reach.
constexpr double default_box_half_width = 0.05;

/// A vector parameter: comma-separated text, "" for its default.
ParameterSpec vector_parameter(std::string name, std::string unit, std::string help) {
  ParameterSpec spec = P::text(std::move(name), std::move(help)).defaults_to("");
  spec.unit = std::move(unit);
  return spec;
}

/// K, B and d: the one-axis wall's, along the shape's coordinate.
std::vector<ParameterSpec> law_parameters() {
  return {
      P::number("stiffness", "N/m", "wall stiffness K along the wall's normal")
          .defaults_to(d::wall_stiffness)
          .at_least(0.0)
          .at_most(r::max_stiffness),
      P::number("damping", "N s/m", "wall damping B on the backward-difference velocity along the normal")
          .defaults_to(d::wall_damping)
          .at_least(0.0)
          .at_most(r::max_damping),
      P::integer("delay", "samples", "output delay d in periods (Hulin d), of the whole force vector")
          .defaults_to(static_cast<double>(d::hulin_delay_samples))
          .at_least(0.0)
          .at_most(static_cast<double>(max_wall_delay_samples)),
  };
}

TaskWallLaw law_of(const ParameterSet& p) {
  return {number_of(p, "stiffness"), number_of(p, "damping"), static_cast<int>(number_of(p, "delay"))};
}

std::string vector_text(const AxisVector& v) {
  std::string out = "(";
  for (Eigen::Index i = 0; i < v.size(); ++i)
    out += (i > 0 ? ", " : "") + text::format_significant(v(i), text::precision::summary);
  return out + ")";
}

using TaskDm = WallDamping;
using TaskDl = WallDelay;

/// Builds the variant of `Shape` that uses no more than the law needs:
/// `make.template operator()<damping, delay>()` returns Shape<damping, delay>.
template <template <WallDamping, WallDelay> class Shape, class Make>
void set_task_wall(ScenePlan& plan, const TaskWallLaw& law, const Make& make) {
  const auto use = [&]<TaskDm damping, TaskDl delay>() {
    set_task_scene(plan, TaskWallScene<Shape<damping, delay>>(make.template operator()<damping, delay>()));
  };
  const bool damped = law.damping != 0.0;
  const bool delayed = law.delay_samples != 0;
  if (damped && delayed) {
    use.template operator()<TaskDm::backward_difference, TaskDl::samples>();
  } else if (damped) {
    use.template operator()<TaskDm::backward_difference, TaskDl::none>();
  } else if (delayed) {
    use.template operator()<TaskDm::none, TaskDl::samples>();
  } else {
    use.template operator()<TaskDm::none, TaskDl::none>();
  }
}

void build_plane_wall(ScenePlan& plan, const SceneContext& context) {
  const ParameterSet& p = plan.parameters;
  const AxisVector first_axis = AxisVector::Unit(context.axes, 0);
  const AxisVector given = parse_axis_vector("normal", text_of(p, "normal"), context.axes, first_axis);
  // Scaled by its largest entry first: "1e300,1e300" is a direction too.
  const double largest = given.cwiseAbs().maxCoeff();
  if (!(largest > 0.0)) throw std::invalid_argument("normal: a direction, not all zero");
  const AxisVector normal = (given / largest).normalized();
  const TaskWallLaw law = law_of(p);
  const double offset = number_of(p, "offset");
  const double t = context.period_s;
  set_task_wall<PlaneWall>(plan, law, [&]<TaskDm damping, TaskDl delay>() {
    return PlaneWall<damping, delay>(normal, offset, law, t);
  });
  plan.task_wall = TaskWallJudgement{law, {normal}, {"the normal " + vector_text(normal)}, false};
}

void build_sphere(ScenePlan& plan, const SceneContext& context) {
  const ParameterSet& p = plan.parameters;
  const AxisVector center = parse_axis_vector("center", text_of(p, "center"), context.axes,
                                              AxisVector::Zero(context.axes), r::max_position);
  const double radius = number_of(p, "radius");
  const bool inside = text_of(p, "side") == "inside";
  const TaskWallLaw law = law_of(p);
  const double t = context.period_s;
  set_task_wall<SphereWall>(plan, law, [&]<TaskDm damping, TaskDl delay>() {
    return SphereWall<damping, delay>(center, radius, inside, law, t);
  });
  plan.task_wall = TaskWallJudgement{law, {}, {}, false};
}

void build_box(ScenePlan& plan, const SceneContext& context) {
  const ParameterSet& p = plan.parameters;
  const AxisVector half = AxisVector::Constant(context.axes, default_box_half_width);
  const AxisVector low = parse_axis_vector("low", text_of(p, "low"), context.axes, -half, r::max_position);
  const AxisVector high = parse_axis_vector("high", text_of(p, "high"), context.axes, half, r::max_position);
  for (Eigen::Index i = 0; i < low.size(); ++i) {
    if (!(low(i) < high(i)))
      throw std::invalid_argument("low, high: low < high on every axis; axis " + std::to_string(i + 1) +
                                  " has low " + text::format_significant(low(i), text::precision::summary) +
                                  " m, high " + text::format_significant(high(i), text::precision::summary) +
                                  " m");
  }
  const TaskWallLaw law = law_of(p);
  const double t = context.period_s;
  set_task_wall<BoxWall>(
      plan, law, [&]<TaskDm damping, TaskDl delay>() { return BoxWall<damping, delay>(low, high, law, t); });
  TaskWallJudgement judged{law, {}, {}, true};
  for (int i = 0; i < context.axes; ++i) {
    judged.directions.push_back(AxisVector::Unit(context.axes, i));
    judged.labels.push_back("axis " + std::to_string(i + 1));
  }
  plan.task_wall = std::move(judged);
}

}  // namespace

SceneDescription PlaneWallEntry::describe() {
  std::vector<ParameterSpec> parameters{
      vector_parameter("normal", "",
                       "the wall's normal, pointing to free space, comma-separated (\"1,1\": normalized); "
                       "empty: the first axis"),
      P::number("offset", "m", "the wall's surface: the free side is n . x > offset (n normalized)")
          .defaults_to(0.0)
          .at_least(-r::max_position)
          .at_most(r::max_position),
  };
  for (auto& law : law_parameters()) parameters.push_back(std::move(law));
  return {.name = "plane-wall",
          .reference = "Hulin et al. 2006 along the normal; analysis/task_space.hpp (m_n)",
          .summary = "a plane wall in task space: Hulin's wall on the coordinate n . x, pushing along n",
          .parameters = std::move(parameters),
          .fixed_motion = Motion::linear,
          .stability = StabilityRule::task_wall,
          .unstable_hint = {},
          .build = build_plane_wall,
          .space = SceneSpace::task};
}

}  // namespace hapticd::world

namespace hapticd::world {

SceneDescription SphereEntry::describe() {
  std::vector<ParameterSpec> parameters{
      vector_parameter("center", "m", "the ball's center, comma-separated; empty: the origin"),
      P::number("radius", "m", "the ball's radius R").defaults_to(0.05).above(0.0).at_most(r::max_position),
      P::choice("side", {"outside", "inside"},
                "outside: the device is kept out of the ball; inside: held inside it")
          .defaults_to("outside"),
  };
  for (auto& law : law_parameters()) parameters.push_back(std::move(law));
  return {.name = "sphere",
          .reference = "Hulin et al. 2006 along the radius, judged in the worst direction (the lightest m_n)",
          .summary = "a ball in task space: Hulin's wall on the distance |x - c|, pushing along the radius",
          .parameters = std::move(parameters),
          .fixed_motion = Motion::linear,
          .stability = StabilityRule::task_wall,
          .unstable_hint = {},
          .build = build_sphere,
          .space = SceneSpace::task};
}

SceneDescription BoxEntry::describe() {
  std::vector<ParameterSpec> parameters{
      vector_parameter("low", "m", "the box's lower corner, comma-separated; empty: -0.05 m on every axis"),
      vector_parameter("high", "m", "the box's upper corner, comma-separated; empty: 0.05 m on every axis"),
  };
  for (auto& law : law_parameters()) parameters.push_back(std::move(law));
  return {.name = "box",
          .reference = "Hulin et al. 2006 on each face, judged along its axis",
          .summary = "the device held inside an axis-aligned box: one Hulin wall per face",
          .parameters = std::move(parameters),
          .fixed_motion = Motion::linear,
          .stability = StabilityRule::task_wall,
          .unstable_hint = {},
          .build = build_box,
          .space = SceneSpace::task};
}

}  // namespace hapticd::world
