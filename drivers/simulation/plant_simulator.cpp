#include "drivers/simulation/plant_simulator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "world/integrator.hpp"
#include "world/units.hpp"

namespace hapticd::drivers::simulation {

namespace detail {

enum class HandKind { free, force, constraint, impedance };

/// Immutable once published; freed only by the non-RT side.
struct PreparedHand {
  HandScript script;
  std::uint64_t id = 0;  ///< distinct per set_hand(): the RT side detects a new script by id
  HandKind kind = HandKind::free;
  StepModel impedance{};  ///< plant with the hand's spring-damper folded in (kind impedance)
  double stiffness = 0.0;
  double damping = 0.0;
};

}  // namespace detail

namespace {

using detail::HandKind;
using detail::PreparedHand;
using detail::StepModel;

constexpr std::array<std::string_view, 5> fault_name_list{"read-error", "stall", "nan", "encoder-jump",
                                                          "fault"};

/// Hold ideal=false default: critically damped at this natural frequency on the total mass.
constexpr double default_hold_frequency_hz = 30.0;

StepModel to_step_model(const world::DiscreteStateSpace& d) {
  StepModel m;
  m.n = static_cast<int>(d.ad.rows());
  for (int i = 0; i < m.n; ++i) {
    for (int j = 0; j < m.n; ++j) m.ad[i][j] = d.ad(i, j);
    for (int j = 0; j < static_cast<int>(d.bd.cols()); ++j) m.bd[i][j] = d.bd(i, j);
  }
  return m;
}

/// Decrements a period counter that is > 0 (N periods left); -1 and 0 stay.
void count_down(std::atomic<std::int64_t>& counter) noexcept {
  std::int64_t value = counter.load(std::memory_order_relaxed);
  while (value > 0 && !counter.compare_exchange_weak(value, value - 1, std::memory_order_relaxed)) {
  }
}

bool active(const std::atomic<std::int64_t>& counter) noexcept {
  return counter.load(std::memory_order_relaxed) != 0;
}

double sign(double v) noexcept { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); }

}  // namespace

std::string_view to_string(Fault fault) noexcept { return fault_name_list[static_cast<std::size_t>(fault)]; }

std::optional<Fault> parse_fault(std::string_view name) noexcept {
  for (std::size_t i = 0; i < fault_name_list.size(); ++i) {
    if (fault_name_list[i] == name) return static_cast<Fault>(i);
  }
  if (name == "read_error") return Fault::read_error;
  if (name == "encoder_jump") return Fault::encoder_jump;
  return std::nullopt;
}

std::string_view fault_names() noexcept { return "read-error, stall, nan, encoder-jump, fault"; }

PlantSimulator::PlantSimulator(const PlantConfig& config, const HandScript& hand) : config_(config) {
  config_.validate();
  if (config_.plant == PlantKind::rigid) {
    model_ = world::RigidPlant{config_.mass, config_.damping}.model();
    pos_motor_ = pos_body_ = 0;
    vel_motor_ = vel_body_ = 1;
  } else {
    model_ = config_.two_mass.model();
    pos_motor_ = 0;
    pos_body_ = 1;
    vel_motor_ = 2;
    vel_body_ = 3;
  }
  plain_ = to_step_model(world::discretize_zoh(model_.dynamics, config_.period_s));
  resolution_ = config_.resolution();
  set_hand(hand);
  publish_snapshot();
}

PlantSimulator::~PlantSimulator() = default;

