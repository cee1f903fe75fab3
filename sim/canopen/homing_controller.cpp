#include "sim/canopen/homing_controller.hpp"

#include <algorithm>
#include <cmath>

namespace hapticd::drivers::canopen::sim {

namespace {

constexpr std::uint16_t operation_start = 1U << 4;  // controlword, homing mode
constexpr std::uint16_t halt = 1U << 8;
constexpr std::uint16_t target_reached = 1U << 10;  // statusword
constexpr std::uint16_t homing_attained = 1U << 12;
constexpr std::uint16_t homing_error = 1U << 13;

constexpr std::int8_t on_negative_limit = 17;
constexpr std::int8_t on_positive_limit = 18;
constexpr std::int8_t on_position_old = 35;
constexpr std::int8_t on_position = 37;

/// At rest: below this speed (SI) the drive counts as stopped.
constexpr double at_rest = 1e-3;

}  // namespace

bool HomingController::has_method(std::int8_t m) const noexcept {
  if (m == on_position || m == on_position_old) return true;
  if (m == on_negative_limit) return switches_.negative.has_value();
  if (m == on_positive_limit) return switches_.positive.has_value();
  return false;
}

bool HomingController::negative_active(double x) const noexcept {
  return switches_.negative && x <= *switches_.negative;
}

bool HomingController::positive_active(double x) const noexcept {
  return switches_.positive && x >= *switches_.positive;
}

std::uint32_t HomingController::digital_inputs(double x) const noexcept {
  return (negative_active(x) ? 1U : 0U) | (positive_active(x) ? 2U : 0U);
}

void HomingController::on_controlword(std::uint16_t previous, std::uint16_t cw, double position) noexcept {
  (void)position;
  const bool rise = (cw & operation_start) != 0 && (previous & operation_start) == 0;
  const bool fall = (cw & operation_start) == 0 && (previous & operation_start) != 0;
  if ((cw & halt) != 0 || fall) {
    interrupt();
    return;
  }
  if (!rise) return;
  started_ = true;
  attained_before_ = false;
  home_.reset();
  stage_ = Stage::starting;  // the method is read at the next SYNC (0x6098 as it is then)
}

void HomingController::interrupt() noexcept {
  if (stage_ == Stage::starting || stage_ == Stage::searching || stage_ == Stage::leaving)
    stage_ = Stage::idle;
  target_ = 0.0;
}

void HomingController::found_home(double position) noexcept {
  home_ = position;
  stage_ = Stage::stopping;
  target_ = 0.0;
}

double HomingController::run_velocity(double velocity, const HomingObjects& o, double period_s) noexcept {
  const double dv = o.acceleration * period_s;
  reference_ += std::clamp(target_ - reference_, -dv, dv);
  return std::clamp(gain_ * (reference_ - velocity), -o.max_force, o.max_force);
}

void HomingController::begin(double x, const HomingObjects& o) noexcept {
  method_ = o.method;
  speed_zero_ = o.speed_zero;
  if (!has_method(method_)) {
    stage_ = Stage::error;
    return;
  }
  if (method_ == on_position || method_ == on_position_old) {
    home_ = x;  // no motion: the home is where the drive stands
    stage_ = Stage::done;
    attained_before_ = true;
    return;
  }
  const double toward = method_ == on_negative_limit ? -1.0 : 1.0;
  const bool on_switch = method_ == on_negative_limit ? negative_active(x) : positive_active(x);
  // Already on the switch: only the way back off it, at the zero search speed.
  stage_ = on_switch ? Stage::leaving : Stage::searching;
  target_ = on_switch ? -toward * o.speed_zero : toward * o.speed_switch;
}

void HomingController::follow_switch(double x) noexcept {
  const bool negative = method_ == on_negative_limit;
  const bool own = negative ? negative_active(x) : positive_active(x);
  const bool other = negative ? positive_active(x) : negative_active(x);
  if (stage_ == Stage::searching && other) {
    stage_ = Stage::error;  // the other side's switch: wrong direction or wiring
    target_ = 0.0;
  } else if (stage_ == Stage::searching && own) {
    stage_ = Stage::leaving;
    target_ = (negative ? 1.0 : -1.0) * speed_zero_;
  } else if (stage_ == Stage::leaving && !own) {
    found_home(x);  // the switch's edge
  }
}

double HomingController::step(double x, double v, const HomingObjects& o, double period_s) noexcept {
  if (stage_ == Stage::starting) begin(x, o);
  if (stage_ == Stage::searching || stage_ == Stage::leaving) follow_switch(x);
  if (stage_ == Stage::stopping && reference_ == 0.0 && std::abs(v) < at_rest) {
    stage_ = Stage::done;
    attained_before_ = true;
  }
  if (!started_) return 0.0;
  return run_velocity(v, o, period_s);  // moving, stopping, or holding still once done or interrupted
}

std::uint16_t HomingController::status_bits(double velocity) const noexcept {
  switch (stage_) {
    case Stage::starting:
    case Stage::searching:
    case Stage::leaving:
      return 0;
    case Stage::stopping:
      return homing_attained;
    case Stage::done:
      return homing_attained | target_reached;
    case Stage::error:
      return homing_error | (std::abs(velocity) < at_rest ? target_reached : 0U);
    case Stage::idle:
      break;
  }
  return target_reached | (attained_before_ ? homing_attained : 0U);
}

std::optional<double> HomingController::take_home() noexcept {
  const auto home = home_;
  home_.reset();
  return home;
}

}  // namespace hapticd::drivers::canopen::sim
