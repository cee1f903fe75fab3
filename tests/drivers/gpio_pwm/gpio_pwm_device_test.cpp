// The gpio-pwm device against the simulated board, through libgpiod on the
// umockdev chip and the PWM and counter files of the testbed's /sys: the
// lifecycle, the force and position in lockstep with an exact reference,
// the fault line, the reset pulse, disable, the charge pump, quadrature.
#include <gtest/gtest.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <numbers>
#include <thread>

#include "drivers/device.hpp"
#include "drivers/gpio_pwm/gpio_pwm_device.hpp"
#include "drivers/stop_request.hpp"
#include "sim/gpio_pwm/board.hpp"
#include "tests/support/alloc_counter.hpp"

namespace hapticd::drivers::gpio_pwm::gpio_pwm_device_test {
namespace {

bool eventually(const std::function<bool()>& condition) {
  for (int i = 0; i < 5000; ++i) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return condition();
}

constexpr double period = 1e-3;
constexpr double counts_per_rev = 16384.0;
constexpr double counts_per_rad = counts_per_rev / (2.0 * std::numbers::pi);

// A free inertia with viscous damping 0, integrated exactly for a held force.
class Inertia final : public sim::BoardPlant {
 public:
  explicit Inertia(double inertia) : j_(inertia) {}
  void step(double force) override {
    x_ += v_ * period + force * period * period / (2.0 * j_);
    v_ += force * period / j_;
  }
  std::int64_t encoder_counts() const override {
    return static_cast<std::int64_t>(std::floor(x_ * counts_per_rad));
  }
  double position() const override { return x_; }