std::unique_ptr<PreparedHand> PlantSimulator::prepare(const HandScript& script) const {
  auto prepared = std::make_unique<PreparedHand>();
  prepared->script = script;
  switch (script.mode) {
    case HandMode::free:
      prepared->kind = HandKind::free;
      return prepared;
    case HandMode::force:
      prepared->kind = HandKind::force;
      return prepared;
    case HandMode::hold:
      if (script.ideal) {
        prepared->kind = HandKind::constraint;
        return prepared;
      }
      break;
    case HandMode::impedance:
      break;
  }
  prepared->kind = HandKind::impedance;
  const double m = config_.total_mass();
  const double w = 2.0 * world::units::pi * default_hold_frequency_hz;
  if (script.mode == HandMode::hold) {
    prepared->stiffness = script.stiffness.value_or(m * w * w);
    prepared->damping = script.damping.value_or(2.0 * std::sqrt(prepared->stiffness * m));
  } else {
    if (!script.stiffness) throw std::invalid_argument("hand script: mode=impedance needs stiffness");
    prepared->stiffness = *script.stiffness;
    prepared->damping = script.damping.value_or(0.0);
  }
  // x' = A x + B_m F_m + B_h (F_ext + k (r - x_b) + b (r' - v_b))
  const Eigen::Index n = model_.dynamics.a.rows();
  const Eigen::VectorXd bm = model_.dynamics.b.col(world::motor_force_input);
  const Eigen::VectorXd bh = model_.dynamics.b.col(world::hand_force_input);
  Eigen::RowVectorXd c = Eigen::RowVectorXd::Zero(n);
  c(pos_body_) += prepared->stiffness;
  c(vel_body_) += prepared->damping;
  world::ContinuousStateSpace sys;
  sys.a = model_.dynamics.a - bh * c;
  sys.b = Eigen::MatrixXd::Zero(n, 4);
  sys.b.col(0) = bm;
  sys.b.col(1) = bh;
  sys.b.col(2) = prepared->stiffness * bh;
  sys.b.col(3) = prepared->damping * bh;
  prepared->impedance = to_step_model(world::discretize_zoh(sys, config_.period_s));
  return prepared;
}

void PlantSimulator::set_hand(const HandScript& script) {
  auto prepared = prepare(script);
  std::lock_guard lock(hand_mutex_);  // non-RT writers only; the RT side never takes it
  prepared->id = ++hand_generation_;
  const PreparedHand* raw = prepared.get();
  hands_.push_back(std::move(prepared));
  current_hand_.store(raw, std::memory_order_seq_cst);
  reclaim_locked();
}

void PlantSimulator::set_hand(std::string_view text) { set_hand(parse_hand_script(text)); }

HandScript PlantSimulator::hand() const {
  std::lock_guard lock(hand_mutex_);
  return current_hand_.load(std::memory_order_acquire)->script;
}

void PlantSimulator::reclaim_locked() {
  // Hazard-pointer reclamation: the RT side publishes the pointer it uses in
  // hazard_ and re-checks current_hand_; anything that is neither current nor
  // the hazard cannot be picked up any more and is freed here, off the RT path.
  const PreparedHand* current = current_hand_.load(std::memory_order_seq_cst);
  const PreparedHand* in_use = hazard_.load(std::memory_order_seq_cst);
  std::erase_if(hands_, [&](const std::unique_ptr<PreparedHand>& h) {
    return h.get() != current && h.get() != in_use;
  });
}

const PreparedHand* PlantSimulator::acquire_hand() noexcept {
  const PreparedHand* p = current_hand_.load(std::memory_order_seq_cst);
  for (;;) {
    hazard_.store(p, std::memory_order_seq_cst);
    const PreparedHand* q = current_hand_.load(std::memory_order_seq_cst);
    if (q == p) return p;
    p = q;  // a new script was published between the two loads: protect that one
  }
}

void PlantSimulator::release_hand() noexcept { hazard_.store(nullptr, std::memory_order_release); }

double PlantSimulator::friction_mass_load(const std::array<double, 4>& x, double motor_force,
                                          double body_force, double stiffness, double damping,
                                          double reference, double reference_rate) const noexcept {
  // Every force on the friction mass except friction, with that mass at rest
  // (viscous damping to ground is then zero).
  double load = body_force + stiffness * (reference - x[pos_body_]) + damping * reference_rate;
  if (config_.plant == PlantKind::rigid) {
    load += motor_force;
  } else {
    const world::TwoMassPlant& p = config_.two_mass;
    load += p.cable_stiffness * (x[pos_motor_] - x[pos_body_]) + p.cable_damping * x[vel_motor_];
  }
  return load;
}

