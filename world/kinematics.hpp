#pragma once
/// \file
/// Kinematics between joint space (what the drivers see: one position and
/// one force or torque per axis) and task space (where the scenes live), as
/// LinuxCNC separates joints from axes and libnifalcon maps a Cartesian
/// force through J^T. Pure and RT-safe: fixed-size Eigen types with at most
/// max_axes rows, no allocation, no exceptions on the per-period path.
///
/// - CartesianKinematics: an XY or XYZ stage, one joint per task axis
///   (identity; SI on both sides).
/// - PantographKinematics: the planar five-bar linkage of the Pantograph
///   (Campion, Wang & Hayward 2005) and of the Hapkit/Haply 2-DOF devices:
///   two motors at the base drive the two proximal links; the distal links
///   meet at the handle. Forward kinematics in closed form, the Jacobian
///   from the loop-closure constraints, inverse kinematics for tests and
///   start-up.
///
/// A configuration outside the workspace (the distal links cannot meet) or
/// near a singularity (the distal links aligned, or a proximal link aligned
/// with its distal link) is reported, never a NaN: the engine zeroes the
/// output and latches a fault with the reason.

#include <Eigen/Dense>

#include <cstdint>
#include <optional>
#include <string_view>
#include <variant>

namespace hapticd::world {

inline constexpr int max_axes = 6;
/// One value per axis (joint or task), at most max_axes: no allocation.
using AxisVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, max_axes, 1>;
/// Task rows by joint columns, at most max_axes each.
using AxisMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, max_axes, max_axes>;

enum class KinematicsStatus : std::uint8_t {
  ok,
  out_of_workspace,  ///< the linkage cannot close at these joint angles
  singular,          ///< too near a singular configuration to render a force
};
std::string_view to_string(KinematicsStatus status) noexcept;

/// Where the handle is and how joint velocities map to it, at one sample.
struct TaskState {
  KinematicsStatus status = KinematicsStatus::ok;
  AxisVector position;  ///< task coordinates (m)
  AxisMatrix jacobian;  ///< d position / d joints
};

class CartesianKinematics {
 public:
  /// 1 to max_axes axes, each a prismatic (m) or rotary (rad) joint as is.
  explicit CartesianKinematics(int axes);
  int joints() const noexcept { return axes_; }
  int task_dimensions() const noexcept { return axes_; }
  void solve(const AxisVector& joints, TaskState& out) const noexcept;
  std::optional<AxisVector> inverse(const AxisVector& task) const;

 private:
  int axes_;
};

/// Link lengths in metres, named as in Campion, Wang & Hayward (2005): a1
/// the left proximal link (motor 1 at the origin), a2 the left distal link,
/// a3 the right distal link, a4 the right proximal link (motor 2 at
/// (a5, 0)), a5 the distance between the motors. Joint angles are measured
/// from the +x axis, counter-clockwise; the handle is above the base (y > 0
/// in its working configuration, the elbows pointing outwards).
struct PantographGeometry {
  double a1 = 0.07, a2 = 0.09, a3 = 0.09, a4 = 0.07, a5 = 0.0381;
  /// Below this smallest singular value of J (m/rad), the handle has all but
  /// lost a direction (a proximal link in line with its distal link).
  double min_singular_value = 0.005;
  /// Below this sine of the angle between the distal links, they are all but
  /// aligned: the handle moves without the motors, no torque holds it.
  double min_distal_sine = 0.05;
  /// Throws std::invalid_argument naming the length that is not positive and
  /// finite, or a linkage that cannot close anywhere.
  void validate() const;
};

class PantographKinematics {
 public:
  explicit PantographKinematics(const PantographGeometry& geometry);
  static constexpr int joints() noexcept { return 2; }
  static constexpr int task_dimensions() noexcept { return 2; }
  const PantographGeometry& geometry() const noexcept { return g_; }
  /// Handle position and Jacobian; status out_of_workspace or singular
  /// (position and Jacobian then zero).
  void solve(const AxisVector& joints, TaskState& out) const noexcept;
  /// The joint angles that put the handle at `task` in the working
  /// configuration; nothing if no such configuration exists.
  std::optional<AxisVector> inverse(const AxisVector& task) const;

 private:
  PantographGeometry g_;
};

using Kinematics = std::variant<CartesianKinematics, PantographKinematics>;

int joint_count(const Kinematics& kinematics) noexcept;
int task_dimensions(const Kinematics& kinematics) noexcept;
void solve(const Kinematics& kinematics, const AxisVector& joints, TaskState& out) noexcept;

/// tau = J^T F (the principle of virtual work: tau . dq = F . dx), then
/// scaled by one common factor so that |tau_i| <= limits_i for every joint:
/// the force keeps its direction, only its size is reduced (libnifalcon
/// does the same). Returns the factor applied, in (0, 1]; 1 when nothing
/// saturated. A non-finite force gives zero torques and factor 0.
double joint_torques(const AxisMatrix& jacobian, const AxisVector& force, const AxisVector& limits,
                     AxisVector& torques) noexcept;

/// tau = J^T F + tau_ff (a feedforward in joint space, e.g. gravity
/// compensation, world/gravity.hpp), then the same common factor on the
/// sum, so |tau_i| <= limits_i and the total keeps its direction. Returns
/// the factor; a non-finite force or feedforward gives zero torques and 0.
double joint_torques(const AxisMatrix& jacobian, const AxisVector& force, const AxisVector& feedforward,
                     const AxisVector& limits, AxisVector& torques) noexcept;

}  // namespace hapticd::world
