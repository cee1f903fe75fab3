#include "world/wall_scene.hpp"

#include <cmath>
#include <stdexcept>

#include "world/scene_catalog.hpp"

namespace hapticd::world {

namespace {

void check(const WallParameters& p, double period_s, WallDamping damping, WallDelay delay) {
  if (!(std::isfinite(period_s) && period_s > 0.0)) throw std::invalid_argument("period must be > 0");
  if (!(std::isfinite(p.stiffness) && p.stiffness >= 0.0))
    throw std::invalid_argument("stiffness must be >= 0");
  if (!(std::isfinite(p.damping) && p.damping >= 0.0)) throw std::invalid_argument("damping must be >= 0");
  if (!std::isfinite(p.position)) throw std::invalid_argument("position must be finite");
  if (damping == WallDamping::none && p.damping != 0.0) {
    throw std::invalid_argument("WallScene<none, ...> needs damping == 0");
  }
  if (delay == WallDelay::none && p.delay_samples != 0) {
    throw std::invalid_argument("WallScene<..., none> needs delay == 0");
  }
  if (delay == WallDelay::samples &&
      (p.delay_samples < 1 || p.delay_samples > static_cast<int>(max_wall_delay_samples))) {
    throw std::invalid_argument("WallScene<..., samples> needs delay in 1..16");
  }
}

}  // namespace

template <WallDamping Damping, WallDelay Delay>
WallScene<Damping, Delay>::WallScene(const WallParameters& parameters, double period_s)
    : stiffness_((check(parameters, period_s, Damping, Delay), parameters.stiffness)),
      position_(parameters.position),
      side_sign_(parameters.side == WallSide::upper ? 1.0 : -1.0),
      estimator_([&] {
        if constexpr (damped) {
          return BackwardDifference(period_s);
        } else {
          return detail::Absent<1>{};
        }
      }()),
      line_([&] {
        if constexpr (delayed) {
          return Line(static_cast<std::size_t>(parameters.delay_samples));
        } else {
          return detail::Absent<2>{};
        }
      }()) {
  if constexpr (damped) damping_ = parameters.damping;
  reset(parameters.position - side_sign_);  // outside, armed, zero state
}

template <WallDamping Damping, WallDelay Delay>
DiscreteLinearScene WallScene<Damping, Delay>::linear_model() const {
  DiscreteLinearScene m;
  m.d = Eigen::MatrixXd::Zero(1, 1);
  if constexpr (damped) {
    const double b_over_t = damping_ * estimator_.inverse_period();
    m.a = Eigen::MatrixXd::Zero(1, 1);
    m.b = Eigen::MatrixXd::Ones(1, 1);
    m.c = Eigen::MatrixXd::Constant(1, 1, b_over_t);
    m.d(0, 0) = -stiffness_ - b_over_t;
  } else {
    m.a = Eigen::MatrixXd::Zero(0, 0);
    m.b = Eigen::MatrixXd::Zero(0, 1);
    m.c = Eigen::MatrixXd::Zero(1, 0);
    m.d(0, 0) = -stiffness_;
  }
  m.output_delay_samples = static_cast<int>(delay_samples());
  return m;
}

template class WallScene<WallDamping::none, WallDelay::none>;
template class WallScene<WallDamping::none, WallDelay::samples>;
template class WallScene<WallDamping::backward_difference, WallDelay::none>;
template class WallScene<WallDamping::backward_difference, WallDelay::samples>;

// The registry entry (world/scene_registry.hpp): Hulin's wall, its units
// following the device's motion.

namespace {

using P = ParameterSpec;

std::vector<ParameterSpec> wall_parameters() {
  namespace d = scene_defaults;
  namespace r = parameter_range;
  std::vector<ParameterSpec> out{
      P::number("stiffness", "N/m", "wall stiffness K")
          .on_rotary("N m/rad")
          .defaults_to(d::wall_stiffness)
          .at_least(0.0)
          .at_most(r::max_stiffness),
      P::number("damping", "N s/m", "wall damping B on the backward-difference velocity")
          .on_rotary("N m s/rad")
          .defaults_to(d::wall_damping)
          .at_least(0.0)
          .at_most(r::max_damping),
      P::number("position", "m", "wall surface x_w")
          .on_rotary("rad")
          .defaults_to(0.0)
          .at_least(-r::max_position)
          .at_most(r::max_position),
      P::choice("side", {"upper", "lower"}, "upper: the wall occupies y > x_w; lower: y < x_w")
          .defaults_to("upper"),
      P::integer("delay", "samples", "output delay d in periods (Hulin d)")
          .defaults_to(static_cast<double>(d::hulin_delay_samples))
          .at_least(0.0)
          .at_most(static_cast<double>(max_wall_delay_samples)),
  };
  for (auto& option : passivity_parameters(std::nullopt)) out.push_back(std::move(option));
  return out;
}

/// The variant without a damper when B = 0, without a delay line when d = 0.
void build_wall(ScenePlan& plan, const SceneContext& context) {
  const ParameterSet& p = plan.parameters;
  WallParameters wp;
  wp.stiffness = number_of(p, "stiffness");
  wp.damping = number_of(p, "damping");
  wp.position = number_of(p, "position");
  wp.side = text_of(p, "side") == "upper" ? WallSide::upper : WallSide::lower;
  wp.delay_samples = static_cast<int>(number_of(p, "delay"));
  const bool damped = wp.damping != 0.0;
  const bool delayed = wp.delay_samples != 0;
  using Dm = WallDamping;
  using Dl = WallDelay;
  const double t = context.period_s;
  const PassivityOptions passivity = passivity_options(p, t);
  const Motion motion = context.motion;
  if (damped && delayed) {
    set_scene(plan, WallScene<Dm::backward_difference, Dl::samples>(wp, t), motion, passivity);
  } else if (damped) {
    set_scene(plan, WallScene<Dm::backward_difference, Dl::none>(wp, t), motion, passivity);
  } else if (delayed) {
    set_scene(plan, WallScene<Dm::none, Dl::samples>(wp, t), motion, passivity);
  } else {
    set_scene(plan, WallScene<Dm::none, Dl::none>(wp, t), motion, passivity);
  }
}

}  // namespace

SceneDescription WallEntry::describe() {
  return {.name = "wall",
          .reference = "Hulin et al. 2006, eq. (1), section 7",
          .summary = "unilateral PD wall: F = -K (y - x_w) - B v while penetrating, delayed d samples",
          .parameters = wall_parameters(),
          .fixed_motion = std::nullopt,
          .stability = StabilityRule::hulin_wall,
          .unstable_hint = {},
          .build = build_wall};
}

}  // namespace hapticd::world