void PlantSimulator::advance_plant(double u, const JointDrive& drive) noexcept {
  const PreparedHand* hand = acquire_hand();
  if (hand->id != active_hand_id_) {
    active_hand_id_ = hand->id;
    hand_start_period_ = period_;
  }
  const double period = config_.period_s;
  const double t = static_cast<double>(period_ - hand_start_period_) * period;
  const double t_next = static_cast<double>(period_ + 1 - hand_start_period_) * period;
  const HandScript& script = hand->script;
  released_ = script.released(t);
  const HandKind kind = released_ ? HandKind::free : hand->kind;
  if (drive.pinned) {
    step_along_trajectory(u, drive.reference);
  } else if (kind == HandKind::constraint) {
    step_along_trajectory(u, script.trajectory.at_time(t_next));
  } else {
    const bool impedance = kind == HandKind::impedance;
    HandPull pull;
    pull.external = (kind == HandKind::force ? script.force_at_time(t) : 0.0) + config_.weight;
    if (drive.external != 0.0) pull.external += drive.external;
    if (impedance) {
      pull.stiffness = hand->stiffness;
      pull.damping = hand->damping;
      pull.reference = script.trajectory.at_time(t);
    }
    step_with_friction(u, impedance ? hand->impedance : plain_, pull);
  }
  release_hand();
}

void PlantSimulator::step_model(const StepModel& m, const std::array<double, 4>& x0, double u,
                                double body_force, double r, double rd) noexcept {
  const int n = plain_.n;
  std::array<double, 4> next{};
  for (int i = 0; i < n; ++i) {
    double acc = m.bd[i][0] * u + m.bd[i][1] * body_force + m.bd[i][2] * r + m.bd[i][3] * rd;
    for (int j = 0; j < n; ++j) acc += m.ad[i][j] * x0[j];
    next[i] = acc;
  }
  x_ = next;
}

void PlantSimulator::step_along_trajectory(double u, const Trajectory::Sample& ref) noexcept {
  // The hand moves the body exactly along the trajectory: solve for the
  // (piecewise-constant) hand force that lands the body on r(t_next), step
  // the whole plant with it, then pin position and velocity.
  const std::array<double, 4> x0 = x_;
  const int pb = pos_body_;
  const double fc = config_.coulomb;
  const double f = fc > 0.0 ? -fc * sign(ref.position - x0[pb]) : 0.0;
  double free_position = plain_.bd[pb][0] * u + plain_.bd[pb][1] * f;
  for (int j = 0; j < plain_.n; ++j) free_position += plain_.ad[pb][j] * x0[j];
  const double fh = (ref.position - free_position) / plain_.bd[pb][1];
  step_model(plain_, x0, u, fh + f, 0.0, 0.0);
  x_[pb] = ref.position;
  x_[vel_body_] = ref.velocity;
  hand_force_ = fh;
  friction_ = f;
  stuck_ = false;
}

void PlantSimulator::step_with_friction(double u, const StepModel& m, const HandPull& pull) noexcept {
  const std::array<double, 4> x0 = x_;
  const int pb = pos_body_;
  const int vb = vel_body_;
  const Trajectory::Sample& ref = pull.reference;
  hand_force_ =
      pull.external + pull.stiffness * (ref.position - x0[pb]) + pull.damping * (ref.velocity - x0[vb]);
  const Friction friction = coulomb_friction(x0, u, pull);
  step_model(m, x0, u, pull.external + friction.force, ref.position, ref.velocity);
  stuck_ = false;
  if (friction.holds) {
    x_[pb] = x0[pb];
    x_[vb] = 0.0;
    stuck_ = true;
  } else if (config_.coulomb > 0.0 && x0[vb] != 0.0) {
    stop_if_velocity_vanished(x0, u, pull);
  }
  friction_ = friction.force;
}

PlantSimulator::Friction PlantSimulator::coulomb_friction(const std::array<double, 4>& x0, double u,
                                                          const HandPull& pull) const noexcept {
  const double fc = config_.coulomb;
  Friction friction;
  if (fc > 0.0) {
    const double v0 = x0[vel_body_];
    if (v0 == 0.0) {
      const double load = friction_mass_load(x0, u, pull.external, pull.stiffness, pull.damping,
                                             pull.reference.position, pull.reference.velocity);
      if (std::abs(load) <= fc) {
        friction.force = -load;  // stiction balances the load
        friction.holds = true;
      } else {
        friction.force = -fc * sign(load);  // breakaway: kinetic friction against the load
      }
    } else {
      friction.force = -fc * sign(v0);
    }
  }
  return friction;
}

