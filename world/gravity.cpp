#include "world/gravity.hpp"

#include <cmath>

namespace hapticd::world {

AxisVector pantograph_gravity_torques(const PantographKinematics& kinematics, const PantographMasses& m,
                                      const AxisVector& q, const TaskState& state) noexcept {
  AxisVector tau = AxisVector::Zero(2);
  if (state.status != KinematicsStatus::ok) return tau;
  const PantographGeometry& g = kinematics.geometry();
  // d y / d q of each centre: the elbows' rows are a cos q on their own
  // joint; the handle's is J's second row.
  const double dy_elbow_left = g.a1 * std::cos(q(0)), dy_elbow_right = g.a4 * std::cos(q(1));
  const double dy_handle_1 = state.jacobian(1, 0), dy_handle_2 = state.jacobian(1, 1);
  // Proximal centres at half the elbow; distal centres halfway from elbow to handle.
  tau(0) = m.proximal_left * 0.5 * dy_elbow_left + m.distal_left * 0.5 * (dy_elbow_left + dy_handle_1) +
           m.distal_right * 0.5 * dy_handle_1 + m.handle * dy_handle_1;
  tau(1) = m.proximal_right * 0.5 * dy_elbow_right + m.distal_right * 0.5 * (dy_elbow_right + dy_handle_2) +
           m.distal_left * 0.5 * dy_handle_2 + m.handle * dy_handle_2;
  return tau * m.gravity;
}

void gravity_torques(const GravityModel& model, const Kinematics& kinematics, const AxisVector& q,
                     const TaskState& state, AxisVector& out) noexcept {
  out.setZero(q.size());
  if (const auto* stage = std::get_if<StageWeight>(&model)) {
    if (stage->holding.size() == q.size()) out = stage->holding;
    return;
  }
  const auto* pantograph = std::get_if<PantographKinematics>(&kinematics);
  if (pantograph != nullptr && q.size() == PantographKinematics::joints())
    out = pantograph_gravity_torques(*pantograph, std::get<PantographMasses>(model), q, state);
}

}  // namespace hapticd::world
