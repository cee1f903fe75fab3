#pragma once
/// \file
/// The RT loop: one SCHED_FIFO thread per device that, every period, waits for
/// its absolute deadline, installs a newly published plan, reads the device,
/// steps the scene, applies the safety rules, writes the device and pushes one
/// telemetry sample. Nothing else happens on that thread: no allocation, no
/// lock, no text, no syscall but the device I/O and the sleep.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <utility>

#include "daemon/engine/loop_plan.hpp"
#include "daemon/engine/origin.hpp"
#include "daemon/engine/safety.hpp"
#include "daemon/engine/task_axes.hpp"
#include "daemon/system/rt_setup.hpp"
#include "daemon/telemetry.hpp"
#include "drivers/device.hpp"
#include "rt/clock.hpp"
#include "rt/cycle_stats.hpp"
#include "rt/mailbox.hpp"
#include "rt/seqlock.hpp"
#include "rt/spsc_ring.hpp"

namespace hapticd::daemon::engine {

struct EngineOptions {
  rt::Nanos period{1'000'000};
  hapticd::daemon::system::RtOptions realtime;  ///< applied on the loop thread at start
  std::uint32_t overrun_limit = 10;             ///< consecutive overruns that latch a fault (0: never)
  std::uint32_t read_error_limit = 10;          ///< consecutive read errors that latch a fault (0: never)
  /// Position plausibility (max_velocity 0: not checked); the service sets
  /// it from [device] max_velocity and the device model.
  PositionStepRule position_rule{};
  std::optional<rt::Nanos> duration;          ///< stop by itself after this much loop time
  std::size_t telemetry_capacity = 1u << 14;  ///< samples; a power of two
  /// [device] require_calibration: the output stays zero (flag_uncalibrated)
  /// until an origin is in force (preset_origin() or a taken request).
  bool require_calibration = false;
  /// A device with several axes: its kinematics (joints to task space);
  /// nothing: Cartesian on the device's axes. Unused on one axis.
  std::optional<world::Kinematics> kinematics;
  /// The gravity feedforward ([gravity], world/gravity.hpp), joint torques
  /// added after the scene, inside the saturation; one axis: a StageWeight
  /// of one (a vertical linear axis).
  std::optional<world::GravityModel> gravity;
  /// Several axes: the workspace wall ([workspace]: a box or a sphere the
  /// device is held inside), stepped beside every scene and added to its force.
  std::optional<world::AnyTaskScene> workspace;
  /// Virtual clock only: wait for ring space instead of dropping a sample.
  /// Simulated time is not real time, so a deterministic run that loses
  /// nothing is worth more than speed; never set with the real clock.
  bool wait_for_telemetry_space = false;
};

/// Counters the RT thread keeps besides CycleStats (relaxed, single writer).
struct EngineCounters {
  std::uint64_t read_errors = 0;
  std::uint64_t write_errors = 0;
  std::uint64_t torque_limited = 0;
  std::uint64_t telemetry_dropped = 0;
  std::uint64_t faults_latched = 0;
  std::uint64_t position_jumps = 0;  ///< readings refused by the position-step rule
};

class Engine {
 public:
  /// The device and clock must outlive the engine. Allocates the ring (and
  /// for a device with several axes their state; std::invalid_argument when
  /// the kinematics' joints are not the device's axes).
  Engine(EngineOptions options, drivers::Device& device, rt::Clock& clock);
  ~Engine();
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  /// Starts the loop thread and waits until it has configured itself.
  /// Returns its real-time report (check `fatal`).
  const hapticd::daemon::system::RtSetupReport& start();
  /// Asks the loop to stop at the next period boundary and joins it.
  void stop() noexcept;
  /// True once the loop has ended (stopped, or reached its duration).
  bool finished() const noexcept { return finished_.load(std::memory_order_acquire); }
  /// Blocks until finished() or the timeout; returns finished().
  bool wait_finished(std::chrono::milliseconds timeout) const;

  // ---- control thread ----
  /// Publishes a plan; it takes effect at the next period boundary.
  rt::Mailbox<LoopPlan>::Publication publish(std::unique_ptr<LoopPlan> plan) {
    return plans_.publish(std::move(plan));
  }
  /// Waits until publication `seq` is in effect; the cycle it took effect at.
  std::optional<std::uint64_t> wait_applied(std::uint64_t seq, std::chrono::milliseconds timeout) const;
  void estop() noexcept { latch_.latch(FaultReason::estop); }
  /// Clears a latched fault; the scene restarts at equilibrium at the next period.
  void clear_fault() noexcept { latch_.clear(); }
  FaultReason fault() const noexcept { return latch_.reason(); }

