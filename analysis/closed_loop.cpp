#include "analysis/closed_loop.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "world/integrator.hpp"

namespace hapticd::analysis {

Eigen::MatrixXd closed_loop_matrix(const world::LinearPlant& plant, world::Sensor sensor,
                                   const world::DiscreteLinearScene& scene, double period_s,
                                   int extra_delay_samples) {
  const Eigen::Index n = plant.dynamics.a.rows();
  const Eigen::Index q = scene.a.rows();
  if (!(period_s > 0.0) || !std::isfinite(period_s)) throw std::invalid_argument("period must be > 0");
  // The augmented matrix grows with the delay (dense eigenvalues: O(D^3)).
  constexpr int max_delay = 1024;
  if (scene.output_delay_samples < 0 || extra_delay_samples < 0 || scene.output_delay_samples > max_delay ||
      extra_delay_samples > max_delay - scene.output_delay_samples) {
    throw std::invalid_argument("delays must be >= 0 and at most 1024 samples in total");
  }
  if (scene.a.cols() != q || scene.b.rows() != q || scene.b.cols() != 1 || scene.c.rows() != 1 ||
      scene.c.cols() != q || scene.d.rows() != 1 || scene.d.cols() != 1) {
    throw std::invalid_argument("scene matrices must be q x q, q x 1, 1 x q, 1 x 1");
  }
  const Eigen::Index delay = scene.output_delay_samples + extra_delay_samples;

  world::ContinuousStateSpace motor{plant.dynamics.a, plant.dynamics.b.col(world::motor_force_input)};
  const world::DiscreteStateSpace zoh = world::discretize_zoh(motor, period_s);
  const Eigen::RowVectorXd c = plant.position(sensor);

  // F[n] = fx x + fs s (a row over the plant and scene states).
  const Eigen::RowVectorXd fx = scene.d(0, 0) * c;
  const Eigen::RowVectorXd& fs = scene.c;

  const Eigen::Index dim = n + q + delay;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(dim, dim);
  a.topLeftCorner(n, n) = zoh.ad;
  if (delay == 0) {
    a.block(0, 0, n, n) += zoh.bd * fx;
    a.block(0, n, n, q) += zoh.bd * fs;
  } else {
    a.block(0, n + q + delay - 1, n, 1) = zoh.bd;  // u[n] = F[n - D]
    a.block(n + q, 0, 1, n) = fx;                  // new F[n-1] slot <- F[n]
    a.block(n + q, n, 1, q) = fs;
    for (Eigen::Index i = 1; i < delay; ++i) a(n + q + i, n + q + i - 1) = 1.0;
  }
  a.block(n, 0, q, n) = scene.b * c;
  a.block(n, n, q, q) = scene.a;
  return a;
}

ClosedLoopVerdict analyze_closed_loop(const world::LinearPlant& plant, world::Sensor sensor,
                                      const world::DiscreteLinearScene& scene, double period_s,
                                      int extra_delay_samples, double tolerance) {
  ClosedLoopVerdict v;
  NumericRecord record;
  record.check_finite("the plant's A", plant.dynamics.a);
  record.check_finite("the plant's B", plant.dynamics.b);
  record.check_finite("the scene's a", scene.a);
  record.check_finite("the scene's b", scene.b);
  record.check_finite("the scene's c", scene.c);
  record.check_finite("the scene's d", scene.d);
  if (record.clean()) {
    const world::ContinuousStateSpace motor{plant.dynamics.a, plant.dynamics.b.col(world::motor_force_input)};
    check_zoh("the plant", motor, world::discretize_zoh(motor, period_s), record);
  }
  if (!record.clean()) {  // an inf in the matrix exponential's scaling is undefined: stop here
    v.pole_radius = v.growth_per_second = std::numeric_limits<double>::quiet_NaN();
    v.verdict = judge_radius(v.pole_radius, tolerance, period_s, record);
    return v;
  }
  v.a = closed_loop_matrix(plant, sensor, scene, period_s, extra_delay_samples);
  const Spectrum s = spectrum("the closed-loop matrix", v.a, record);
  v.eigenvalues = s.eigenvalues;
  v.pole_radius = s.radius;
  v.verdict = judge_radius(v.pole_radius, tolerance, period_s, record);
  v.growth_per_second = v.verdict.assessed() ? std::pow(v.pole_radius, 1.0 / period_s)
                                             : std::numeric_limits<double>::quiet_NaN();
  return v;
}

}  // namespace hapticd::analysis
