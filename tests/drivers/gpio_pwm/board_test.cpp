// The simulated board in lockstep with the driver's transport, everything
// through the kernel interfaces as the driver sees them: libgpiod on the
// umockdev chip, the PWM and counter files of the testbed's /sys.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <functional>
#include <numbers>
#include <thread>

#include "drivers/gpio_pwm/gpio_lines.hpp"
#include "drivers/gpio_pwm/sysfs_attributes.hpp"
#include "sim/gpio_pwm/board.hpp"

namespace hapticd::drivers::gpio_pwm::sim::board_test {
namespace {

bool eventually(const std::function<bool()>& condition) {
  for (int i = 0; i < 5000; ++i) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return condition();
}

constexpr double period = 1e-3;
constexpr double counts_per_rad = 16384.0 / (2.0 * std::numbers::pi);

// A free inertia, integrated exactly for a force held over the period.
class Inertia final : public BoardPlant {
 public:
  Inertia(double inertia, double step_s) : j_(inertia), t_(step_s) {}
  void step(double force) override {
    x_ += v_ * t_ + force * t_ * t_ / (2.0 * j_);
    v_ += force * t_ / j_;
  }
  std::int64_t encoder_counts() const override {
    return static_cast<std::int64_t>(std::floor(x_ * counts_per_rad));
  }
  double position() const override { return x_; }
  // For the reference runs in the tests.
  double advance(double force) {
    step(force);
    return x_;
  }

