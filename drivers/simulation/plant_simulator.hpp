#pragma once
/// \file
/// The shared plant simulator (DRIVERS.md "Simulated peers"): the plant the
/// loopback driver is, and the plant behind every simulated peer (CANopen
/// drive, Modbus amplifier, USB board, GPIO board), so a peer run can be
/// compared sample by sample with a loopback run of the same plant and delay.
/// Each step() advances the plant by exactly one period with the exact
/// zero-order-hold discretization computed at construction; simulated time
/// is (number of step() calls) * period, independent of the wall clock.
/// sense() returns the position quantized to encoder counts, with the
/// injected faults. drivers/loopback/README.md describes the whole model.
///
/// Sign convention: a positive motor force (step()) and a positive hand
/// force both increase the position.
///
/// Threads: sense()/step() belong to one thread (the loopback's RT thread, a
/// peer's exchange loop; noexcept, no allocation, no locks, no
/// std::function). set_hand(), inject_fault(), clear_faults(), snapshot(),
/// counters() may be called from any other thread at any time;
/// reset_actuator() and set_initial_state() only when no thread is inside
/// sense()/step().

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string_view>
#include <vector>

#include "drivers/device_hooks.hpp"
#include "drivers/simulation/hand_script.hpp"
#include "drivers/simulation/plant_config.hpp"
#include "rt/seqlock.hpp"
#include "world/plant.hpp"

namespace hapticd::drivers::simulation {

/// Faults the device can be told to simulate.
enum class Fault {
  read_error,    ///< sense() returns IoResult::error (no valid value)
  stall,         ///< the device stops: time and plant freeze, sense() returns the stale value, step() errors
  nan,           ///< sense() returns IoResult::ok with a NaN position
  encoder_jump,  ///< the encoder count jumps by N counts once (the offset stays until clear_faults())
  fault,         ///< sense() and step() return IoResult::fault; the amplifier is off (motor force 0)
};
std::string_view to_string(Fault fault) noexcept;  ///< "read-error", "stall", "nan", "encoder-jump", "fault"
std::optional<Fault> parse_fault(std::string_view name) noexcept;
std::string_view fault_names() noexcept;  ///< for error messages

/// A consistent copy of the simulated state, taken at a period boundary.
struct PlantSnapshot {
  std::uint64_t period = 0;     ///< number of step() calls that advanced the plant
  double time_s = 0.0;          ///< period * T
  double motor_position = 0.0;  ///< m or rad (rigid: the mass)
  double body_position = 0.0;   ///< m or rad (rigid: the mass)
  double motor_velocity = 0.0;
  double body_velocity = 0.0;
  double sensed_position = 0.0;  ///< true (unquantized) position at the configured sensor
  double commanded_force = 0.0;  ///< last step() argument after saturation
  double applied_force = 0.0;    ///< motor force applied over the last step (after the delay line)
  double hand_force = 0.0;       ///< hand force over the last step (ideal hold: the reaction it took)
  double friction_force = 0.0;   ///< Coulomb friction over the last step (on the mass / the body)
  bool stuck = false;            ///< the friction mass is at rest in stiction
  bool hand_released = false;    ///< release_at has passed (the hand acts as mode=free)
};

namespace detail {
/// x[n+1] = ad x[n] + bd [motor force, body force, reference, reference rate],
/// n = 2 (rigid) or 4 (two-mass); fixed storage for the RT path.
struct StepModel {
  int n = 0;
  std::array<std::array<double, 4>, 4> ad{};
  std::array<std::array<double, 4>, 4> bd{};
};
struct PreparedHand;
}  // namespace detail

/// Outcome counts of sense() and step() since construction.
struct SimulatorCounters {
  std::uint64_t read_errors = 0;   ///< sense() returned error
  std::uint64_t write_errors = 0;  ///< step() returned error (stall, non-finite force)
  std::uint64_t faults = 0;        ///< sense() or step() returned fault
};

/// What a linkage's hand does to one joint over one period, besides the
/// joint's own script (drivers/simulation/pantograph_simulator.hpp): a
/// torque J^T F_hand added to the body, or the joint pinned to a reference
/// (the handle held ideally: every joint follows it, its script waits).
struct JointDrive {
  double external = 0.0;  ///< N or N m on the body, added to the script's hand
  bool pinned = false;
  Trajectory::Sample reference{};  ///< pinned: the body's position and velocity at the period's end
};

class PlantSimulator {
 public:
  /// Validates the config (throws std::invalid_argument) and discretizes the plant.
  explicit PlantSimulator(const PlantConfig& config, const HandScript& hand = {});
  ~PlantSimulator();
  PlantSimulator(const PlantSimulator&) = delete;
  PlantSimulator& operator=(const PlantSimulator&) = delete;

  /// The encoder's position now (m or rad, quantized), with the injected faults.
  IoResult sense(double& position) noexcept;
  /// Commands `force` (saturated; zero while faulted; non-finite: zero and an
  /// error) and advances the plant one period through the output delay line.
  IoResult step(double force) noexcept { return step(force, JointDrive{}); }
  /// step() with a linkage's hand on this joint as well.
  IoResult step(double force, const JointDrive& drive) noexcept;
  /// The true (unquantized) body position and velocity: for the thread that
  /// steps the plant (a linkage computing its hand), between steps.
  double body_position() const noexcept { return x_[pos_body_]; }
  double body_velocity() const noexcept { return x_[vel_body_]; }
  /// Empties the delay line and zeroes the commanded and applied force (an
  /// amplifier switched on again applies nothing stale).
  void reset_actuator() noexcept;

