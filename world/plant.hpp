#pragma once
/// \file
/// Physical devices as linear plants, for simulation (the loopback device)
/// and analysis (critical stiffness). SI units; a rotary device uses the same
/// equations with inertia in kg m^2, torque in N m and angle in rad.
///
/// Every plant has inputs u = [motor force, hand force] and the state layout
/// [positions; velocities], so any integrator in world/integrator.hpp applies.

#include <optional>
#include <string_view>

#include <Eigen/Dense>

#include "world/state_space.hpp"

namespace hapticd::world {

/// Where the position fed back to the scene is measured (Diaz & Gil II, VI).
enum class Sensor { motor, body };
std::string_view to_string(Sensor sensor) noexcept;
std::optional<Sensor> parse_sensor(std::string_view name) noexcept;

inline constexpr Eigen::Index motor_force_input = 0;
inline constexpr Eigen::Index hand_force_input = 1;

/// A plant with its two position outputs.
struct LinearPlant {
  ContinuousStateSpace dynamics;      ///< inputs [motor force, hand force]
  Eigen::RowVectorXd motor_position;  ///< x_m = motor_position * x
  Eigen::RowVectorXd body_position;   ///< x_h = body_position * x
  const Eigen::RowVectorXd& position(Sensor sensor) const {
    return sensor == Sensor::motor ? motor_position : body_position;
  }
};

/// Rigid device: G(s) = 1 / (m s^2 + b s) (Diaz & Gil eq. 2). Motor and hand
/// act on the same mass; both sensors read the same position.
struct RigidPlant {
  double mass = 0.1;     ///< kg (or kg m^2)
  double damping = 0.0;  ///< N s/m (or N m s/rad), viscous, to ground
  LinearPlant model() const;
};

/// Motor and body joined by a cable spring-damper (Diaz & Gil eq. 3-9).
/// Defaults are the LHifAM of Table I.
struct TwoMassPlant {
  double motor_mass = 0.3;          ///< m_m, kg
  double body_mass = 5.1;           ///< m_d, kg
  double motor_damping = 0.1;       ///< b_m, N s/m
  double body_damping = 3.4;        ///< b_d, N s/m
  double cable_stiffness = 79.5e3;  ///< k_c, N/m
  double cable_damping = 15.0;      ///< b_c, N s/m

  double total_mass() const noexcept { return motor_mass + body_mass; }           ///< m = m_m + m_d
  double total_damping() const noexcept { return motor_damping + body_damping; }  ///< b = b_m + b_d
  LinearPlant model() const;  ///< state [x_m, x_d, v_m, v_d]
};

}  // namespace hapticd::world
