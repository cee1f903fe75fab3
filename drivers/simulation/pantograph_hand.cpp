#include "drivers/simulation/pantograph_hand.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "drivers/parameter.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::simulation {

namespace {

using world::AxisVector;
using world::text::format_number;

/// "0,-1" -> (0, -1): two finite numbers; throws ParameterError naming `key`.
std::array<double, 2> parse_pair(std::string_view key, std::string_view text) {
  const auto fail = [&] {
    throw ParameterError(std::string(key), "task hand: " + std::string(key) + "=" + std::string(text) +
                                               " is not accepted; two comma-separated finite numbers (m or "
                                               "a direction), e.g. " +
                                               std::string(key) + "=0,-1");
  };
  const std::size_t comma = text.find(',');
  if (comma == std::string_view::npos) fail();
  std::array<double, 2> out{};
  const std::string_view parts[] = {text.substr(0, comma), text.substr(comma + 1)};
  for (std::size_t i = 0; i < 2; ++i) {
    const std::string item(parts[i]);
    std::size_t used = 0;
    try {
      out[i] = std::stod(item, &used);
    } catch (const std::exception&) {
      fail();
    }
    if (used != item.size() || !std::isfinite(out[i]) || std::abs(out[i]) > 1e3) fail();
  }
  return out;
}

/// The extremes of s(t) over all t (m).
std::pair<double, double> trajectory_range(const Trajectory& t) {
  switch (t.kind) {
    case TrajectoryKind::constant:
      return {t.position, t.position};
    case TrajectoryKind::step:
      return {std::min(t.position, t.position + t.amplitude), std::max(t.position, t.position + t.amplitude)};
    case TrajectoryKind::ramp:
      return {std::min(t.from, t.to), std::max(t.from, t.to)};
    case TrajectoryKind::sine:
      return {t.position - std::abs(t.amplitude), t.position + std::abs(t.amplitude)};
  }
  return {0.0, 0.0};
}

AxisVector point(const TaskHandScript& hand, double s) {
  AxisVector x(2);
  x << hand.origin[0] + s * hand.direction[0], hand.origin[1] + s * hand.direction[1];
  return x;
}

}  // namespace

std::string TaskHandScript::to_text() const {
  return "direction=" + format_number(direction[0]) + "," + format_number(direction[1]) +
         " origin=" + format_number(origin[0]) + "," + format_number(origin[1]) + " " + script.to_text();
}

TaskHandScript parse_task_hand_script(std::string_view text, const std::array<double, 2>& origin) {
  TaskHandScript out;
  out.origin = origin;
  if (text.find_first_not_of(" \t\n") == std::string_view::npos) return out;  // no hand: free
  std::string rest;
  std::size_t i = 0;
  while (i < text.size()) {
    const std::size_t begin = text.find_first_not_of(" \t\n", i);
    if (begin == std::string_view::npos) break;
    const std::size_t end = std::min(text.find_first_of(" \t\n", begin), text.size());
    const std::string_view token = text.substr(begin, end - begin);
    if (token.starts_with("direction=")) {
      out.direction = parse_pair("direction", token.substr(10));
    } else if (token.starts_with("origin=")) {
      out.origin = parse_pair("origin", token.substr(7));
    } else {
      rest += std::string(token) + " ";
    }
    i = end;
  }
  const double norm = std::hypot(out.direction[0], out.direction[1]);
  if (!(norm > 0.0))
    throw ParameterError("direction", "task hand: direction must not be 0,0; e.g. direction=0,-1");
  out.direction = {out.direction[0] / norm, out.direction[1] / norm};
  out.script = parse_hand_script(rest);
  const bool spring =
      out.script.mode == HandMode::impedance || (out.script.mode == HandMode::hold && !out.script.ideal);
  if (spring && !out.script.stiffness)
    throw ParameterError("stiffness", "task hand: mode=" + std::string(to_string(out.script.mode)) +
                                          (out.script.ideal ? "" : " ideal=false") +
                                          " on the handle needs stiffness (N/m)");
  return out;
}

PantographHand::PantographHand(const world::PantographGeometry& geometry, const TaskHandScript& script,
                               double period_s)
    : kinematics_(geometry), period_s_(period_s) {
  set_script(script);
}