  // ---- the origin (origin.hpp) ----
  /// Before start() only: the origin in force from the first cycle (restored
  /// from the state directory, or 0 for a device that homed itself).
  void preset_origin(double origin) noexcept;
  /// Control thread: makes the position read in the coming cycle the
  /// origin (device.zero); the scene restarts at equilibrium there. Waits
  /// until the RT thread took it, or dropped it for want of a valid reading
  /// within `valid_for` of loop time. Nothing when the loop did not get to it
  /// within `valid_for` + 2 s of wall time (stopped, or stalled), or the last
  /// request is still pending; settle_origin() then tells it later.
  std::optional<OriginOutcome> zero_here(std::chrono::milliseconds valid_for);
  /// zero_here() without the wait: the request's ticket (0: the last one is
  /// still pending), for origin_outcome().
  std::uint64_t request_zero(std::chrono::milliseconds valid_for) noexcept;
  std::optional<OriginOutcome> origin_outcome(std::uint64_t ticket) const noexcept {
    return origins_.outcome(ticket);
  }
  /// The outcome of the last request, once done (zero_here() may have given up waiting).
  std::optional<OriginOutcome> settle_origin() const noexcept { return origins_.outcome(waiting_ticket_); }
  bool origin_request_pending() const noexcept { return !origins_.idle(); }
  /// m or rad in the device's frame; 0 until calibrated.
  double origin() const noexcept { return origin_published_.load(std::memory_order_acquire); }
  bool calibrated() const noexcept { return calibrated_published_.load(std::memory_order_acquire); }
  /// The figures of the latched encoder jump (nothing for any other fault).
  std::optional<PositionJump> position_jump() const;
  /// The latched fault in words, with its figures where it has them
  /// (formatted here, off the RT thread); "" when none is latched.
  std::string fault_description() const;

  // ---- statistics and telemetry (non-RT readers) ----
  rt::CycleStats::Snapshot stats() const { return stats_.snapshot(); }
  /// Asks the RT thread to clear its timing statistics at the next period
  /// (it is their only writer) and waits for it: the cycle from which the
  /// statistics count, or nothing if the loop did not get there in time.
  std::optional<std::uint64_t> reset_stats(std::chrono::milliseconds timeout);
  /// The cycle of the last reset_stats() (0: counting since the start).
  std::uint64_t stats_since_cycle() const noexcept {
    return stats_since_cycle_.load(std::memory_order_acquire);
  }
  EngineCounters counters() const noexcept;
  /// Telemetry consumer (exactly one thread): pops up to out.size() samples.
  std::size_t drain(std::span<TelemetrySample> out) noexcept { return telemetry_.pop_bulk(out); }
  std::uint64_t cycle() const noexcept { return cycle_.load(std::memory_order_relaxed); }
  const EngineOptions& options() const noexcept { return options_; }

  /// One period of work after the wake-up (public for tests that drive the
  /// loop body directly, e.g. the allocation-counting test).
  void run_cycle(const rt::WakeUp& wake) noexcept;

 private:
  void thread_main();
  /// Reads the device and applies the reading rules (fault, error streak,
  /// finite value, position step); true when `position` may be rendered.
  bool read_position(const rt::WakeUp& wake, TelemetrySample& sample, double& position) noexcept;
  /// Publishes the cycle and starts its sample (cycle, time, latency).
  TelemetrySample begin_sample(const rt::WakeUp& wake) noexcept;
  /// The latch at the wake-up (returned); `cleared` when a fault was cleared
  /// since the last period (the scene restarts: reset_pending_); an overrun
  /// streak known at the wake-up latches now.
  bool latch_at_wake(const rt::WakeUp& wake, bool& cleared) noexcept;
  /// Takes the plan in force at `cycle`; true when it is new (the scene
  /// restarts at equilibrium: reset_pending_).
  bool take_plan(std::uint64_t cycle) noexcept;
  /// A read's outcome on one axis or all: a fault latches, an error counts
  /// toward the streak and flags the sample; true when the read was ok.
  bool read_succeeded(drivers::IoResult read, TelemetrySample& sample) noexcept;
  /// A write's outcome: anything but ok is counted and latches.
  void note_write(drivers::IoResult write, TelemetrySample& sample) noexcept;
  /// Latches `reason` (counted when this call latched it).
  void latch(FaultReason reason) noexcept;
  /// Stores a refused step's figures for position_jump(), then latches.
  void latch_jump(const PositionJump& jump) noexcept;
  /// Takes a pending origin request with this cycle's valid reading (raw,
  /// the device's own), or drops it once expired.
  void take_origin(std::uint64_t cycle, const double* raw) noexcept;
  /// Statistics, flags, channels and the push of this cycle's sample.
  void finish_sample(const rt::WakeUp& wake, TelemetrySample& sample, bool output_latched) noexcept;