  SimulatorCounters counters() const noexcept;
  /// The injected faults still active, in words ("" if none).
  std::string active_faults() const;
  /// An injected `fault` is active (the amplifier is off).
  bool faulted() const noexcept { return fault_left_.load(std::memory_order_relaxed) != 0; }

  const PlantConfig& config() const noexcept { return config_; }
  /// The continuous model that is simulated (inputs [motor force, hand force]).
  const world::LinearPlant& plant_model() const noexcept { return model_; }
  /// The two-mass parameters when plant = two-mass (info().effective_mass is
  /// the total mass m_m + m_d; analysis wants the full model).
  std::optional<world::TwoMassPlant> two_mass() const;

  /// Replaces the hand script (non-RT; allocates, computes the impedance
  /// discretization, publishes it lock-free). Times in the script count from
  /// the first step() that sees it. Throws std::invalid_argument.
  void set_hand(const HandScript& script);
  void set_hand(std::string_view text);
  HandScript hand() const;

  /// Injects a fault (non-RT, lock-free for the stepping side). For read_error,
  /// stall, nan and fault, `amount` is a number of periods (step() calls),
  /// -1 = until cleared; for encoder_jump it is the jump in counts (+/-).
  void inject_fault(Fault fault, std::int64_t amount = -1) noexcept;
  void clear_faults() noexcept;
  /// The encoder-jump offset injected so far, in counts.
  std::int64_t encoder_offset() const noexcept { return encoder_offset_.load(std::memory_order_relaxed); }

  /// Consistent copy of the simulated state (seqlock; never blocks the RT side).
  PlantSnapshot snapshot() const noexcept;

  /// Sets the state (all positions to `position`, cable relaxed, velocities
  /// to `velocity`); only while nothing steps the plant.
  void set_initial_state(double position, double velocity);

 private:
  /// The hand's pull on the body over one step when it does not pin it: an
  /// external force (mode force) or a spring-damper to the reference (impedance).
  struct HandPull {
    double external = 0.0;
    double stiffness = 0.0;
    double damping = 0.0;
    Trajectory::Sample reference{};
  };
  /// Coulomb friction on the friction mass over one step.
  struct Friction {
    double force = 0.0;
    bool holds = false;  ///< stiction holds the mass at rest
  };

  const detail::PreparedHand* acquire_hand() noexcept;
  void release_hand() noexcept;
  /// One period of the plant under the hand's current script (RT path).
  void advance_plant(double motor_force, const JointDrive& drive) noexcept;
  /// x_ = ad x0 + bd [motor force, body force, reference, reference rate].
  void step_model(const detail::StepModel& m, const std::array<double, 4>& x0, double motor_force,
                  double body_force, double reference, double reference_rate) noexcept;
  /// An ideal hold: the hand force that puts the body on the reference, then the body pinned there.
  void step_along_trajectory(double motor_force, const Trajectory::Sample& reference) noexcept;
  /// A free, pushed or impedance-held body, with Coulomb friction and stiction.
  void step_with_friction(double motor_force, const detail::StepModel& m, const HandPull& pull) noexcept;
  /// Stiction when the friction mass is at rest and the load is within it, else sliding friction.
  Friction coulomb_friction(const std::array<double, 4>& x0, double motor_force,
                            const HandPull& pull) const noexcept;
  /// A sliding mass whose velocity reached zero or reversed within the step
  /// stops where it reached zero if stiction holds the load there.
  void stop_if_velocity_vanished(const std::array<double, 4>& x0, double motor_force,
                                 const HandPull& pull) noexcept;
  double friction_mass_load(const std::array<double, 4>& x, double motor_force, double body_force,
                            double stiffness, double damping, double reference,
                            double reference_rate) const noexcept;
  void publish_snapshot() noexcept;
  std::unique_ptr<detail::PreparedHand> prepare(const HandScript& script) const;
  void reclaim_locked();

  PlantConfig config_;
  world::LinearPlant model_;
  detail::StepModel plain_;
  int pos_motor_ = 0, pos_body_ = 0, vel_motor_ = 1, vel_body_ = 1;
  double resolution_ = 0.0;

  // RT-owned state.
  std::array<double, 4> x_{};
  std::array<double, max_delay_periods + 1> delay_line_{};
  std::size_t delay_head_ = 0;
  std::uint64_t period_ = 0;
  std::uint64_t active_hand_id_ = 0;
  std::uint64_t hand_start_period_ = 0;
  double last_reading_ = 0.0;
  double commanded_ = 0.0, applied_ = 0.0, hand_force_ = 0.0, friction_ = 0.0;
  bool stuck_ = false;
  bool released_ = false;

  // Shared with non-RT threads.
  std::atomic<const detail::PreparedHand*> current_hand_{nullptr};
  std::atomic<const detail::PreparedHand*> hazard_{nullptr};
  std::atomic<std::int64_t> read_error_left_{0}, stall_left_{0}, nan_left_{0}, fault_left_{0};
  std::atomic<std::int64_t> encoder_offset_{0};
  std::atomic<std::uint64_t> read_errors_{0}, write_errors_{0}, faults_{0};

  // Snapshot seqlock (written by whoever advances the plant).
  struct SnapshotCells {
    std::atomic<std::uint64_t> period{0};
    std::array<std::atomic<double>, 10> values{};
    std::atomic<bool> stuck{false}, released{false};
  };
  rt::SeqlockVersion snapshot_version_;
  SnapshotCells cells_;

  // Non-RT ownership of hand scripts.
  mutable std::mutex hand_mutex_;
  std::uint64_t hand_generation_ = 0;
  std::vector<std::unique_ptr<detail::PreparedHand>> hands_;  ///< current and retired, freed off the RT path
};

}  // namespace hapticd::drivers::simulation
