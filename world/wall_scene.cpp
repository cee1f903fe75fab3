#include "world/wall_scene.hpp"

#include <cmath>
#include <stdexcept>

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

}  // namespace hapticd::world