 private:
  double j_, x_ = 0.0, v_ = 0.0;
};

// Lines: 0 EN, 1 DIR, 2 nFAULT (active low), 3 ENC_A, 4 ENC_B, 5 PUMP, 6 BRAKE, 7 RESET.
sim::GpioChipSpec chip_spec() {
  sim::GpioChipSpec s;
  s.line_names = {"MOTOR_EN", "MOTOR_DIR", "MOTOR_NFAULT", "ENC_A", "ENC_B", "PUMP", "BRAKE", "RESET"};
  return s;
}

GpioPwmConfig device_config(bool counter) {
  GpioPwmConfig c;
  c.chip = "gpiochip0";
  c.enable_line = parse_line_spec("enable_line", "MOTOR_EN");
  c.direction_line = parse_line_spec("direction_line", "1");
  c.fault_line = parse_line_spec("fault_line", "MOTOR_NFAULT", true);
  c.charge_pump_line = parse_line_spec("charge_pump_line", "PUMP");
  c.brake_line = parse_line_spec("brake_line", "6");
  c.reset_line = parse_line_spec("reset_line", "RESET");
  c.force_at_full_duty = 0.8;
  c.max_duty = 1.0;
  c.pwm_period_ns = 50'000;
  c.counts_per_unit = counts_per_rev;
  c.mass = 0.01;
  c.reset_pulse_s = 0.002;
  if (counter) {
    c.counter = "/sys/bus/counter/devices/counter0";
  } else {
    c.encoder_a_line = parse_line_spec("encoder_a_line", "ENC_A");
    c.encoder_b_line = parse_line_spec("encoder_b_line", "ENC_B");
  }
  return c;
}

sim::BoardConfig board_config(bool counter) {
  sim::BoardConfig b;
  b.wiring.enable = 0;
  b.wiring.direction = 1;
  b.wiring.fault = 2;
  b.wiring.fault_active_low = true;
  b.wiring.charge_pump = 5;
  b.wiring.brake = 6;
  b.wiring.reset = 7;
  if (!counter) {
    b.wiring.encoder_a = 3;
    b.wiring.encoder_b = 4;
  }
  b.amplifier = {0.8, 0};
  b.period_s = period;
  return b;
}

class GpioPwmDeviceTest : public ::testing::Test {
 protected:
  void make_board(bool counter) {
    board_ = std::make_unique<sim::SimulatedBoard>(gpio_, pwm_chip_, counter ? &counter_ : nullptr,
                                                   board_config(counter), std::make_unique<Inertia>(0.01));
  }
  bool line(unsigned offset) {
    return gpio_.with_chip([offset](sim::GpioChipModel& c) { return c.physical_level(offset); });
  }
  sim::UmockdevGpioTestbed gpio_{chip_spec()};
  sim::SimulatedPwmChip pwm_chip_{gpio_.root_dir(), "/sys/class/pwm/pwmchip0", 1};
  sim::SimulatedCounter counter_{gpio_.root_dir(), "/sys/bus/counter/devices/counter0", 0, 0xFFFFFFFF};
  std::unique_ptr<sim::SimulatedBoard> board_;
};

TEST_F(GpioPwmDeviceTest, LifecycleAndTheDefinedStates) {
  make_board(true);
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(device_config(true)));
  Reading r;
  EXPECT_EQ(device.read(r), IoResult::error);  // before configure
  EXPECT_THROW(device.enable(), std::logic_error);
  device.configure({period});
  EXPECT_THROW(device.configure({period}), std::logic_error);
  EXPECT_NE(device.hooks_as<GpioPwmDevice>().description().find("charge pump on PUMP (offset 5)"),
            std::string::npos)
      << device.hooks_as<GpioPwmDevice>().description();
  EXPECT_FALSE(line(0));  // enable inactive
  EXPECT_TRUE(line(6));   // brake applied
  EXPECT_EQ(pwm_chip_.state(0), (sim::PwmChannelState{50'000, 0, true, false}));
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_EQ(r.position, 0.0);
  EXPECT_EQ(device.write(0.2), IoResult::error);  // before enable
  device.enable();
  EXPECT_FALSE(line(0));  // armed: the lines follow at the first write
  EXPECT_EQ(device.write(0.2), IoResult::ok);
  EXPECT_TRUE(line(0));
  EXPECT_FALSE(line(6));
  EXPECT_EQ(pwm_chip_.state(0).duty_ns, 12'500u);
  device.disable();
  EXPECT_EQ(pwm_chip_.state(0), (sim::PwmChannelState{50'000, 0, true, false}));  // duty 0, still enabled
  EXPECT_FALSE(line(0));
  EXPECT_TRUE(line(6));
  device.disable();  // idempotent
  device.close();
  device.close();
  EXPECT_EQ(device.read(r), IoResult::error);
  hapticd::drivers::Device again("gpio-pwm", std::make_unique<GpioPwmDevice>(device_config(true)));
  again.configure({period});  // every line was released
  EXPECT_TRUE(pwm_chip_.refused().empty());
}

TEST_F(GpioPwmDeviceTest, ForceAndPositionInLockstepWithAnExactReference) {
  make_board(true);
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(device_config(true)));
  device.configure({period});
  device.enable();
  Inertia reference(0.01);
  for (int n = 0; n < 300; ++n) {
    Reading r;
    ASSERT_EQ(device.read(r), IoResult::ok);
    const double expected_counts = std::floor(reference.position() * counts_per_rad);
    ASSERT_DOUBLE_EQ(r.position, expected_counts / counts_per_rad) << "period " << n;
    const double force = n < 150 ? 0.3 : -0.45;  // 18750 and 28125 ns of 50 us: exact
    ASSERT_EQ(device.write(force), IoResult::ok);
    reference.step(force);
  }
  const auto history = board_->history();
  ASSERT_EQ(history.size(), 300u);
  for (std::size_t n = 1; n < history.size(); ++n)
    EXPECT_NE(history[n].charge_pump, history[n - 1].charge_pump);
  EXPECT_TRUE(history[200].enable && !history[200].direction_positive);
  EXPECT_DOUBLE_EQ(history[200].motor_force, -0.45);
  EXPECT_TRUE(pwm_chip_.refused().empty());
}

TEST_F(GpioPwmDeviceTest, FaultLineLatchesZeroesInThatPeriodAndClearsWithAResetPulse) {
  make_board(true);
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(device_config(true)));
  device.configure({period});
  device.enable();
  Reading r;
  for (int n = 0; n < 10; ++n) {
    ASSERT_EQ(device.read(r), IoResult::ok);
    ASSERT_EQ(device.write(0.4), IoResult::ok);
  }
  board_->trip("over-current");
  EXPECT_EQ(device.read(r), IoResult::fault);
  EXPECT_EQ(device.write(0.4), IoResult::fault);  // the engine would write 0; the device holds off anyway
  const auto last = board_->history().back();
  EXPECT_FALSE(last.enable);
  EXPECT_EQ(last.pwm_fraction, 0.0);
  EXPECT_EQ(last.motor_force, 0.0);
  const DeviceStatus status = device.status();
  EXPECT_EQ(status.state, DeviceState::fault);
  EXPECT_EQ(status.faults, 1u);
  EXPECT_EQ(status.fault_reason, "fault line MOTOR_NFAULT (offset 2) active");
  EXPECT_EQ(device.read(r), IoResult::fault);  // latched
  EXPECT_EQ(device.clear_fault(), "fault line MOTOR_NFAULT (offset 2) active: cleared by a 2 ms reset pulse");
  EXPECT_FALSE(board_->fault());
  EXPECT_EQ(board_->resets(), 1u);
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_EQ(device.write(0.4), IoResult::ok);
  EXPECT_DOUBLE_EQ(board_->history().back().motor_force, 0.4);
  EXPECT_EQ(device.clear_fault(), "");  // nothing latched
}

// A count the counter cannot give (above its ceiling: a ceiling changed
// behind hapticd's back, a bad read) is not a position: the output goes to
// zero in that period and a fault latches with the figures, until cleared.
TEST_F(GpioPwmDeviceTest, AnImplausibleCountLatchesAFaultWithTheFigures) {
  make_board(true);
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(device_config(true)));
  device.configure({period});
  device.enable();
  Reading r;
  ASSERT_EQ(device.read(r), IoResult::ok);
  ASSERT_EQ(device.write(0.4), IoResult::ok);
  {
    std::ofstream count(counter_.count_path(), std::ios::trunc);
    count << "5000000000\n";  // the simulated counter's ceiling is 2^32 - 1
  }
  EXPECT_EQ(device.read(r), IoResult::fault);
  EXPECT_EQ(device.write(0.4), IoResult::fault);
  const auto last = board_->history().back();
  EXPECT_FALSE(last.enable);
  EXPECT_EQ(last.motor_force, 0.0);
  const DeviceStatus status = device.status();
  EXPECT_EQ(status.state, DeviceState::fault);
  EXPECT_EQ(status.faults, 1u);
  const std::string reason =
      "counter /sys/bus/counter/devices/counter0/count0/count read 5000000000, above its ceiling 4294967295";
  EXPECT_EQ(status.fault_reason, reason);
  counter_.set_position(7);
  EXPECT_EQ(device.clear_fault(), reason + ": cleared, the next period reads the count again");
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_DOUBLE_EQ(r.position, 7.0 / counts_per_rad);
  EXPECT_EQ(device.write(0.4), IoResult::ok);
  EXPECT_EQ(device.status().state, DeviceState::enabled);
}

// Issue 17 item 9: a fault clear's reset pulse (up to 1 s, and as long again
// for the fault line to follow) gives way to the daemon's stop, the reset
// line released all the same.
TEST_F(GpioPwmDeviceTest, AResetPulseGivesWayToAStopAndReleasesTheLine) {
  make_board(true);
  GpioPwmConfig c = device_config(true);
  c.reset_pulse_s = 1.0;
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(c));
  StopRequest stop;
  device.configure({period, stop.token()});
  device.enable();
  Reading r;
  ASSERT_EQ(device.read(r), IoResult::ok);
  ASSERT_EQ(device.write(0.4), IoResult::ok);
  board_->trip("over-current");
  ASSERT_EQ(device.read(r), IoResult::fault);
  stop.request("the test");
  try {
    device.clear_fault();
    FAIL() << "cleared";
  } catch (const StopRequested& e) {
    EXPECT_EQ(std::string(e.what()),
              "gpio-pwm: the reset pulse on reset_line: abandoned, hapticd is stopping");
  }
  EXPECT_FALSE(line(7)) << "the reset line was left active";
  EXPECT_EQ(device.status().state, DeviceState::fault);
}

TEST_F(GpioPwmDeviceTest, AnActiveFaultAtConfigureIsResetOnceThenRefused) {
  make_board(true);
  board_->trip("over-temperature");
  {
    hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(device_config(true)));
    device.configure({period});  // the reset pulse clears the board's latch
    EXPECT_FALSE(board_->fault());
  }
  GpioPwmConfig no_reset = device_config(true);
  no_reset.reset_line = {};
  board_->trip("over-temperature");
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(no_reset));
  try {
    device.configure({period});
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "fault_line");
    EXPECT_NE(std::string(e.what()).find("MOTOR_NFAULT (offset 2) active"), std::string::npos) << e.what();
  }
}

TEST_F(GpioPwmDeviceTest, ChargePumpTogglesWhileWritingAndStopsWhenDisabled) {
  make_board(true);
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(device_config(true)));
  device.configure({period});
  device.enable();
  Reading r;
  bool previous = line(5);
  for (int n = 0; n < 20; ++n) {
    device.read(r);
    device.write(0.0);
    EXPECT_NE(line(5), previous) << n;
    previous = line(5);
  }
  device.disable();
  const bool stopped = line(5);
  board_->advance_idle(5);
  EXPECT_EQ(line(5), stopped);
}

