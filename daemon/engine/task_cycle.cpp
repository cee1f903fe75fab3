// The RT cycle of a device with several axes (issue 22), beside engine.cpp's
// one-axis run_cycle: the same rules (a new plan or a cleared fault restarts
// the scene at equilibrium at the measured position, the latch holds the
// output at zero, every reading checked), on every axis read and written in
// one call at one sample instant. Between them the kinematics and
// tau = J^T F with one common saturation factor, so that the force keeps
// its direction when an axis reaches its limit (world/kinematics.hpp).
// Nothing here allocates: fixed-capacity vectors (world::max_axes).

#include <cmath>

#include "daemon/engine/engine.hpp"

namespace hapticd::daemon::engine {

namespace {
void bump_counter(std::atomic<std::uint64_t>& counter) noexcept {
  rt::single_writer_add(counter, std::uint64_t{1});
}
}  // namespace

TaskAxes::TaskAxes(int n, world::Kinematics k, PositionStepRule rule)
    : axes(n),
      kinematics(k),
      joints(world::AxisVector::Zero(n)),
      force(world::AxisVector::Zero(world::task_dimensions(kinematics))),
      output(world::AxisVector::Zero(n)),
      limits(world::AxisVector::Zero(n)),
      feedforward(world::AxisVector::Zero(n)),
      workspace_force(world::AxisVector::Zero(world::task_dimensions(kinematics))),
      linkage(std::holds_alternative<world::PantographKinematics>(kinematics)) {
  if (world::joint_count(kinematics) != n)
    throw std::invalid_argument("the kinematics has " + std::to_string(world::joint_count(kinematics)) +
                                " joints; the device has " + std::to_string(n) + " axes");
  guards.fill(PositionStepGuard(rule));
}

bool Engine::read_task_position(const rt::WakeUp& wake, TelemetrySample& sample) noexcept {
  TaskAxes& a = *task_;
  const auto n = static_cast<std::size_t>(a.axes);
  if (!read_succeeded(device_.read_axes(std::span<drivers::Reading>(a.readings.data(), n)), sample))
    return false;
  bool finite = true;
  for (std::size_t i = 0; i < n; ++i) {
    if (a.readings[i].stale) sample.flags |= flag_stale_position;
    finite = finite && std::isfinite(a.readings[i].position);
  }
  if (!finite) {
    latch(FaultReason::non_finite_position);
    return false;
  }
  // Each axis against its own last reading (every guard sees every reading,
  // so a refused one is the next reference, as on one axis).
  const double now_s = std::chrono::duration<double>(wake.woke).count();
  bool jumped = false;
  for (std::size_t i = 0; i < n; ++i) {
    a.joints(static_cast<Eigen::Index>(i)) = a.readings[i].position;
    PositionJump jump;
    if (a.guards[i].implausible(a.readings[i].position, now_s, jump) && !jumped) {
      jumped = true;
      jump.axis = static_cast<int>(i);
      sample.flags |= flag_position_jump;
      latch_jump(jump);
    }
  }
  last_position_ = a.joints(0);
  if (jumped) return false;
  world::solve(a.kinematics, a.joints, a.task);
  if (a.task.status != world::KinematicsStatus::ok) {
    latch(a.task.status == world::KinematicsStatus::singular ? FaultReason::kinematics_singular
                                                             : FaultReason::kinematics);
    return false;
  }
  if (reset_pending_ && plan_ != nullptr) {
    world::reset(a.scene, a.task.position);
    if (a.workspace) world::reset(*a.workspace, a.task.position);
    reset_pending_ = false;
  }
  return true;
}

void Engine::render_task_force(TelemetrySample& sample, bool position_valid, bool output_allowed,
                               bool& output_latched) noexcept {
  TaskAxes& a = *task_;
  a.force.setZero();
  a.output.setZero();
  a.feedforward.setZero();
  if (position_valid && plan_ != nullptr && output_allowed) {
    world::step(a.scene, a.task.position, a.force);
    // The workspace wall on top of the scene, in task space (before J^T).
    if (a.workspace) {
      world::step(*a.workspace, a.task.position, a.workspace_force);
      a.force += a.workspace_force;
    }
    // Gravity after the scene, in joint space: tau = J^T F + tau_g.
    if (a.gravity) world::gravity_torques(*a.gravity, a.kinematics, a.joints, a.task, a.feedforward);
    if (!a.force.allFinite() || !a.feedforward.allFinite()) latch(FaultReason::non_finite_command);
  }
  // As on one axis: one read of the latch decides the output and the flag.
  output_latched = output_latched || latch_.latched();
  if (position_valid && plan_ != nullptr && !output_latched) {
    if (plan_->axis_torque_limits.size() == a.limits.size()) {
      a.limits = plan_->axis_torque_limits;
    } else {
      a.limits.setConstant(plan_->torque_limit);
    }
    // One common factor on the sum: the feedforward saturates with the scene.
    const double factor =
        a.gravity ? world::joint_torques(a.task.jacobian, a.force, a.feedforward, a.limits, a.output)
                  : world::joint_torques(a.task.jacobian, a.force, a.limits, a.output);
    if (factor < 1.0) {
      sample.flags |= flag_torque_limited;
      bump_counter(torque_limited_);
    }
  }
}

void Engine::run_task_cycle(const rt::WakeUp& wake) noexcept {
  TaskAxes& a = *task_;
  TelemetrySample sample = begin_sample(wake);
  if (take_plan(wake.cycle)) a.scene = plan_->task_scene;
  bool cleared = false;
  const bool latched_before = latch_at_wake(wake, cleared);
  if (cleared) {
    for (auto& guard : a.guards) guard.forget();  // the first reading after a clear is the new reference
  }
  const bool position_valid = read_task_position(wake, sample);
  const bool output_allowed = !latched_before && !latch_.latched();
  bool output_latched = latched_before;
  render_task_force(sample, position_valid, output_allowed, output_latched);
  const auto n = static_cast<std::size_t>(a.axes);
  note_write(device_.write_axes(std::span<const double>(a.output.data(), n)), sample);
  // The first axis in the one-axis fields, for clients that read one.
  sample.position = a.joints(0);
  // A linkage's first joint: its torque J^T F before the limit (N m, as the
  // column says), not the task force along x.
  sample.command = a.linkage ? a.task.jacobian.col(0).dot(a.force) : a.force(0);
  sample.applied = a.output(0);
  finish_sample(wake, sample, output_latched);
}

void Engine::task_channels(TelemetrySample& sample) const noexcept {
  const TaskAxes& a = *task_;
  const auto n = static_cast<std::size_t>(a.axes);
  for (std::size_t i = 0; i < n; ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    sample.channels[i] = a.joints(k);
    sample.channels[n + i] = k < a.force.size() ? a.force(k) : 0.0;
    sample.channels[2 * n + i] = a.output(k);
  }
  std::size_t count = channels_per_axis * n;
  if (a.linkage) {
    // The handle where the kinematics put it (0 when they could not).
    for (Eigen::Index k = 0; k < a.force.size(); ++k)
      sample.channels[count + static_cast<std::size_t>(k)] =
          a.task.status == world::KinematicsStatus::ok && k < a.task.position.size() ? a.task.position(k)
                                                                                     : 0.0;
    count = a.axis_channels();
  }
  if (a.gravity) {
    for (std::size_t i = 0; i < n; ++i)
      sample.channels[count + i] = a.feedforward(static_cast<Eigen::Index>(i));
    count += n;
  }
  if (a.workspace) {
    const std::size_t wall = world::channel_count(*a.workspace);
    world::channels(*a.workspace, std::span<double>(sample.channels.data() + count, wall));
    count += wall;
  }
  if (plan_ != nullptr) {
    const std::size_t scene = world::channel_count(a.scene);
    world::channels(a.scene, std::span<double>(sample.channels.data() + count, scene));
    count += scene;
  }
  sample.channel_count = static_cast<std::uint32_t>(count);
}

}  // namespace hapticd::daemon::engine
