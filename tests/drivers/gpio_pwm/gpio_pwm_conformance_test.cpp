// The gpio-pwm device through the conformance suite every driver passes,
// built through the registry from a [device.gpio-pwm] table, against the
// simulated board (libgpiod on the umockdev chip, PWM and counter files of
// the testbed's /sys, the shared plant simulator behind them).

#include <memory>

#include "drivers/loopback/loopback_config.hpp"
#include "sim/gpio_pwm/board.hpp"
#include "tests/drivers/conformance/device_conformance.hpp"

namespace {

namespace sim = hapticd::drivers::gpio_pwm::sim;
using hapticd::testing::BadParameters;
using hapticd::testing::ParameterTable;

constexpr double period = 1e-3;

sim::GpioChipSpec chip_spec() {
  sim::GpioChipSpec s;
  s.line_names = {"MOTOR_EN", "MOTOR_DIR", "MOTOR_NFAULT", "ENC_A", "ENC_B", "PUMP", "BRAKE", "RESET"};
  return s;
}

sim::BoardConfig board_config() {
  sim::BoardConfig b;
  b.wiring.enable = 0;
  b.wiring.direction = 1;
  b.wiring.fault = 2;
  b.wiring.fault_active_low = true;
  b.wiring.charge_pump = 5;
  b.wiring.brake = 6;
  b.wiring.reset = 7;
  b.amplifier = {0.8, 0};
  b.period_s = period;
  return b;
}

std::unique_ptr<sim::BoardPlant> loopback_wheel() {
  auto plant = hapticd::drivers::loopback::parse_loopback_config("");  // the loopback's default wheel
  plant.period_s = period;
  return std::make_unique<sim::SimulatorPlant>(
      std::make_unique<hapticd::drivers::simulation::PlantSimulator>(plant));
}

struct GpioPwmConformance {
  static constexpr const char* driver = "gpio-pwm";
  sim::UmockdevGpioTestbed gpio{chip_spec()};
  sim::SimulatedPwmChip pwm{gpio.root_dir(), "/sys/class/pwm/pwmchip0", 1};
  sim::SimulatedCounter counter{gpio.root_dir(), "/sys/bus/counter/devices/counter0", 0, 0xFFFFFFFF};
  sim::SimulatedBoard board{gpio, pwm, &counter, board_config(), loopback_wheel()};

  ParameterTable parameters() {
    return {{"mass", 0.01},
            {"enable_line", std::string("MOTOR_EN")},
            {"direction_line", std::string("1")},
            {"fault_line", std::string("MOTOR_NFAULT")},
            {"fault_active_low", true},
            {"charge_pump_line", std::string("PUMP")},
            {"brake_line", std::string("BRAKE")},
            {"reset_line", std::string("RESET")},
            {"reset_pulse", std::string("2ms")},
            {"force_at_full_duty", 0.8},
            {"counter", std::string("/sys/bus/counter/devices/counter0")}};
  }
  double period_s() { return period; }
  void inject_device_fault(hapticd::drivers::Device&) { board.trip("over-current"); }
  double observed_output(hapticd::drivers::Device&) {
    const auto history = board.history();
    return history.empty() ? 0.0 : history.back().motor_force;
  }
  std::vector<BadParameters> bad_parameters() {
    const auto with = [this](const std::string& key, hapticd::drivers::ParameterValue value) {
      ParameterTable t = parameters();
      t[key] = std::move(value);
      return t;
    };
    ParameterTable no_enable = parameters();
    no_enable.erase("enable_line");
    ParameterTable no_position = with("counter", std::string(""));
    return {
        {with("mass", -1.0), "mass"},                                       // the table's range
        {no_enable, "enable_line"},                                         // required
        {with("pwm_period", std::string("500ns")), "pwm_period"},           // below 1 us
        {with("deadband", 1.0), "deadband"},                                // every command would give duty 0
        {with("fault_line", std::string("MOTOR_EN")), "fault_line"},        // one line, two roles
        {no_position, "encoder_a_line"},                                    // no counter and no encoder lines
        {with("chip", std::string("gpiochip7")), "chip"},                   // configure: no such chip
        {with("enable_line", std::string("MOTOR_ENABLE")), "enable_line"},  // configure: no such line
        {with("pwm_channel", 3.0), "pwm_channel"},                          // configure: the chip has one
        {with("counter", std::string("/sys/bus/counter/devices/counter9")), "counter"},
    };
  }
};

}  // namespace

namespace hapticd::testing::gpio_pwm_conformance_test {
INSTANTIATE_TYPED_TEST_SUITE_P(GpioPwm, DeviceConformance, GpioPwmConformance);
}  // namespace hapticd::testing::gpio_pwm_conformance_test
