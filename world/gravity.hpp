#pragma once
/// \file
/// Gravity compensation (issue 22 item 7), as the vendor SDKs have it: a
/// feedforward added after the scene so that the linkage weighs nothing in
/// the hand. The joint torques that hold the links still are the gradient of
/// their potential energy, tau = dV/dq with V = g sum_k m_k y_k(q) (y up).
/// - A Cartesian stage: a constant force on each axis (m g on a vertical
///   axis, 0 on a horizontal one), from the config.
/// - The pantograph in a vertical plane: link masses at the links' middles
///   and a mass at the handle; y_k(q) from the forward kinematics, so
///   dV/dq = g sum_k m_k d y_k / d q with the handle's row of J.
/// Pure and RT-safe.

#include <variant>

#include "world/kinematics.hpp"

namespace hapticd::world {

inline constexpr double standard_gravity = 9.80665;  ///< m/s^2

/// Masses in kg, each link's centre at its middle (a uniform link).
struct PantographMasses {
  double proximal_left = 0.0, distal_left = 0.0, distal_right = 0.0, proximal_right = 0.0, handle = 0.0;
  double gravity = standard_gravity;  ///< m/s^2, along -y of the task plane
};

/// The motor torques (N m) that hold the pantograph's links against gravity
/// at joints q, where `state` is solve(q)'s result (status ok). Zero
/// otherwise: no feedforward at a singular configuration.
AxisVector pantograph_gravity_torques(const PantographKinematics& kinematics, const PantographMasses& masses,
                                      const AxisVector& q, const TaskState& state) noexcept;

/// A Cartesian stage: the constant joint force that holds each axis, N (m g
/// on a vertical axis, 0 on a horizontal one): V = sum_i h_i q_i, so
/// dV/dq = h.
struct StageWeight {
  AxisVector holding;
};

/// What the config describes ([gravity], docs/config.md).
using GravityModel = std::variant<StageWeight, PantographMasses>;

/// The joint torques (N or N m) that hold the device still against gravity
/// at joints q, `state` being solve(q)'s result: the feedforward the engine
/// adds after the scene (tau = J^T F + tau_g). Zero where the model does not
/// fit the kinematics (a pantograph's masses on a stage) or at a singular
/// configuration. RT-safe: `out` has fixed capacity.
void gravity_torques(const GravityModel& model, const Kinematics& kinematics, const AxisVector& q,
                     const TaskState& state, AxisVector& out) noexcept;

}  // namespace hapticd::world
