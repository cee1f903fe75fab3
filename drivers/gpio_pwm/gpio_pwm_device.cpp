#include "drivers/gpio_pwm/gpio_pwm_device.hpp"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <thread>

namespace hapticd::drivers::gpio_pwm {
namespace {

std::string line_words(const GpioChip& chip, unsigned offset) {
  const LineInfo info = chip.info(offset);
  return info.name.empty() ? "offset " + std::to_string(offset)
                           : info.name + " (offset " + std::to_string(offset) + ")";
}

std::string format_hz(std::uint64_t period_ns) {
  const double hz = 1e9 / static_cast<double>(period_ns);
  return hz >= 1000.0 ? std::to_string(std::llround(hz / 1000.0)) + " kHz"
                      : std::to_string(std::llround(hz)) + " Hz";
}

}  // namespace

GpioPwmDevice::GpioPwmDevice(GpioPwmConfig config) : config_(std::move(config)) {
  validate(config_);
  scaling_ =
      DriveScaling{config_.force_at_full_duty, config_.max_duty, config_.deadband, config_.pwm_period_ns};
  position_per_count_ = config_.metres_or_radians_per_count();
  active_low_[enable_out] = config_.enable_line.active_low;
  active_low_[direction_out] = config_.direction_line.active_low;
  active_low_[brake_out] = config_.brake_line.active_low;
  active_low_[pump_out] = config_.charge_pump_line.active_low;
}

GpioPwmDevice::~GpioPwmDevice() { close(); }

void GpioPwmDevice::configure(const LoopContext& loop) {
  std::lock_guard lock(lifecycle_);
  if (!(loop.period_s > 0.0)) throw DeviceError("gpio-pwm: the loop period must be > 0 s", "period");
  stop_ = loop.stop;
  try {
    chip_ = std::make_unique<GpioChip>(config_.chip);
    request_outputs();
    open_reset_and_fault();
    pwm_ = std::make_unique<PwmOutput>(PwmOutput::Settings{config_.pwm_chip, config_.pwm_channel,
                                                           config_.pwm_period_ns, config_.pwm_inversed,
                                                           config_.export_timeout_s, stop_});
    const std::string position_words = open_position();
    description_ = "gpio-pwm on " + chip_->describe() + ", PWM " + pwm_->channel_dir() + " at " +
                   format_hz(config_.pwm_period_ns) + ", " + position_words + "; " +
                   (config_.charge_pump_line.configured()
                        ? "charge pump on " + line_words(*chip_, output_offsets_[pump_out])
                        : "NO charge pump: nothing stops the motor if hapticd is killed");
    fault_cause_.store(FaultCause::none);
    enabled_ = false;
  } catch (...) {
    release();
    throw;
  }
}

// One request for every output: enable inactive, direction "positive",
// brake applied, pump low.
void GpioPwmDevice::request_outputs() {
  std::vector<unsigned> offsets;
  std::vector<int> initial;
  std::vector<std::string> keys;
  const auto add_output = [&](Output role, const LineSpec& spec, const char* key, bool logical) {
    if (!spec.configured()) return;
    slot_[role] = static_cast<int>(offsets.size());
    output_offsets_[role] = chip_->resolve(spec, key);
    offsets.push_back(output_offsets_[role]);
    initial.push_back(logical != active_low_[role] ? 1 : 0);
    keys.emplace_back(key);
  };
  add_output(enable_out, config_.enable_line, "enable_line", false);
  add_output(direction_out, config_.direction_line, "direction_line", true);
  add_output(brake_out, config_.brake_line, "brake_line", true);
  add_output(pump_out, config_.charge_pump_line, "charge_pump_line", false);
  used_outputs_ = offsets.size();
  for (std::size_t i = 0; i < used_outputs_; ++i) levels_[i] = initial[i];
  outputs_ = std::make_unique<OutputLines>(*chip_, offsets, initial, config_.consumer, keys);
  direction_positive_ = true;
  pump_ = false;
}

// The reset line (inactive) and the fault line; an active fault gets one
// reset pulse, then refuses the start.
void GpioPwmDevice::open_reset_and_fault() {
  if (config_.reset_line.configured()) {
    const unsigned offset[] = {chip_->resolve(config_.reset_line, "reset_line")};
    const int inactive[] = {config_.reset_line.active_low ? 1 : 0};
    const std::string key[] = {"reset_line"};
    reset_ = std::make_unique<OutputLines>(*chip_, offset, inactive, config_.consumer, key);
  }
  if (!config_.fault_line.configured()) return;
  const unsigned offset = chip_->resolve(config_.fault_line, "fault_line");
  fault_ = std::make_unique<EdgeInput>(*chip_, offset, config_.consumer, "fault_line");
  fault_reason_ = "fault line " + line_words(*chip_, offset) + " active";
  if (fault_line_active() && reset_) pulse_reset();
  if (fault_line_active()) {
    throw TransportError("fault_line",
                         "fault_line: " + fault_reason_ + (reset_ ? " after a reset pulse" : "") +
                             ": the amplifier reports a fault; clear its cause and start again");
  }
}

// The kernel counter, or the quadrature thread on two lines; returns the
// words for the description.
std::string GpioPwmDevice::open_position() {
  if (config_.position_source() == PositionSource::counter) {
    counter_ = std::make_unique<CounterInput>(config_.counter, config_.counter_count);
    std::uint64_t raw = 0;
    if (const int error = counter_->read(raw); error != 0) {
      throw TransportError(
          "counter", "counter: reading " + counter_->path() + " failed: " + system_reason(error), error);
    }
    unwrap_.emplace(counter_->ceiling(), raw);
    return "position from " + counter_->path() +
           (counter_->function().empty() ? "" : " (" + counter_->function() + ")");
  }
  const unsigned a = chip_->resolve(config_.encoder_a_line, "encoder_a_line");
  const unsigned b = chip_->resolve(config_.encoder_b_line, "encoder_b_line");
  encoder_a_ = std::make_unique<EdgeInput>(*chip_, a, config_.consumer, "encoder_a_line");
  encoder_b_ = std::make_unique<EdgeInput>(*chip_, b, config_.consumer, "encoder_b_line");
  quadrature_ =
      std::make_unique<QuadratureReader>(*encoder_a_, *encoder_b_, config_.encoder_a_line.active_low,
                                         config_.encoder_b_line.active_low, config_.reverse);
  quadrature_->start();
  return "position decoded from lines " + std::to_string(a) + " and " + std::to_string(b) + " (at most " +
         std::to_string(static_cast<long long>(max_count_rate(1e-3))) +
         " counts/s if the decoding thread can be held up 1 ms)";
}

void GpioPwmDevice::enable() {
  std::lock_guard lock(lifecycle_);
  if (enabled_) return;
  if (const int error = pwm_->off(); error != 0) {
    throw TransportError("pwm_channel",
                         std::string("gpio-pwm: setting duty 0 failed: ") + system_reason(error), error);
  }
  // The enable line goes active with the first write(), in the same ioctl
  // as the first charge-pump edge: every output commit is one period's
  // (the simulated board counts one period per commit), and the power stage
  // is never on before the loop drives it.
  enabled_ = true;
}

bool GpioPwmDevice::fault_line_active() {
  const int level = fault_->level();
  if (level < 0) {
    throw TransportError(
        "fault_line", std::string("fault_line: reading its level failed: ") + system_reason(-level), -level);
  }
  return (level != 0) != config_.fault_line.active_low;
}

void GpioPwmDevice::pulse_reset() {
  const bool low = config_.reset_line.active_low;
  const int active[] = {low ? 0 : 1};
  const int inactive[] = {low ? 1 : 0};
  if (const int error = reset_->set(active); error != 0) {
    throw TransportError("reset_line", std::string("reset_line: setting it failed: ") + system_reason(error),
                         error);
  }
  // The pulse in slices: a stop ends it early, the line released all the same.
  const bool whole =
      sleep_unless_stopped(stop_, std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(config_.reset_pulse_s)));
  if (const int error = reset_->set(inactive); error != 0) {
    throw TransportError("reset_line",
                         std::string("reset_line: releasing it failed: ") + system_reason(error), error);
  }
  if (!whole) throw StopRequested(abandoned("gpio-pwm: the reset pulse on reset_line"));
  // The amplifier's fault output follows the reset: give it the pulse's
  // width again (bounded) to go inactive.
  if (fault_) {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration<double>(std::max(config_.reset_pulse_s, 0.001));
    while (fault_line_active() && std::chrono::steady_clock::now() < deadline) {
      throw_if_stopped(stop_, "gpio-pwm: waiting for fault_line to go inactive after the reset pulse");
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
  }
}

std::string GpioPwmDevice::clear_fault() {
  std::lock_guard lock(lifecycle_);
  const FaultCause cause = fault_cause_.load(std::memory_order_acquire);
  if (cause == FaultCause::none) return "";
  if (cause == FaultCause::counter_implausible) {
    // Nothing on the board to reset: the next read() checks the count again
    // (and latches again if it is still implausible).
    const std::string words = counter_fault_words();
    fault_cause_.store(FaultCause::none, std::memory_order_release);
    return words + ": cleared, the next period reads the count again";
  }
  if (reset_) pulse_reset();
  if (fault_ && fault_line_active()) {
    throw TransportError("fault_line", fault_reason_ + (reset_ ? " still, after a reset pulse" : " still") +
                                           ": the amplifier's fault persists");
  }
  fault_cause_.store(FaultCause::none, std::memory_order_release);
  const long long pulse_ms = std::llround(config_.reset_pulse_s * 1000.0);
  return fault_reason_ + (reset_ ? ": cleared by a " + std::to_string(pulse_ms) + " ms reset pulse"
                                 : ": cleared, the line reads inactive again");
}

void GpioPwmDevice::latch(FaultCause cause) noexcept {
  FaultCause expected = FaultCause::none;
  fault_cause_.compare_exchange_strong(expected, cause, std::memory_order_acq_rel);
}

std::string GpioPwmDevice::counter_fault_words() const {
  const std::uint64_t raw = implausible_raw_.load(std::memory_order_relaxed);
  const std::uint64_t last = last_good_raw_.load(std::memory_order_relaxed);
  const std::string where = "counter " + (counter_ ? counter_->path() : config_.counter);
  const std::uint64_t ceiling = counter_ ? counter_->ceiling() : 0;
  if (counter_ && raw > ceiling)
    return where + " read " + std::to_string(raw) + ", above its ceiling " + std::to_string(ceiling);
  return where + " read " + std::to_string(raw) + " after " + std::to_string(last) +
         ": a move that takes the position past 64 bits";
}

bool GpioPwmDevice::set_outputs(bool enable, bool brake) noexcept {
  pump_ = !pump_;
  const auto put = [this](Output role, bool logical) {
    if (slot_[role] >= 0)
      levels_[static_cast<std::size_t>(slot_[role])] = (logical != active_low_[role]) ? 1 : 0;
  };
  put(enable_out, enable);
  put(direction_out, direction_positive_);
  put(brake_out, brake);
  put(pump_out, pump_);
  if (const int error = outputs_->set(std::span<const int>(levels_.data(), used_outputs_)); error != 0) {
    last_errno_.store(error, std::memory_order_relaxed);
    return false;
  }
  return true;
}

bool GpioPwmDevice::drive_off() noexcept {
  bool written = true;
  if (const int error = pwm_->off(); error != 0) {
    last_errno_.store(error, std::memory_order_relaxed);
    written = false;
  }
  return set_outputs(false, true) && written;
}

IoResult GpioPwmDevice::read(Reading& out) noexcept {
  if (fault_ && fault_->pending() != 0) {  // one poll() per period; a read only when an edge came
    std::array<EdgeEvent, kernel_event_queue_depth> events;
    const int n = fault_->read(events);
    if (n < 0) {
      last_errno_.store(-n, std::memory_order_relaxed);
      return IoResult::error;
    }
    for (int i = 0; i < n; ++i) {
      const bool active = events[static_cast<std::size_t>(i)].rising != config_.fault_line.active_low;
      if (active) latch(FaultCause::fault_line);
    }
  }
  if (latched()) return IoResult::fault;
  std::int64_t counts = 0;
  if (counter_) {
    std::uint64_t raw = 0;
    if (const int error = counter_->read(raw); error != 0) {
      last_errno_.store(error, std::memory_order_relaxed);
      return IoResult::error;
    }
    if (!unwrap_->update(raw)) {
      // Above the ceiling, or a jump past 64 bits: not a count this counter
      // can give. The figures for health(), the output zero from now on.
      counter_range_errors_.fetch_add(1, std::memory_order_relaxed);
      implausible_raw_.store(raw, std::memory_order_relaxed);
      last_good_raw_.store(unwrap_->last_raw(), std::memory_order_relaxed);
      latch(FaultCause::counter_implausible);
      return IoResult::fault;
    }
    counts = config_.reverse ? -unwrap_->position() : unwrap_->position();
  } else {
    counts = quadrature_->count();  // the reader applies `reverse`
  }
  out.position = static_cast<double>(counts) * position_per_count_;
  return IoResult::ok;
}

IoResult GpioPwmDevice::write(double force) noexcept {
  if (latched()) {
    const bool off = drive_off();
    // drive_off() is a PWM write and an ioctl: a fault clear can land
    // meanwhile, and a stale "fault" would latch the engine again after it
    // cleared (seen in 2 of 5 end-to-end runs under load). The output is off
    // in this period either way, unless a write failed: then error.
    if (latched()) return IoResult::fault;
    return off ? IoResult::ok : IoResult::error;
  }
  const DriveResult drive = split_force(force, scaling_, direction_positive_);
  direction_positive_ = drive.command.positive;
  bool written = drive.valid;
  // The duty first, then the lines (direction, enable, pump) in one ioctl:
  // a sign change runs the new duty with the old direction for the few
  // microseconds between the two calls.
  if (const int error = pwm_->set_duty(drive.command.duty_ns); error != 0) {
    last_errno_.store(error, std::memory_order_relaxed);
    written = false;
  }
  if (!set_outputs(true, false)) written = false;
  return written ? IoResult::ok : IoResult::error;
}

// The framework calls it after enable() (or a failed one), never twice in
// a row; it switches off whatever enable() and the writes reached.
void GpioPwmDevice::disable() noexcept {
  std::lock_guard lock(lifecycle_);
  enabled_ = false;
  if (!pwm_ || !outputs_) return;  // a failed configure released them
  if (const int error = pwm_->off(); error != 0) last_errno_.store(error, std::memory_order_relaxed);
  // Enable inactive and the brake on; the pump keeps its level and stops.
  const auto put = [this](Output role, bool logical) {
    if (slot_[role] >= 0)
      levels_[static_cast<std::size_t>(slot_[role])] = (logical != active_low_[role]) ? 1 : 0;
  };
  put(enable_out, false);
  put(brake_out, true);
  if (const int error = outputs_->set(std::span<const int>(levels_.data(), used_outputs_)); error != 0)
    last_errno_.store(error, std::memory_order_relaxed);
}

// The framework has called disable() first.
void GpioPwmDevice::close() noexcept {
  std::lock_guard lock(lifecycle_);
  release();
}

void GpioPwmDevice::release() noexcept {
  if (quadrature_) quadrature_->stop();
  quadrature_.reset();
  encoder_b_.reset();
  encoder_a_.reset();
  unwrap_.reset();
  counter_.reset();
  pwm_.reset();
  fault_.reset();
  reset_.reset();
  outputs_.reset();
  chip_.reset();
  slot_ = {-1, -1, -1, -1};
  output_offsets_ = {};
  used_outputs_ = 0;
}

DeviceModel GpioPwmDevice::model() const {
  DeviceModel m;
  m.motion = config_.motion;
  m.effective_mass = config_.mass;
  m.viscous_damping = config_.damping;
  m.position_resolution = position_per_count_;
  m.delay_periods = 0;  // the duty written in period n drives the bridge from then on
  m.source = "config";
  m.description =
      std::string(to_string(config_.motion)) + ", H-bridge on " + config_.pwm_chip + "/pwm" +
      std::to_string(config_.pwm_channel) +
      (config_.position_source() == PositionSource::counter ? ", kernel counter" : ", quadrature lines");
  return m;
}

DeviceHealth GpioPwmDevice::health() const {
  std::lock_guard lock(lifecycle_);
  DeviceHealth s;
  const FaultCause cause = fault_cause_.load(std::memory_order_acquire);
  s.faulted = cause != FaultCause::none;
  if (cause == FaultCause::fault_line) s.fault_reason = fault_reason_;
  if (cause == FaultCause::counter_implausible) s.fault_reason = counter_fault_words();
  if (const int e = last_errno_.load(); e != 0) s.last_error = system_reason(e);
  s.counters.push_back({"counter_range_errors", counter_range_errors_.load()});
  if (pwm_) s.counters.push_back({"pwm_writes", pwm_->writes()});
  if (quadrature_) {
    const auto q = quadrature_->stats();
    s.counters.push_back({"encoder_edges", q.edges});
    s.counters.push_back({"encoder_invalid_transitions", q.invalid_transitions});
    s.counters.push_back({"encoder_lost_edges", q.lost_edges});
    s.counters.push_back({"encoder_full_queue_reads", q.full_reads});
  }
  return s;
}

std::string GpioPwmDevice::description() const {
  std::lock_guard lock(lifecycle_);
  return description_;
}

}  // namespace hapticd::drivers::gpio_pwm