 private:
  double j_, t_, x_ = 0.0, v_ = 0.0;
};

GpioChipSpec chip_spec() {
  GpioChipSpec s;
  s.line_names = {"EN", "DIR", "FAULT", "ENC_A", "ENC_B", "PUMP", "BRAKE", "RESET"};
  return s;
}

BoardConfig board_config(bool counter) {
  BoardConfig c;
  c.wiring.enable = 0;
  c.wiring.direction = 1;
  c.wiring.fault = 2;
  c.wiring.fault_active_low = true;  // open-drain nFAULT
  c.wiring.charge_pump = 5;
  c.wiring.brake = 6;
  c.wiring.reset = 7;
  if (!counter) {
    c.wiring.encoder_a = 3;
    c.wiring.encoder_b = 4;
  }
  c.amplifier = {0.8, 0};
  c.period_s = period;
  return c;
}

class BoardLockstep : public ::testing::Test {
 protected:
  UmockdevGpioTestbed gpio_{chip_spec()};
  SimulatedPwmChip pwm_chip_{gpio_.root_dir(), "/sys/class/pwm/pwmchip0", 2};
  SimulatedCounter counter_{gpio_.root_dir(), "/sys/bus/counter/devices/counter0", 0, 0xFFFFFFFF};
};

TEST_F(BoardLockstep, OnePeriodPerOutputCommitAndTheCountIsReadyAtTheNextRead) {
  SimulatedBoard board(gpio_, pwm_chip_, &counter_, board_config(true),
                       std::make_unique<Inertia>(0.01, period));
  GpioChip chip(gpio_.chip_path());
  const unsigned offsets[] = {0, 1, 5, 6};  // enable, direction, pump, brake
  const int initial[] = {0, 1, 0, 1};
  const std::string keys[] = {"enable_line", "direction_line", "charge_pump_line", "brake_line"};
  OutputLines outputs(chip, offsets, initial, "hapticd", keys);
  PwmOutput pwm({"/sys/class/pwm/pwmchip0", 0, 50'000, false, 1.0});
  CounterInput count("/sys/bus/counter/devices/counter0", 0);

  Inertia reference(0.01, period);
  int pump = 0;
  for (int n = 0; n < 200; ++n) {
    const double force = n < 100 ? 0.2 : -0.1;  // 25 % forward, then 12.5 % backward
    ASSERT_EQ(pwm.set_duty(static_cast<std::uint64_t>(std::fabs(force) / 0.8 * 50'000)), 0);
    pump ^= 1;
    const int levels[] = {1, force > 0 ? 1 : 0, pump, 0};
    ASSERT_EQ(outputs.set(levels), 0);
    ASSERT_EQ(board.periods(), static_cast<std::uint64_t>(n + 1));
    const double x = reference.advance(force);
    std::uint64_t raw = 0;
    ASSERT_EQ(count.read(raw), 0);
    const auto expected = static_cast<std::int64_t>(std::floor(x * counts_per_rad));
    ASSERT_EQ(static_cast<std::int32_t>(static_cast<std::uint32_t>(raw)), expected) << "period " << n;
  }
  const auto history = board.history();
  for (std::size_t n = 1; n < history.size(); ++n) {
    EXPECT_NE(history[n].charge_pump, history[n - 1].charge_pump) << n;  // toggled every period
  }
  EXPECT_DOUBLE_EQ(history[0].motor_force, 0.2);
  EXPECT_DOUBLE_EQ(history[150].motor_force, -0.1);
  EXPECT_TRUE(pwm_chip_.refused().empty());
}

TEST_F(BoardLockstep, FaultLineEdgeAndResetPulse) {
  SimulatedBoard board(gpio_, pwm_chip_, &counter_, board_config(true),
                       std::make_unique<Inertia>(0.01, period));
  GpioChip chip(gpio_.chip_path());
  EdgeInput fault(chip, 2, "hapticd", "fault_line");
  const unsigned reset_offset[] = {7};
  const int inactive[] = {0};
  const std::string reset_key[] = {"reset_line"};
  OutputLines reset(chip, reset_offset, inactive, "hapticd", reset_key);
  EXPECT_EQ(fault.level(), 1);  // active low: high = no fault
  board.trip("over-current");
  std::array<EdgeEvent, 4> events;
  ASSERT_EQ(fault.read(events), 1);
  EXPECT_FALSE(events[0].rising);  // nFAULT falls
  EXPECT_TRUE(board.fault());
  const int active[] = {1};
  ASSERT_EQ(reset.set(active), 0);
  EXPECT_TRUE(board.fault());  // cleared at the end of the pulse
  ASSERT_EQ(reset.set(inactive), 0);
  EXPECT_FALSE(board.fault());
  EXPECT_EQ(board.resets(), 1u);
  ASSERT_EQ(fault.read(events), 1);
  EXPECT_TRUE(events[0].rising);
}

TEST_F(BoardLockstep, WatchdogCutsThePowerWhenThePumpStops) {
  BoardConfig config = board_config(true);
  config.amplifier.watchdog_periods = 5;
  SimulatedBoard board(gpio_, pwm_chip_, &counter_, config, std::make_unique<Inertia>(0.01, period));
  GpioChip chip(gpio_.chip_path());
  const unsigned offsets[] = {0, 1, 5};
  const int initial[] = {0, 1, 0};
  const std::string keys[] = {"enable_line", "direction_line", "charge_pump_line"};
  OutputLines outputs(chip, offsets, initial, "hapticd", keys);
  PwmOutput pwm({"/sys/class/pwm/pwmchip0", 0, 50'000, false, 1.0});
  ASSERT_EQ(pwm.set_duty(25'000), 0);
  for (int n = 0; n < 10; ++n) {
    const int levels[] = {1, 1, (n + 1) & 1};
    ASSERT_EQ(outputs.set(levels), 0);
  }
  EXPECT_DOUBLE_EQ(board.history().back().motor_force, 0.4);
  // hapticd killed: the lines keep their last levels, the PWM keeps running.
  board.advance_idle(5);
  EXPECT_DOUBLE_EQ(board.history().back().motor_force, 0.4);  // within the watchdog's timeout
  board.advance_idle(1);
  EXPECT_TRUE(board.watchdog_expired());
  EXPECT_DOUBLE_EQ(board.history().back().motor_force, 0.0);
}

TEST_F(BoardLockstep, QuadratureEdgesFollowThePlant) {
  SimulatedBoard board(gpio_, pwm_chip_, nullptr, board_config(false),
                       std::make_unique<Inertia>(0.01, period));
  GpioChip chip(gpio_.chip_path());
  const unsigned offsets[] = {0, 1};
  const int initial[] = {0, 1};
  const std::string keys[] = {"enable_line", "direction_line"};
  OutputLines outputs(chip, offsets, initial, "hapticd", keys);
  PwmOutput pwm({"/sys/class/pwm/pwmchip0", 0, 50'000, false, 1.0});
  EdgeInput a(chip, 3, "hapticd", "encoder_a_line");
  EdgeInput b(chip, 4, "hapticd", "encoder_b_line");
  QuadratureReader reader(a, b, false, false, false);
  reader.start();
  // Small pushes: a few counts per period, well inside the 16-event queues.
  ASSERT_EQ(pwm.set_duty(500), 0);
  for (int n = 0; n < 100; ++n) {
    const int levels[] = {1, n < 50 ? 1 : 0};
    ASSERT_EQ(outputs.set(levels), 0);
    ASSERT_TRUE(eventually([&] { return reader.count() == board.counts(); })) << "period " << n;
  }
  reader.stop();
  EXPECT_NE(board.counts(), 0);
  EXPECT_EQ(reader.stats().invalid_transitions + reader.stats().lost_edges + reader.stats().full_reads, 0u);
  EXPECT_EQ(gpio_.dropped_events(), 0u);
}

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::sim::board_test
