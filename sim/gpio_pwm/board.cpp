#include "sim/gpio_pwm/board.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hapticd::drivers::gpio_pwm::sim {

SimulatorPlant::SimulatorPlant(std::unique_ptr<simulation::PlantSimulator> simulator)
    : simulator_(std::move(simulator)), resolution_(simulator_->config().resolution()) {
  sense();
}

void SimulatorPlant::sense() {
  // A failed read (an injected read error) keeps the last count, as an
  // encoder interface that missed a sample would.
  double position = 0.0;
  if (simulator_->sense(position) == IoResult::ok && std::isfinite(position)) sensed_ = position;
}

void SimulatorPlant::step(double motor_force) {
  simulator_->step(motor_force);
  sense();
}

// sense() quantizes to whole counts: the division gives the count to rounding.
std::int64_t SimulatorPlant::encoder_counts() const { return std::llround(sensed_ / resolution_); }

double SimulatorPlant::position() const { return sensed_; }

SimulatedBoard::SimulatedBoard(UmockdevGpioTestbed& gpio, SimulatedPwmChip& pwm, SimulatedCounter* counter,
                               BoardConfig config, std::unique_ptr<BoardPlant> plant)
    : gpio_(gpio),
      pwm_(pwm),
      counter_(counter),
      config_(config),
      plant_(std::move(plant)),
      amplifier_(config.amplifier),
      encoder_(0) {
  const BoardWiring& w = config_.wiring;
  if (counter_ == nullptr && (!w.encoder_a || !w.encoder_b)) {
    throw std::invalid_argument(
        "SimulatedBoard: no counter and no encoder lines: nowhere to put the position");
  }
  // Rest state of the position outputs before the driver looks.
  counts_ = plant_->encoder_counts();
  if (config_.encoder_reverse) counts_ = -counts_;
  if (counter_ != nullptr) counter_->set_position(counts_);
  if (w.encoder_a && w.encoder_b) {
    encoder_ = QuadratureEncoder(counts_);
    gpio_.drive_input(*w.encoder_a, encoder_.level(EncoderLine::a) != w.encoder_a_active_low, 0);
    gpio_.drive_input(*w.encoder_b, encoder_.level(EncoderLine::b) != w.encoder_b_active_low, 0);
  }
  if (w.fault) gpio_.drive_input(*w.fault, w.fault_active_low, 0);  // inactive
  gpio_.set_values_observer([this](RequestId request) { on_values(request); });
}

SimulatedBoard::~SimulatedBoard() { gpio_.set_values_observer(nullptr); }

bool SimulatedBoard::logical(unsigned offset, bool active_low) {
  return gpio_.with_chip([offset](GpioChipModel& c) { return c.physical_level(offset); }) != active_low;
}

void SimulatedBoard::on_values(RequestId request) {
  const BoardWiring& w = config_.wiring;
  const auto offsets = gpio_.with_chip([request](GpioChipModel& c) {
    const LineRequest* r = c.request(request);
    return r == nullptr ? std::vector<unsigned>{} : r->offsets;
  });
  const auto holds = [&offsets](std::optional<unsigned> line) {
    return line && std::find(offsets.begin(), offsets.end(), *line) != offsets.end();
  };
  if (holds(w.direction) && before_period_) before_period_();
  std::lock_guard lock(mutex_);
  if (holds(w.reset)) {
    const bool had_fault = amplifier_.fault();
    amplifier_.set_reset(logical(*w.reset, w.reset_active_low));
    if (had_fault && !amplifier_.fault()) drive_fault(false);
  }
  if (!holds(w.direction)) return;
  // The period's commit: take the lines and the PWM channel as the driver left them.
  AmplifierInputs in;
  in.enable = logical(w.enable, w.enable_active_low);
  in.direction_positive = logical(w.direction, w.direction_active_low);
  in.brake = w.brake && logical(*w.brake, w.brake_active_low);
  in.charge_pump = w.charge_pump && logical(*w.charge_pump, false);
  const double high =
      pwm_.exported(w.pwm_channel) ? PwmChannelModel(pwm_.state(w.pwm_channel)).high_fraction() : 0.0;
  const bool pwm_on = pwm_.exported(w.pwm_channel) && pwm_.state(w.pwm_channel).enabled;
  in.pwm_active_fraction = !pwm_on ? 0.0 : (w.pwm_input_active_low ? 1.0 - high : high);
  step_period(in);
}