void PantographHand::check_reach(const TaskHandScript& hand) const {
  if (hand.script.mode == HandMode::free || hand.script.mode == HandMode::force) return;
  const auto [low, high] = trajectory_range(hand.script.trajectory);
  constexpr int samples = 64;
  for (int k = 0; k <= samples; ++k) {
    const AxisVector x = point(hand, low + (high - low) * k / samples);
    const auto q = kinematics_.inverse(x);
    world::TaskState s;
    if (q) kinematics_.solve(*q, s);
    if (!q || s.status != world::KinematicsStatus::ok)
      throw std::invalid_argument(
          "task hand: the reference passes (" + format_number(x(0)) + ", " + format_number(x(1)) + ") m, " +
          (q ? std::string(world::to_string(s.status)) : std::string("out of the pantograph's reach")) +
          "; accepted: a reference within the linkage's reach (origin, direction and the trajectory's "
          "range)");
  }
}

void PantographHand::set_script(const TaskHandScript& script) {
  check_reach(script);
  std::lock_guard lock(writer_);
  scripts_.publish(std::make_unique<TaskHandScript>(script));
  last_ = script;
}

TaskHandScript PantographHand::script() const {
  std::lock_guard lock(writer_);
  return last_;
}

void PantographHand::hold(const TaskHandScript& hand, double t_next,
                          std::array<JointDrive, 2>& out) const noexcept {
  const Trajectory::Sample s = hand.script.trajectory.at_time(t_next);
  AxisVector x(2);
  x << hand.origin[0] + s.position * hand.direction[0], hand.origin[1] + s.position * hand.direction[1];
  const auto q = kinematics_.inverse(x);
  if (!q) return;  // checked when set: not reached
  world::TaskState state;
  kinematics_.solve(*q, state);
  if (state.status != world::KinematicsStatus::ok) return;
  // q' = J^-1 r' (J invertible away from the singularities solve() refuses).
  const Eigen::Vector2d rd(s.velocity * hand.direction[0], s.velocity * hand.direction[1]);
  const Eigen::Matrix2d j = state.jacobian.topLeftCorner<2, 2>();
  const Eigen::Vector2d qd = j.inverse() * rd;
  for (std::size_t i = 0; i < 2; ++i) {
    out[i].pinned = true;
    out[i].reference = {(*q)(static_cast<Eigen::Index>(i)), qd(static_cast<Eigen::Index>(i))};
  }
}

void PantographHand::drives(const std::array<double, 2>& q, const std::array<double, 2>& qd,
                            std::uint64_t period, std::array<JointDrive, 2>& out) noexcept {
  out = {};
  const TaskHandScript* hand = scripts_.acquire(period);
  if (hand != active_) {
    active_ = hand;
    start_period_ = period;
  }
  if (hand == nullptr) return;
  const HandScript& script = hand->script;
  const double t = static_cast<double>(period - start_period_) * period_s_;
  if (script.mode == HandMode::free || script.released(t)) return;
  if (script.mode == HandMode::hold && script.ideal) return hold(*hand, t + period_s_, out);
  AxisVector joints(2);
  joints << q[0], q[1];
  world::TaskState state;
  kinematics_.solve(joints, state);
  if (state.status != world::KinematicsStatus::ok) return;  // a broken linkage transmits nothing
  const Eigen::Vector2d d(hand->direction[0], hand->direction[1]);
  Eigen::Vector2d force = Eigen::Vector2d::Zero();
  if (script.mode == HandMode::force) {
    force = script.force_at_time(t) * d;
  } else {
    // A spring-damper to r(t) in both task directions (impedance, or a
    // hold through a spring), evaluated at the period's start (held over it).
    const Trajectory::Sample s = script.trajectory.at_time(t);
    const Eigen::Vector2d r(hand->origin[0] + s.position * d(0), hand->origin[1] + s.position * d(1));
    const Eigen::Matrix2d j = state.jacobian.topLeftCorner<2, 2>();
    const Eigen::Vector2d x = state.position.head<2>();
    const Eigen::Vector2d xd = j * Eigen::Vector2d(qd[0], qd[1]);
    force = script.stiffness.value_or(0.0) * (r - x) + script.damping.value_or(0.0) * (s.velocity * d - xd);
  }
  // tau = J^T F: the hand's torque on each joint (virtual work).
  const Eigen::Vector2d tau = state.jacobian.topLeftCorner<2, 2>().transpose() * force;
  out[0].external = tau(0);
  out[1].external = tau(1);
}

}  // namespace hapticd::drivers::simulation