void PlantSimulator::stop_if_velocity_vanished(const std::array<double, 4>& x0, double u,
                                               const HandPull& pull) noexcept {
  const int pb = pos_body_;
  const int vb = vel_body_;
  const double v0 = x0[vb];
  const double v1 = x_[vb];
  if (v1 == 0.0 || sign(v1) != sign(v0)) {
    const double load = friction_mass_load(x_, u, pull.external, pull.stiffness, pull.damping,
                                           pull.reference.position, pull.reference.velocity);
    if (std::abs(load) <= config_.coulomb) {
      // Stops within the step: position where the (linearly decaying)
      // velocity reaches zero; exact for a rigid mass without viscous damping.
      const double stop_time = v0 / (v0 - v1) * config_.period_s;
      x_[pb] = x0[pb] + 0.5 * v0 * stop_time;
      x_[vb] = 0.0;
      stuck_ = true;
    }
  }
}

void PlantSimulator::reset_actuator() noexcept {
  delay_line_.fill(0.0);
  delay_head_ = 0;
  commanded_ = applied_ = 0.0;
  publish_snapshot();
}

IoResult PlantSimulator::sense(double& position) noexcept {
  if (active(fault_left_)) {
    faults_.fetch_add(1, std::memory_order_relaxed);
    return IoResult::fault;
  }
  if (active(stall_left_)) {
    position = last_reading_;  // the device answers nothing new
    return IoResult::ok;
  }
  if (active(read_error_left_)) {
    read_errors_.fetch_add(1, std::memory_order_relaxed);
    return IoResult::error;
  }
  if (active(nan_left_)) {
    position = std::numeric_limits<double>::quiet_NaN();
    return IoResult::ok;
  }
  const int index = config_.sensor == world::Sensor::motor ? pos_motor_ : pos_body_;
  const double counts = std::floor(x_[index] / resolution_) +
                        static_cast<double>(encoder_offset_.load(std::memory_order_relaxed));
  position = counts * resolution_;
  last_reading_ = position;
  return IoResult::ok;
}

IoResult PlantSimulator::step(double force, const JointDrive& drive) noexcept {
  auto end_period = [this]() noexcept {
    count_down(read_error_left_);
    count_down(stall_left_);
    count_down(nan_left_);
    count_down(fault_left_);
  };
  if (active(stall_left_)) {
    write_errors_.fetch_add(1, std::memory_order_relaxed);
    end_period();
    return IoResult::error;
  }
  IoResult result = IoResult::ok;
  double command = force;
  if (!std::isfinite(command)) {
    write_errors_.fetch_add(1, std::memory_order_relaxed);
    command = 0.0;
    result = IoResult::error;
  }
  const bool faulted = active(fault_left_);
  if (faulted) {
    faults_.fetch_add(1, std::memory_order_relaxed);
    command = 0.0;
    result = IoResult::fault;
  }
  command = std::clamp(command, -config_.max_force, config_.max_force);
  commanded_ = command;
  constexpr std::size_t length = max_delay_periods + 1;
  delay_line_[delay_head_] = command;
  const std::size_t delay = static_cast<std::size_t>(config_.delay);
  applied_ = faulted ? 0.0 : delay_line_[(delay_head_ + length - delay) % length];
  delay_head_ = (delay_head_ + 1) % length;
  advance_plant(applied_, drive);
  ++period_;
  end_period();
  publish_snapshot();
  return result;
}