TEST_F(GpioPwmDeviceTest, ReadAndWriteDoNotAllocate) {
  make_board(true);
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(device_config(true)));
  device.configure({period});
  device.enable();
  Reading r;
  int not_ok = 0;
  testing::AllocationGuard guard;
  for (int n = 0; n < 1000; ++n) {
    not_ok += device.read(r) != IoResult::ok;
    not_ok += device.write(0.3 * std::sin(n * 0.01)) != IoResult::ok;
  }
  const auto allocations = guard.count();
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(not_ok, 0) << "read/write calls that were not ok";
}

// The framework counts the errors from the IoResult: a PWM write or a line
// write that fails is an error in the period it fails, and the next period
// that writes is ok again.
TEST_F(GpioPwmDeviceTest, AFailedPwmOrLineWriteIsAnErrorInThatPeriod) {
  make_board(true);
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(device_config(true)));
  device.configure({period});
  device.enable();
  Reading r;
  ASSERT_EQ(device.read(r), IoResult::ok);
  ASSERT_EQ(device.write(0.2), IoResult::ok);
  pwm_chip_.fail_stores(EIO);
  EXPECT_EQ(device.write(0.3), IoResult::error) << "the duty changed and its store failed";
  EXPECT_EQ(device.status().write_errors, 1u);
  pwm_chip_.fail_stores(0);
  EXPECT_EQ(device.write(0.4), IoResult::ok);
  gpio_.with_chip([](sim::GpioChipModel& c) { c.fail_set_values(EIO); });
  EXPECT_EQ(device.write(0.4), IoResult::error) << "the duty is unchanged, the lines' ioctl failed";
  EXPECT_EQ(device.status().write_errors, 2u);
  EXPECT_EQ(device.status().last_error, "Input/output error");
  gpio_.with_chip([](sim::GpioChipModel& c) { c.fail_set_values(0); });
  EXPECT_EQ(device.write(0.4), IoResult::ok);
  EXPECT_EQ(device.status().write_errors, 2u);
  EXPECT_EQ(device.status().faults, 0u);
}

TEST_F(GpioPwmDeviceTest, QuadratureLinesGiveThePosition) {
  make_board(false);
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<GpioPwmDevice>(device_config(false)));
  device.configure({period});
  device.enable();
  Reading r;
  for (int n = 0; n < 100; ++n) {
    // Wait for the decoding thread (not in the RT path: a test's patience).
    ASSERT_TRUE(eventually([&] {
      return device.read(r) == IoResult::ok && std::llround(r.position * counts_per_rad) == board_->counts();
    })) << "period "
        << n;
    ASSERT_EQ(device.write(n < 50 ? 0.01 : -0.01), IoResult::ok);
  }
  EXPECT_NE(board_->counts(), 0);
  for (const auto& counter : device.status().counters) {
    if (counter.name.rfind("encoder_", 0) == 0 && counter.name != "encoder_edges") {
      EXPECT_EQ(counter.value, 0u) << counter.name;
    }
  }
}

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::gpio_pwm_device_test
