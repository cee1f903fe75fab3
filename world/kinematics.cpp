#include "world/kinematics.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace hapticd::world {

std::string_view to_string(KinematicsStatus status) noexcept {
  switch (status) {
    case KinematicsStatus::ok:
      return "ok";
    case KinematicsStatus::out_of_workspace:
      return "out of the workspace: the linkage cannot close there";
    case KinematicsStatus::singular:
      return "at a singular configuration of the linkage";
  }
  return "?";
}

// ---- Cartesian ----------------------------------------------------------------

CartesianKinematics::CartesianKinematics(int axes) : axes_(axes) {
  if (axes < 1 || axes > max_axes)
    throw std::invalid_argument("cartesian kinematics: " + std::to_string(axes) + " axes; accepted: 1 to " +
                                std::to_string(max_axes));
}

void CartesianKinematics::solve(const AxisVector& joints, TaskState& out) const noexcept {
  out.status = KinematicsStatus::ok;
  out.position = joints.head(axes_);
  out.jacobian.setIdentity(axes_, axes_);
}

std::optional<AxisVector> CartesianKinematics::inverse(const AxisVector& task) const {
  if (task.size() != axes_) return std::nullopt;
  return task;
}

// ---- the five-bar pantograph -----------------------------------------------

void PantographGeometry::validate() const {
  const std::pair<const char*, double> lengths[] = {
      {"a1", a1}, {"a2", a2}, {"a3", a3}, {"a4", a4}, {"a5", a5}};
  for (const auto& [name, value] : lengths) {
    if (!(std::isfinite(value) && value > 0.0))
      throw std::invalid_argument(std::string("pantograph: link ") + name +
                                  " must be a positive length in m");
  }
  // The handle can be reached only if the two arms can meet: the motors'
  // distance below the sum of every link on the way round.
  if (a5 >= a1 + a2 + a3 + a4)
    throw std::invalid_argument("pantograph: a5 (the motors' distance) must be below a1 + a2 + a3 + a4");
  if (!(min_singular_value > 0.0) || !(min_distal_sine > 0.0 && min_distal_sine < 1.0))
    throw std::invalid_argument("pantograph: the singularity thresholds must be positive (sine below 1)");
}

PantographKinematics::PantographKinematics(const PantographGeometry& geometry) : g_(geometry) {
  g_.validate();
}

namespace {

Eigen::Vector2d perpendicular(const Eigen::Vector2d& v) noexcept { return {-v.y(), v.x()}; }

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) noexcept {
  return a.x() * b.y() - a.y() * b.x();
}

void zero(TaskState& out, KinematicsStatus status) noexcept {
  out.status = status;
  out.position.setZero(2);
  out.jacobian.setZero(2, 2);
}

/// One common factor so that |tau_i| <= limits_i: the direction is kept.
double scale_to_limits(const AxisVector& limits, AxisVector& torques) noexcept {
  double factor = 1.0;
  for (Eigen::Index i = 0; i < torques.size(); ++i) {
    const double size = std::abs(torques(i));
    if (size > limits(i)) factor = std::min(factor, limits(i) / size);
  }
  torques *= factor;
  return factor;
}

}  // namespace