void PlantSimulator::publish_snapshot() noexcept {
  const int sensed = config_.sensor == world::Sensor::motor ? pos_motor_ : pos_body_;
  const std::array<double, 10> values{static_cast<double>(period_) * config_.period_s,
                                      x_[pos_motor_],
                                      x_[pos_body_],
                                      x_[vel_motor_],
                                      x_[vel_body_],
                                      x_[sensed],
                                      commanded_,
                                      applied_,
                                      hand_force_,
                                      friction_};
  snapshot_version_.write_begin();
  rt::seq_store(cells_.period, period_);
  for (std::size_t i = 0; i < values.size(); ++i) rt::seq_store(cells_.values[i], values[i]);
  rt::seq_store(cells_.stuck, stuck_);
  rt::seq_store(cells_.released, released_);
  snapshot_version_.write_end();
}

PlantSnapshot PlantSimulator::snapshot() const noexcept {
  PlantSnapshot s;
  std::array<double, 10> v{};
  // Consistent unless the plant's writer stopped mid-update for a second,
  // which a running loop never does.
  snapshot_version_.read([&] {
    s.period = rt::seq_load(cells_.period);
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = rt::seq_load(cells_.values[i]);
    s.stuck = rt::seq_load(cells_.stuck);
    s.hand_released = rt::seq_load(cells_.released);
  });
  s.time_s = v[0];
  s.motor_position = v[1];
  s.body_position = v[2];
  s.motor_velocity = v[3];
  s.body_velocity = v[4];
  s.sensed_position = v[5];
  s.commanded_force = v[6];
  s.applied_force = v[7];
  s.hand_force = v[8];
  s.friction_force = v[9];
  return s;
}

void PlantSimulator::set_initial_state(double position, double velocity) {
  x_.fill(0.0);
  x_[pos_motor_] = x_[pos_body_] = position;
  x_[vel_motor_] = x_[vel_body_] = velocity;
  stuck_ = false;
  publish_snapshot();
}

void PlantSimulator::inject_fault(Fault fault, std::int64_t amount) noexcept {
  const std::int64_t periods = amount < 0 ? -1 : amount;
  switch (fault) {
    case Fault::read_error:
      read_error_left_.store(periods, std::memory_order_relaxed);
      break;
    case Fault::stall:
      stall_left_.store(periods, std::memory_order_relaxed);
      break;
    case Fault::nan:
      nan_left_.store(periods, std::memory_order_relaxed);
      break;
    case Fault::fault:
      fault_left_.store(periods, std::memory_order_relaxed);
      break;
    case Fault::encoder_jump:
      encoder_offset_.fetch_add(amount, std::memory_order_relaxed);
      break;
  }
}

void PlantSimulator::clear_faults() noexcept {
  read_error_left_.store(0, std::memory_order_relaxed);
  stall_left_.store(0, std::memory_order_relaxed);
  nan_left_.store(0, std::memory_order_relaxed);
  fault_left_.store(0, std::memory_order_relaxed);
  encoder_offset_.store(0, std::memory_order_relaxed);
}

SimulatorCounters PlantSimulator::counters() const noexcept {
  return {read_errors_.load(std::memory_order_relaxed), write_errors_.load(std::memory_order_relaxed),
          faults_.load(std::memory_order_relaxed)};
}

std::string PlantSimulator::active_faults() const {
  std::string out;
  auto describe = [&out](std::string_view name, std::int64_t left) {
    if (left == 0) return;
    if (!out.empty()) out += "; ";
    out += "injected " + std::string(name) +
           (left < 0 ? std::string(" (until cleared)") : " (" + std::to_string(left) + " periods left)");
  };
  describe("fault", fault_left_.load(std::memory_order_relaxed));
  describe("stall", stall_left_.load(std::memory_order_relaxed));
  describe("read-error", read_error_left_.load(std::memory_order_relaxed));
  describe("nan", nan_left_.load(std::memory_order_relaxed));
  const std::int64_t offset = encoder_offset_.load(std::memory_order_relaxed);
  if (offset != 0) {
    if (!out.empty()) out += "; ";
    out += "injected encoder-jump (offset " + std::to_string(offset) + " counts)";
  }
  return out;
}

std::optional<world::TwoMassPlant> PlantSimulator::two_mass() const {
  if (config_.plant == PlantKind::two_mass) return config_.two_mass;
  return std::nullopt;
}

}  // namespace hapticd::drivers::simulation
