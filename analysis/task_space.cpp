#include "analysis/task_space.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "world/text.hpp"

namespace hapticd::analysis {

namespace {

using world::AxisMatrix;
using world::AxisVector;
using world::text::format_significant;

std::string num(double x) { return format_significant(x, world::text::precision::summary); }

AxisVector unit_direction(const AxisVector& direction, Eigen::Index size) {
  if (direction.size() != size || !direction.allFinite() || direction.norm() == 0.0)
    throw std::invalid_argument("the direction must be " + std::to_string(size) +
                                " finite numbers, not all zero");
  return direction.normalized();
}

void check_joints(std::span<const JointModel> joints, std::size_t count) {
  if (joints.size() != count)
    throw std::invalid_argument(std::to_string(count) + " joints need " + std::to_string(count) +
                                " masses; got " + std::to_string(joints.size()));
  for (std::size_t i = 0; i < joints.size(); ++i) {
    if (!(std::isfinite(joints[i].mass) && joints[i].mass > 0.0))
      throw std::invalid_argument("joint " + std::to_string(i + 1) + ": the mass must be positive");
    if (!(std::isfinite(joints[i].damping) && joints[i].damping >= 0.0))
      throw std::invalid_argument("joint " + std::to_string(i + 1) + ": the damping must be >= 0");
  }
}

/// m_n = 1 / (n^T J M^-1 J^T n) at one configuration.
double mass_along(const AxisMatrix& jacobian, std::span<const JointModel> joints, const AxisVector& n) {
  const AxisVector jt_n = jacobian.transpose() * n;
  double inverse = 0.0;
  for (Eigen::Index i = 0; i < jt_n.size(); ++i)
    inverse += jt_n(i) * jt_n(i) / joints[static_cast<std::size_t>(i)].mass;
  return inverse > 0.0 ? 1.0 / inverse : std::numeric_limits<double>::infinity();
}

/// The least damping per unit mass of the joints that move along n
/// (J^T n non-zero), and whether they all have the same.
std::pair<double, bool> damping_per_mass(const AxisMatrix& jacobian, std::span<const JointModel> joints,
                                         const AxisVector& n) {
  const AxisVector jt_n = jacobian.transpose() * n;
  double least = std::numeric_limits<double>::infinity(), most = 0.0;
  for (Eigen::Index i = 0; i < jt_n.size(); ++i) {
    if (std::abs(jt_n(i)) < 1e-12 * jt_n.norm()) continue;
    const JointModel& j = joints[static_cast<std::size_t>(i)];
    least = std::min(least, j.damping / j.mass);
    most = std::max(most, j.damping / j.mass);
  }
  return {least, most - least <= 1e-12 * std::max(most, 1.0)};
}

}  // namespace

DirectionalModel cartesian_along(std::span<const JointModel> axes, const AxisVector& direction) {
  const auto size = static_cast<Eigen::Index>(axes.size());
  if (size < 1 || size > world::max_axes) throw std::invalid_argument("a stage has 1 to 6 axes");
  check_joints(axes, axes.size());
  const AxisVector n = unit_direction(direction, size);
  const AxisMatrix identity = AxisMatrix::Identity(size, size);
  DirectionalModel out;
  out.mass = mass_along(identity, axes, n);
  const auto [per_mass, proportional] = damping_per_mass(identity, axes, n);
  out.damping = per_mass * out.mass;
  out.exact = proportional;
  out.joints = AxisVector::Zero(size);
  out.position = AxisVector::Zero(size);
  out.basis = "m_n = 1 / (n^T M^-1 n) = " + num(out.mass) + " kg; " +
              (proportional ? "damping proportional to the mass along n: the wall's axis decouples (exact)"
                            : "damping " + num(out.damping) +
                                  " N s/m: the least damping per unit mass of the axes along n (a bound: "
                                  "the axes' damping is not proportional to their mass)");
  return out;
}

namespace {

struct Candidate {
  double mass = std::numeric_limits<double>::infinity();
  AxisVector joints, position;
  AxisMatrix jacobian;
};

/// The lightest configuration on an n x n grid over the box by `mass_at`
/// (the mass a configuration's Jacobian gives); throws for a point outside
/// the workspace.
template <class MassAt>
Candidate lightest_on_grid(const world::PantographKinematics& k, const TaskBox& box, int steps,
                           const MassAt& mass_at) {
  Candidate best;
  for (int i = 0; i <= steps; ++i) {
    for (int j = 0; j <= steps; ++j) {
      AxisVector x(2);
      x << box.x_min + (box.x_max - box.x_min) * i / steps, box.y_min + (box.y_max - box.y_min) * j / steps;
      const auto q = k.inverse(x);
      world::TaskState s;
      if (q) k.solve(*q, s);
      if (!q || s.status != world::KinematicsStatus::ok)
        throw std::invalid_argument("the workspace point (" + num(x(0)) + ", " + num(x(1)) + ") m is " +
                                    std::string(q ? to_string(s.status) : "out of the pantograph's reach"));
      const double m = mass_at(s.jacobian);
      if (m < best.mass) best = {m, *q, s.position, s.jacobian};
    }
  }
  return best;
}

/// A 40 x 40 grid, then two finer grids around the lightest cell.
template <class MassAt>
Candidate lightest_over(const world::PantographKinematics& kinematics, const TaskBox& box,
                        const MassAt& mass_at) {
  if (!(box.x_min <= box.x_max && box.y_min <= box.y_max) ||
      !std::isfinite(box.x_min + box.x_max + box.y_min + box.y_max))
    throw std::invalid_argument("the workspace box must be finite with min <= max");
  Candidate best = lightest_on_grid(kinematics, box, 40, mass_at);
  TaskBox around = box;
  for (int round = 0; round < 2; ++round) {
    const double dx = (around.x_max - around.x_min) / 40, dy = (around.y_max - around.y_min) / 40;
    around = {std::max(box.x_min, best.position(0) - dx), std::min(box.x_max, best.position(0) + dx),
              std::max(box.y_min, best.position(1) - dy), std::min(box.y_max, best.position(1) + dy)};
    const Candidate finer = lightest_on_grid(kinematics, around, 20, mass_at);
    if (finer.mass < best.mass) best = finer;
  }
  return best;
}

std::string configuration_text(const Candidate& best) {
  return "(" + num(best.position(0)) + ", " + num(best.position(1)) + ") m, q = (" + num(best.joints(0)) +
         ", " + num(best.joints(1)) + ") rad";
}

/// The task-space inverse inertia J M^-1 J^T.
Eigen::Matrix2d inverse_inertia(const AxisMatrix& jacobian, std::span<const JointModel> joints) {
  const Eigen::Matrix2d j = jacobian.topLeftCorner<2, 2>();
  const Eigen::Vector2d inverse_mass(1.0 / joints[0].mass, 1.0 / joints[1].mass);
  return j * inverse_mass.asDiagonal() * j.transpose();
}

}  // namespace

DirectionalModel pantograph_along(const world::PantographKinematics& kinematics,
                                  std::span<const JointModel> joints, const AxisVector& direction,
                                  const TaskBox& box) {
  check_joints(joints, 2);
  const AxisVector n = unit_direction(direction, 2);
  const Candidate best =
      lightest_over(kinematics, box, [&](const AxisMatrix& j) { return mass_along(j, joints, n); });
  DirectionalModel out;
  out.mass = best.mass;
  out.damping = damping_per_mass(best.jacobian, joints, n).first * best.mass;
  out.exact = false;
  out.joints = best.joints;
  out.position = best.position;
  out.basis = "the lightest m_n over the workspace, " + num(out.mass) + " kg at " + configuration_text(best) +
              ": a bound, not exact (the linkage's mass changes with its configuration); damping " +
              num(out.damping) + " N s/m, the joints' least damping per unit inertia";
  return out;
}

DirectionalModel pantograph_lightest(const world::PantographKinematics& kinematics,
                                     std::span<const JointModel> joints, const TaskBox& box,
                                     AxisVector& direction) {
  check_joints(joints, 2);
  // At one configuration the lightest direction is the eigenvector of the
  // largest eigenvalue of J M^-1 J^T, and m = 1 / that eigenvalue.
  const auto lightest = [&](const AxisMatrix& j) {
    return 1.0 / Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(inverse_inertia(j, joints)).eigenvalues()(1);
  };
  const Candidate best = lightest_over(kinematics, box, lightest);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(inverse_inertia(best.jacobian, joints));
  direction = AxisVector(2);
  direction << eigen.eigenvectors()(0, 1), eigen.eigenvectors()(1, 1);
  DirectionalModel out;
  out.mass = best.mass;
  double least = std::numeric_limits<double>::infinity();
  for (const auto& j : joints) least = std::min(least, j.damping / j.mass);
  out.damping = least * best.mass;
  out.exact = false;
  out.joints = best.joints;
  out.position = best.position;
  out.basis = "the lightest m_n over every direction and the workspace, " + num(out.mass) + " kg along (" +
              num(direction(0)) + ", " + num(direction(1)) + ") at " + configuration_text(best) +
              ": a bound, not exact; damping " + num(out.damping) +
              " N s/m, the joints' least damping per unit inertia";
  return out;
}

}  // namespace hapticd::analysis
