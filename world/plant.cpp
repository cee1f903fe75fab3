#include "world/plant.hpp"

namespace hapticd::world {

std::string_view to_string(Sensor sensor) noexcept { return sensor == Sensor::motor ? "motor" : "body"; }

std::optional<Sensor> parse_sensor(std::string_view name) noexcept {
  if (name == "motor") return Sensor::motor;
  if (name == "body" || name == "user" || name == "hand") return Sensor::body;
  return std::nullopt;
}

LinearPlant RigidPlant::model() const {
  LinearPlant plant;
  plant.dynamics.a = Eigen::MatrixXd::Zero(2, 2);
  plant.dynamics.a(0, 1) = 1.0;
  plant.dynamics.a(1, 1) = -damping / mass;
  plant.dynamics.b = Eigen::MatrixXd::Zero(2, 2);
  plant.dynamics.b(1, motor_force_input) = 1.0 / mass;
  plant.dynamics.b(1, hand_force_input) = 1.0 / mass;
  plant.motor_position = Eigen::RowVectorXd::Unit(2, 0);
  plant.body_position = plant.motor_position;
  return plant;
}

LinearPlant TwoMassPlant::model() const {
  // m_m x_m'' = F_m - b_m v_m - k_c (x_m - x_d) - b_c (v_m - v_d)   (Diaz & Gil eq. 9)
  // m_d x_d'' = F_h - b_d v_d - k_c (x_d - x_m) - b_c (v_d - v_m)   (Diaz & Gil eq. 8)
  enum : Eigen::Index { xm, xd, vm, vd };
  LinearPlant plant;
  Eigen::MatrixXd& a = plant.dynamics.a;
  a = Eigen::MatrixXd::Zero(4, 4);
  a(xm, vm) = 1.0;
  a(xd, vd) = 1.0;
  a(vm, xm) = -cable_stiffness / motor_mass;
  a(vm, xd) = cable_stiffness / motor_mass;
  a(vm, vm) = -(motor_damping + cable_damping) / motor_mass;
  a(vm, vd) = cable_damping / motor_mass;
  a(vd, xd) = -cable_stiffness / body_mass;
  a(vd, xm) = cable_stiffness / body_mass;
  a(vd, vd) = -(body_damping + cable_damping) / body_mass;
  a(vd, vm) = cable_damping / body_mass;
  plant.dynamics.b = Eigen::MatrixXd::Zero(4, 2);
  plant.dynamics.b(vm, motor_force_input) = 1.0 / motor_mass;
  plant.dynamics.b(vd, hand_force_input) = 1.0 / body_mass;
  plant.motor_position = Eigen::RowVectorXd::Unit(4, xm);
  plant.body_position = Eigen::RowVectorXd::Unit(4, xd);
  return plant;
}

}  // namespace hapticd::world