  // A device with several axes (task_cycle.cpp): run_cycle hands over to
  // these; the one-axis cycle above is untouched by them.
  /// One period: read every axis, kinematics, the task scene's force,
  /// tau = J^T F with one common saturation factor, write every axis.
  void run_task_cycle(const rt::WakeUp& wake) noexcept;
  /// Every axis' reading with the reading rules (fault, error streak, finite
  /// values, a position guard per axis), then the kinematics; true when the
  /// task position may be rendered.
  bool read_task_position(const rt::WakeUp& wake, TelemetrySample& sample) noexcept;
  /// The task force of this period and the joint outputs it makes.
  void render_task_force(TelemetrySample& sample, bool position_valid, bool output_allowed,
                         bool& output_latched) noexcept;
  /// Each axis' position, task force and output, then the scene's channels.
  void task_channels(TelemetrySample& sample) const noexcept;

  EngineOptions options_;
  drivers::Device& device_;
  rt::Clock& clock_;
  rt::Mailbox<LoopPlan> plans_;
  rt::SpscRing<TelemetrySample> telemetry_;
  rt::CycleStats stats_;
  FaultLatch latch_;

  // RT thread state.
  const LoopPlan* plan_ = nullptr;
  world::AnyScene scene_{};
  bool was_latched_ = false;
  bool reset_pending_ = false;  ///< reset the scene at the next valid reading
  double last_position_ = 0.0;  ///< calibrated (the device's minus origin_)
  double origin_ = 0.0;         ///< subtracted from every reading
  bool calibrated_ = false;
  StreakCounter read_error_streak_;
  PositionStepGuard position_guard_;
  rt::Nanos t0_{0};
  std::unique_ptr<TaskAxes> task_;  ///< a device with several axes; null for one
  /// One axis with [gravity]: the holding force m g (N, signed: +m g when
  /// down is negative) and this period's feedforward (0 when none went out).
  std::optional<double> axis_weight_;
  double axis_feedforward_ = 0.0;

  std::atomic<std::uint64_t> cycle_{0};
  std::atomic<std::uint64_t> read_errors_{0};
  std::atomic<std::uint64_t> write_errors_{0};
  std::atomic<std::uint64_t> torque_limited_{0};
  std::atomic<std::uint64_t> faults_latched_{0};
  std::atomic<std::uint64_t> position_jumps_{0};

  // The latched jump's figures: written by the RT thread before it latches
  // (seqlock, never waits), read by position_jump() on a control thread.
  rt::SeqlockVersion jump_version_;
  std::atomic<double> jump_step_{0.0};
  std::atomic<double> jump_limit_{0.0};
  std::atomic<double> jump_interval_s_{0.0};
  std::atomic<int> jump_axis_{-1};

  // stats.reset: the control thread bumps `requested`; the RT thread resets
  // and copies it to `done` (release, after stats_since_cycle_).
  std::atomic<std::uint64_t> stats_reset_requested_{0};
  std::atomic<std::uint64_t> stats_reset_done_{0};
  std::atomic<std::uint64_t> stats_since_cycle_{0};

  // The origin: requests in (origins_), what is in force out (for status).
  OriginHandover origins_;
  std::uint64_t waiting_ticket_ = 0;  ///< control thread: the last zero_here() request
  std::atomic<double> origin_published_{0.0};
  std::atomic<bool> calibrated_published_{false};

  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> finished_{false};
  std::atomic<bool> started_{false};
  hapticd::daemon::system::RtSetupReport rt_report_;
  std::thread thread_;
};

}  // namespace hapticd::daemon::engine
