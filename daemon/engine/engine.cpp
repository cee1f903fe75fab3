#include "daemon/engine/engine.hpp"

#include <algorithm>
#include <cmath>

#include "daemon/system/thread_placement.hpp"

namespace hapticd::daemon::engine {

namespace {
void bump(std::atomic<std::uint64_t>& counter) noexcept { rt::single_writer_add(counter, std::uint64_t{1}); }
}  // namespace

Engine::Engine(EngineOptions options, drivers::Device& device, rt::Clock& clock)
    : options_(std::move(options)),
      device_(device),
      clock_(clock),
      telemetry_(options_.telemetry_capacity),
      read_error_streak_(options_.read_error_limit),
      position_guard_(options_.position_rule) {
  if (device_.axes() > 1) {
    task_ = std::make_unique<TaskAxes>(
        device_.axes(), options_.kinematics.value_or(world::CartesianKinematics(device_.axes())),
        options_.position_rule);
    task_->gravity = options_.gravity;
    task_->workspace = options_.workspace;
  } else if (options_.workspace) {
    throw std::invalid_argument("a workspace wall needs a device with several axes");
  } else if (options_.gravity) {
    const auto* stage = std::get_if<world::StageWeight>(&*options_.gravity);
    if (stage == nullptr || stage->holding.size() != 1)
      throw std::invalid_argument("one axis takes gravity as the weight on that axis alone");
    axis_weight_ = stage->holding(0);
  }
}

Engine::~Engine() { stop(); }

const hapticd::daemon::system::RtSetupReport& Engine::start() {
  thread_ = std::thread([this] { thread_main(); });
  started_.wait(false, std::memory_order_acquire);
  return rt_report_;
}

void Engine::stop() noexcept {
  stop_requested_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

bool Engine::wait_finished(std::chrono::milliseconds timeout) const {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!finished()) {
    if (std::chrono::steady_clock::now() >= end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

std::optional<std::uint64_t> Engine::wait_applied(std::uint64_t seq,
                                                  std::chrono::milliseconds timeout) const {
  const auto applied = plans_.wait_applied(seq, timeout);
  if (!applied || applied->seq != seq) return std::nullopt;
  return applied->cycle;
}

EngineCounters Engine::counters() const noexcept {
  return {read_errors_.load(std::memory_order_relaxed),    write_errors_.load(std::memory_order_relaxed),
          torque_limited_.load(std::memory_order_relaxed), telemetry_.dropped(),
          faults_latched_.load(std::memory_order_relaxed), position_jumps_.load(std::memory_order_relaxed)};
}

std::optional<std::uint64_t> Engine::reset_stats(std::chrono::milliseconds timeout) {
  const std::uint64_t ticket = stats_reset_requested_.fetch_add(1, std::memory_order_acq_rel) + 1;
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (stats_reset_done_.load(std::memory_order_acquire) < ticket) {
    if (finished() || std::chrono::steady_clock::now() >= end) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  return stats_since_cycle();
}

void Engine::thread_main() {
  hapticd::daemon::system::name_this_thread("hapticd-rt");
  rt_report_ = hapticd::daemon::system::configure_realtime(options_.realtime);
  const bool fatal = rt_report_.fatal;
  started_.store(true, std::memory_order_release);
  started_.notify_all();
  if (fatal) {
    finished_.store(true, std::memory_order_release);
    return;
  }
  rt::PeriodicSchedule schedule(clock_, options_.period);
  schedule.start();
  t0_ = schedule.t0();
  while (!stop_requested_.load(std::memory_order_acquire)) {
    const rt::WakeUp wake = schedule.wait_next();
    run_cycle(wake);
    if (options_.duration && wake.deadline - t0_ >= *options_.duration) break;
  }
  finished_.store(true, std::memory_order_release);
}

void Engine::latch(FaultReason reason) noexcept {
  if (latch_.latch(reason)) bump(faults_latched_);
}

void Engine::latch_jump(const PositionJump& jump) noexcept {
  bump(position_jumps_);
  // Only the first reason latched is reported: the figures are stored only
  // when none is latched yet (an estop landing between here and the latch
  // wins, and these figures are then never read).
  if (latch_.latched()) return;
  jump_version_.write_begin();
  rt::seq_store(jump_step_, jump.step);
  rt::seq_store(jump_limit_, jump.limit);
  rt::seq_store(jump_interval_s_, jump.interval_s);
  rt::seq_store(jump_axis_, jump.axis);
  jump_version_.write_end();
  latch(FaultReason::encoder_jump);
}

std::optional<PositionJump> Engine::position_jump() const {
  if (latch_.reason() != FaultReason::encoder_jump) return std::nullopt;
  PositionJump jump;
  const bool consistent = jump_version_.read([&] {
    jump.step = rt::seq_load(jump_step_);
    jump.limit = rt::seq_load(jump_limit_);
    jump.interval_s = rt::seq_load(jump_interval_s_);
    jump.axis = rt::seq_load(jump_axis_);
  });
  if (!consistent) return std::nullopt;
  return jump;
}

std::string Engine::fault_description() const {
  const FaultReason reason = latch_.reason();
  if (reason == FaultReason::none) return {};
  if (const auto jump = position_jump()) return describe(*jump, options_.position_rule);
  return std::string(to_string(reason));
}

bool Engine::read_succeeded(drivers::IoResult read, TelemetrySample& sample) noexcept {
  if (read == drivers::IoResult::fault) {
    latch(FaultReason::device_fault);
    return false;
  }
  if (read == drivers::IoResult::error) {
    sample.flags |= flag_read_error;
    bump(read_errors_);
    if (read_error_streak_.record(true)) latch(FaultReason::read_error_streak);
    return false;
  }
  read_error_streak_.record(false);
  return true;
}

void Engine::note_write(drivers::IoResult write, TelemetrySample& sample) noexcept {
  if (write == drivers::IoResult::ok) return;
  bump(write_errors_);
  latch(write == drivers::IoResult::fault ? FaultReason::device_fault : FaultReason::write_error);
  sample.flags |= flag_fault_latched;  // the output did not reach the device
}

bool Engine::read_position(const rt::WakeUp& wake, TelemetrySample& sample, double& position) noexcept {
  drivers::Reading reading;
  if (!read_succeeded(device_.read(reading), sample)) return false;
  if (reading.stale) sample.flags |= flag_stale_position;
  if (!std::isfinite(reading.position)) {
    latch(FaultReason::non_finite_position);
    return false;
  }
  // Beside the finite-value guard: a step no device makes in this interval
  // is a fault of the encoder or the link, never motion. Zero output in this
  // very period; the recording keeps the reading, flagged. The rule sees the
  // device's own readings, so a new origin is no step.
  PositionJump jump;
  if (position_guard_.implausible(reading.position, std::chrono::duration<double>(wake.woke).count(), jump)) {
    last_position_ = reading.position - origin_;
    sample.flags |= flag_position_jump;
    latch_jump(jump);
    return false;
  }
  take_origin(wake.cycle, &reading.position);
  last_position_ = reading.position - origin_;  // the one subtraction: everything downstream is calibrated
  if (reset_pending_ && plan_ != nullptr) {
    world::reset(scene_, last_position_);
    reset_pending_ = false;
  }
  position = last_position_;
  return true;
}

void Engine::take_origin(std::uint64_t cycle, const double* raw) noexcept {
  OriginHandover::Pending request;
  if (!origins_.pending(request)) return;
  const bool usable = request.kind == OriginRequest::set_value || raw != nullptr;
  if (!usable) {
    if (cycle > request.valid_until_cycle) origins_.complete(false, cycle, origin_, origin_);
    return;
  }
  const double previous = origin_;
  origin_ = request.kind == OriginRequest::zero_here ? *raw : request.value;
  calibrated_ = true;
  // The scene restarts at equilibrium at the position now measured from the
  // new origin, as for a new plan: no torque step.
  reset_pending_ = true;
  origin_published_.store(origin_, std::memory_order_release);
  calibrated_published_.store(true, std::memory_order_release);
  origins_.complete(true, cycle, origin_, previous);
}

void Engine::preset_origin(double origin) noexcept {
  origin_ = origin;
  calibrated_ = true;
  origin_published_.store(origin, std::memory_order_release);
  calibrated_published_.store(true, std::memory_order_release);
}

std::uint64_t Engine::request_zero(std::chrono::milliseconds valid_for) noexcept {
  const double period_s = std::chrono::duration<double>(options_.period).count();
  const auto periods =
      static_cast<std::uint64_t>(std::chrono::duration<double>(valid_for).count() / period_s);
  const std::uint64_t ticket =
      origins_.request(OriginRequest::zero_here, 0.0, cycle() + std::max<std::uint64_t>(periods, 1) + 1);
  if (ticket != 0) waiting_ticket_ = ticket;
  return ticket;
}

std::optional<OriginOutcome> Engine::zero_here(std::chrono::milliseconds valid_for) {
  const std::uint64_t ticket = request_zero(valid_for);
  if (ticket == 0) return std::nullopt;  // the last one is still pending
  const auto end = std::chrono::steady_clock::now() + valid_for + std::chrono::seconds(2);
  for (;;) {
    if (const auto outcome = origins_.outcome(ticket)) return outcome;
    if (finished() || std::chrono::steady_clock::now() >= end) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
}

TelemetrySample Engine::begin_sample(const rt::WakeUp& wake) noexcept {
  cycle_.store(wake.cycle, std::memory_order_relaxed);
  TelemetrySample sample;
  sample.cycle = wake.cycle;
  sample.time_s = std::chrono::duration<double>(wake.deadline - t0_).count();
  sample.latency_s = std::chrono::duration<double>(wake.latency).count();
  return sample;
}

bool Engine::latch_at_wake(const rt::WakeUp& wake, bool& cleared) noexcept {
  const bool latched_before = latch_.latched();
  // The scene restarts at equilibrium at the next valid reading, so a step
  // across the clear cannot become torque: that reading is the new
  // reference, unchecked (the device's own clear may have moved it).
  cleared = was_latched_ && !latched_before;
  if (cleared) reset_pending_ = true;
  was_latched_ = latched_before;
  // An overrun streak is known at the wake-up: zero this period's output.
  if (options_.overrun_limit != 0 && wake.overrun && stats_.overrun_streak() + 1 >= options_.overrun_limit) {
    latch(FaultReason::overrun_streak);
  }
  return latched_before;
}

bool Engine::take_plan(std::uint64_t cycle) noexcept {
  const LoopPlan* plan = plans_.acquire(cycle);
  if (plan == plan_) return false;
  plan_ = plan;
  reset_pending_ = true;
  return true;
}

void Engine::run_cycle(const rt::WakeUp& wake) noexcept {
  if (task_) {
    run_task_cycle(wake);  // several axes: task_cycle.cpp
    return;
  }
  TelemetrySample sample = begin_sample(wake);
  // A new plan, or the end of a latched fault, restarts the scene at
  // equilibrium at the position measured in this very cycle (below, before
  // the first step): no torque step, even before the first valid reading or
  // when the device moved since the last one.
  if (take_plan(wake.cycle)) scene_ = plan_->scene;
  bool cleared = false;
  const bool latched_before = latch_at_wake(wake, cleared);
  if (cleared) position_guard_.forget();

  double position = 0.0;
  const bool position_valid = read_position(wake, sample, position);
  if (!position_valid) take_origin(wake.cycle, nullptr);  // a set value needs no reading; a zero expires
  sample.position = last_position_;
  // [device] require_calibration: nothing renders until an origin is in force.
  const bool uncalibrated = options_.require_calibration && !calibrated_;
  if (uncalibrated) sample.flags |= flag_uncalibrated;

  // A fault.clear landing after the latch check at the top of this cycle
  // takes effect next cycle, where it restarts the scene at the measured
  // position: computing a command now would use the stale scene state.
  const bool output_allowed = !latched_before && !latch_.latched() && !uncalibrated;
  double command = 0.0;
  axis_feedforward_ = 0.0;
  if (position_valid && plan_ != nullptr && output_allowed) {
    command = world::step(scene_, position);
    if (!std::isfinite(command)) latch(FaultReason::non_finite_command);
    axis_feedforward_ = axis_weight_.value_or(0.0);  // [gravity]: after the scene
  }
  // One read decides both the output and the sample's latched flag: an estop
  // from the control thread landing after it takes effect next cycle, and
  // this sample must not say "latched" beside the torque it did send.
  const bool output_latched = latched_before || latch_.latched();
  double applied = 0.0;
  if (position_valid && plan_ != nullptr && !output_latched && !uncalibrated) {
    const double wanted = command + axis_feedforward_;
    applied = limit_output(wanted, plan_->torque_limit);
    if (applied != wanted) {
      sample.flags |= flag_torque_limited;
      bump(torque_limited_);
    }
  }
  note_write(device_.write(applied), sample);
  sample.command = command;
  sample.applied = applied;
  finish_sample(wake, sample, output_latched);
}

void Engine::finish_sample(const rt::WakeUp& wake, TelemetrySample& sample, bool output_latched) noexcept {
  if (wake.overrun) sample.flags |= flag_overrun;
  if (const auto requested = stats_reset_requested_.load(std::memory_order_acquire);
      requested != stats_reset_done_.load(std::memory_order_relaxed)) {
    stats_.reset();  // this cycle is the first one counted afresh
    stats_since_cycle_.store(wake.cycle, std::memory_order_relaxed);
    stats_reset_done_.store(requested, std::memory_order_release);
  }
  stats_.record(wake, clock_.now() - wake.woke);
  if (output_latched) sample.flags |= flag_fault_latched;
  if (plan_ != nullptr && plan_->unstable_forced) sample.flags |= flag_unstable_forced;

  sample.compute_s = std::chrono::duration<double>(clock_.now() - wake.woke).count();
  if (task_) {
    task_channels(sample);
  } else if (plan_ != nullptr) {
    // [gravity]'s feedforward first, as on several axes, then the scene's.
    const std::size_t first = axis_weight_ ? 1 : 0;
    if (axis_weight_) sample.channels[0] = axis_feedforward_;
    const std::size_t n = world::channel_count(scene_);
    sample.channel_count = static_cast<std::uint32_t>(first + n);
    world::channels(scene_, std::span<double>(sample.channels.data() + first, n));
  }
  if (options_.wait_for_telemetry_space) {
    // The recorder keeps draining while the engine stops, so keep waiting a
    // little even after a stop request: this cycle ran, its sample counts.
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (telemetry_.size() >= telemetry_.capacity()) {
      if (stop_requested_.load(std::memory_order_relaxed) && std::chrono::steady_clock::now() > give_up)
        break;
      std::this_thread::yield();
    }
  }
  telemetry_.try_push(sample);
}

}  // namespace hapticd::daemon::engine