void PantographKinematics::solve(const AxisVector& joints, TaskState& out) const noexcept {
  const double q1 = joints(0), q2 = joints(1);
  if (!std::isfinite(q1) || !std::isfinite(q2)) return zero(out, KinematicsStatus::out_of_workspace);
  // The elbows: P2 on the left arm, P4 on the right.
  const Eigen::Vector2d p2(g_.a1 * std::cos(q1), g_.a1 * std::sin(q1));
  const Eigen::Vector2d p4(g_.a5 + g_.a4 * std::cos(q2), g_.a4 * std::sin(q2));
  const Eigen::Vector2d v = p4 - p2;
  const double d = v.norm();
  // The handle P3 closes the loop: |P3 - P2| = a2, |P3 - P4| = a3 (two
  // circles); the working configuration takes the intersection left of P2->P4.
  const double along = (g_.a2 * g_.a2 - g_.a3 * g_.a3 + d * d) / (2.0 * d);
  const double h2 = g_.a2 * g_.a2 - along * along;
  if (!(d > 0.0) || !(h2 >= 0.0)) return zero(out, KinematicsStatus::out_of_workspace);
  const Eigen::Vector2d p3 = p2 + (along / d) * v + (std::sqrt(h2) / d) * perpendicular(v);
  // Differentiating the two constraints: A dP3 = B dq, with A's rows the
  // distal links and B diagonal, so J = A^-1 B.
  const Eigen::Vector2d left = p3 - p2, right = p3 - p4;
  if (std::abs(cross(left, right)) < g_.min_distal_sine * g_.a2 * g_.a3)
    return zero(out, KinematicsStatus::singular);
  Eigen::Matrix2d a;
  a << left.transpose(), right.transpose();
  const Eigen::Vector2d dp2(-g_.a1 * std::sin(q1), g_.a1 * std::cos(q1));
  const Eigen::Vector2d dp4(-g_.a4 * std::sin(q2), g_.a4 * std::cos(q2));
  const Eigen::Matrix2d b = Eigen::Vector2d(left.dot(dp2), right.dot(dp4)).asDiagonal();
  const Eigen::Matrix2d j = a.inverse() * b;
  if (Eigen::JacobiSVD<Eigen::Matrix2d>(j).singularValues()(1) < g_.min_singular_value)
    return zero(out, KinematicsStatus::singular);
  out.status = KinematicsStatus::ok;
  out.position = p3;
  out.jacobian = j;
}

std::optional<AxisVector> PantographKinematics::inverse(const AxisVector& task) const {
  if (task.size() != 2 || !task.allFinite()) return std::nullopt;
  const double x = task(0), y = task(1);
  // Each arm by the law of cosines; the elbows point outwards (the left one
  // counter-clockwise of the line to the handle, the right one clockwise).
  const double r1 = std::hypot(x, y), r2 = std::hypot(x - g_.a5, y);
  const double c1 = (g_.a1 * g_.a1 + r1 * r1 - g_.a2 * g_.a2) / (2.0 * g_.a1 * r1);
  const double c2 = (g_.a4 * g_.a4 + r2 * r2 - g_.a3 * g_.a3) / (2.0 * g_.a4 * r2);
  if (!(r1 > 0.0 && r2 > 0.0) || std::abs(c1) > 1.0 || std::abs(c2) > 1.0) return std::nullopt;
  AxisVector q(2);
  q << std::atan2(y, x) + std::acos(c1), std::atan2(y, x - g_.a5) - std::acos(c2);
  return q;
}

// ---- any kinematics ----------------------------------------------------------

int joint_count(const Kinematics& kinematics) noexcept {
  return std::visit([](const auto& k) { return k.joints(); }, kinematics);
}

int task_dimensions(const Kinematics& kinematics) noexcept {
  return std::visit([](const auto& k) { return k.task_dimensions(); }, kinematics);
}

void solve(const Kinematics& kinematics, const AxisVector& joints, TaskState& out) noexcept {
  std::visit([&](const auto& k) { k.solve(joints, out); }, kinematics);
}

double joint_torques(const AxisMatrix& jacobian, const AxisVector& force, const AxisVector& limits,
                     AxisVector& torques) noexcept {
  torques.setZero(jacobian.cols());
  if (!force.allFinite() || !jacobian.allFinite()) return 0.0;
  torques.noalias() = jacobian.transpose() * force;
  return scale_to_limits(limits, torques);
}

double joint_torques(const AxisMatrix& jacobian, const AxisVector& force, const AxisVector& feedforward,
                     const AxisVector& limits, AxisVector& torques) noexcept {
  torques.setZero(jacobian.cols());
  if (!force.allFinite() || !jacobian.allFinite() || !feedforward.allFinite() ||
      feedforward.size() != jacobian.cols())
    return 0.0;
  torques.noalias() = jacobian.transpose() * force;
  torques += feedforward;
  return scale_to_limits(limits, torques);
}

}  // namespace hapticd::world