void SimulatedBoard::step_period(const AmplifierInputs& in) {
  last_inputs_ = in;
  const double force = amplifier_.step(in);
  plant_->step(force);
  const double position = plant_->position();
  std::int64_t counts = plant_->encoder_counts();
  if (config_.encoder_reverse) counts = -counts;
  const auto period_ns = static_cast<std::uint64_t>(std::llround(config_.period_s * 1e9));
  publish_position(counts, period_ * period_ns, (period_ + 1) * period_ns);
  BoardPeriod p;
  p.index = period_;
  p.enable = in.enable;
  p.direction_positive = in.direction_positive;
  p.brake = in.brake;
  p.charge_pump = in.charge_pump;
  p.pwm_fraction = in.pwm_active_fraction;
  p.motor_force = force;
  p.powered = amplifier_.powered();
  p.position = position;
  p.counts = counts;
  history_.push_back(p);
  ++period_;
}

void SimulatedBoard::publish_position(std::int64_t counts, std::uint64_t from_ns, std::uint64_t to_ns) {
  counts_ = counts;
  if (counter_ != nullptr) counter_->set_position(counts);
  const BoardWiring& w = config_.wiring;
  if (!w.encoder_a || !w.encoder_b) return;
  std::vector<EncoderEdge> edges;
  encoder_.move_to(counts, from_ns, to_ns, edges);
  for (const EncoderEdge& e : edges) {
    const bool a = e.line == EncoderLine::a;
    gpio_.drive_input(a ? *w.encoder_a : *w.encoder_b,
                      e.level != (a ? w.encoder_a_active_low : w.encoder_b_active_low), e.timestamp_ns);
  }
}

void SimulatedBoard::drive_fault(bool active) {
  const BoardWiring& w = config_.wiring;
  if (!w.fault) return;
  const auto period_ns = static_cast<std::uint64_t>(std::llround(config_.period_s * 1e9));
  gpio_.drive_input(*w.fault, active != w.fault_active_low, period_ * period_ns);
}

void SimulatedBoard::trip(const std::string& reason) {
  std::lock_guard lock(mutex_);
  amplifier_.trip(reason);
  drive_fault(true);
}

void SimulatedBoard::set_before_period(std::function<void()> hook) { before_period_ = std::move(hook); }

void SimulatedBoard::advance_idle(unsigned periods) {
  std::lock_guard lock(mutex_);
  for (unsigned i = 0; i < periods; ++i) step_period(last_inputs_);
}

std::vector<BoardPeriod> SimulatedBoard::history() const {
  std::lock_guard lock(mutex_);
  return history_;
}
std::uint64_t SimulatedBoard::periods() const {
  std::lock_guard lock(mutex_);
  return period_;
}
bool SimulatedBoard::fault() const {
  std::lock_guard lock(mutex_);
  return amplifier_.fault();
}
std::string SimulatedBoard::fault_reason() const {
  std::lock_guard lock(mutex_);
  return amplifier_.fault_reason();
}
std::uint64_t SimulatedBoard::resets() const {
  std::lock_guard lock(mutex_);
  return amplifier_.resets();
}
bool SimulatedBoard::watchdog_expired() const {
  std::lock_guard lock(mutex_);
  return amplifier_.watchdog_expired();
}
std::int64_t SimulatedBoard::counts() const {
  std::lock_guard lock(mutex_);
  return counts_;
}

}  // namespace hapticd::drivers::gpio_pwm::sim
