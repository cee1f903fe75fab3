#include "world/spring_scene.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

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
    : stiffness_(parameters.stiffness), estimator_([&] {
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

}  // namespace hapticd::world
