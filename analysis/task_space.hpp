#pragma once
/// \file
/// The device seen along a task-space direction, for the one-axis gate
/// (issue 22; Hulin et al. treat a PHANToM-like device one axis at a time,
/// which is exact only where the axes decouple). A plane wall with unit
/// normal n acts on the penetration p = n . x; with joint mass matrix M and
/// Jacobian J the task-space inverse inertia is J M^-1 J^T, so the mass the
/// wall pushes along n is
///     m_n = 1 / (n^T J M^-1 J^T n).
/// With joint damping B = c M (proportional) the n-dynamics decouple:
/// p'' = f / m_n - c p', exactly the one-axis wall with mass m_n and damping
/// c m_n. Otherwise the damping used is c_min m_n with c_min the least
/// damping per unit mass of the joints that move along n: less dissipation
/// than the device has, so a stability verdict from it is conservative
/// where damping helps (it does in Hulin's region), and said to be a bound.
/// For the pantograph m_n depends on the configuration: the lightest over
/// the configured workspace is the worst case, and a bound.

#include <span>
#include <string>

#include "world/kinematics.hpp"

namespace hapticd::analysis {

/// One joint: the mass (kg) or inertia (kg m^2) its motor moves, and its
/// viscous damping to ground (N s/m or N m s/rad).
struct JointModel {
  double mass = 0.0;
  double damping = 0.0;
};

/// What the wall pushes along n.
struct DirectionalModel {
  double mass = 0.0;           ///< m_n, kg
  double damping = 0.0;        ///< N s/m along n (exact or the bound, see `exact`)
  bool exact = false;          ///< true only for a Cartesian stage with proportional damping
  world::AxisVector joints;    ///< the configuration judged (the pantograph's worst case)
  world::AxisVector position;  ///< the handle there, m
  std::string basis;           ///< one line: how m_n and the damping were found
};

/// A Cartesian stage (J = I): exact where the damping is proportional to
/// the mass. Throws std::invalid_argument for a direction that is not a
/// finite non-zero vector of the stage's size, or a joint whose mass is not
/// positive and finite, or whose damping is negative.
DirectionalModel cartesian_along(std::span<const JointModel> axes, const world::AxisVector& direction);

/// An axis-aligned box of the task plane, m.
struct TaskBox {
  double x_min = 0.0, x_max = 0.0, y_min = 0.0, y_max = 0.0;
};

/// The pantograph's worst case over `box`: the configuration of smallest
/// m_n (a grid over the box, refined around its minimum). Throws
/// std::invalid_argument, naming the point, if part of the box is outside
/// the workspace or at a singularity: such a box cannot be held.
DirectionalModel pantograph_along(const world::PantographKinematics& kinematics,
                                  std::span<const JointModel> joints, const world::AxisVector& direction,
                                  const TaskBox& box);

/// The pantograph's worst case over `box` and over every direction (a
/// sphere's radius may point anywhere): the smallest m_n, 1 / the largest
/// eigenvalue of J M^-1 J^T, and that direction (out). Throws as
/// pantograph_along.
DirectionalModel pantograph_lightest(const world::PantographKinematics& kinematics,
                                     std::span<const JointModel> joints, const TaskBox& box,
                                     world::AxisVector& direction);

}  // namespace hapticd::analysis
