// gpio-pwm parameters: line specs, ranges, combinations; errors name the key.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <string>

#include "drivers/gpio_pwm/gpio_pwm_config.hpp"

namespace hapticd::drivers::gpio_pwm::config_test {
namespace {

GpioPwmConfig valid_counter_config() {
  GpioPwmConfig c;
  c.enable_line = parse_line_spec("enable_line", "5");
  c.direction_line = parse_line_spec("direction_line", "MOTOR_DIR");
  c.force_at_full_duty = 0.8;
  c.counter = "/sys/bus/counter/devices/counter0";
  c.mass = 0.01;
  return c;
}

// Runs validate() and returns the key of the error ("" if none).
std::string error_key(const GpioPwmConfig& c, std::string* message = nullptr) {
  try {
    validate(c);
  } catch (const ParameterError& e) {
    if (message) *message = e.what();
    return e.key();
  }
  return "";
}

TEST(GpioPwmConfig, LineSpecByOffsetOrName) {
  EXPECT_EQ(parse_line_spec("k", "17").offset, 17u);
  EXPECT_EQ(parse_line_spec("k", "MOTOR_EN").name, "MOTOR_EN");
  EXPECT_FALSE(parse_line_spec("k", "").configured());
  EXPECT_TRUE(parse_line_spec("k", "0").configured());
  EXPECT_TRUE(parse_line_spec("k", "3", true).active_low);
  EXPECT_EQ(parse_line_spec("k", "17").describe(), "17");
  EXPECT_EQ(parse_line_spec("k", "EN").describe(), "\"EN\"");
}

TEST(GpioPwmConfig, LineSpecRefusals) {
  EXPECT_THROW(parse_line_spec("enable_line", "65536"), ParameterError);
  EXPECT_THROW(parse_line_spec("enable_line", "99999999999999999999"), ParameterError);
  try {
    parse_line_spec("fault_line", std::string(32, 'x'));
    FAIL();
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.key(), "fault_line");
    EXPECT_NE(std::string(e.what()).find("31 characters"), std::string::npos);
  }
}

TEST(GpioPwmConfig, ValidCounterAndQuadratureConfigs) {
  EXPECT_EQ(error_key(valid_counter_config()), "");
  GpioPwmConfig q = valid_counter_config();
  q.counter.clear();
  q.encoder_a_line = parse_line_spec("encoder_a_line", "20");
  q.encoder_b_line = parse_line_spec("encoder_b_line", "21");
  EXPECT_EQ(error_key(q), "");
  EXPECT_EQ(q.position_source(), PositionSource::quadrature);
  EXPECT_DOUBLE_EQ(q.metres_or_radians_per_count(), 2.0 * std::numbers::pi / 16384.0);
}

TEST(GpioPwmConfig, EachRefusalNamesItsKey) {
  const std::vector<std::pair<std::string, std::function<void(GpioPwmConfig&)>>> cases{
      {"chip", [](GpioPwmConfig& c) { c.chip.clear(); }},
      {"consumer", [](GpioPwmConfig& c) { c.consumer = std::string(40, 'c'); }},
      {"enable_line", [](GpioPwmConfig& c) { c.enable_line = {}; }},
      {"direction_line", [](GpioPwmConfig& c) { c.direction_line = {}; }},
      {"pwm_chip", [](GpioPwmConfig& c) { c.pwm_chip = "pwmchip0"; }},
      {"pwm_period", [](GpioPwmConfig& c) { c.pwm_period_ns = 999; }},
      {"pwm_period", [](GpioPwmConfig& c) { c.pwm_period_ns = 2'000'000'000; }},
      {"force_at_full_duty", [](GpioPwmConfig& c) { c.force_at_full_duty = 0.0; }},
      {"force_at_full_duty", [](GpioPwmConfig& c) { c.force_at_full_duty = std::nan(""); }},
      {"max_duty", [](GpioPwmConfig& c) { c.max_duty = 1.5; }},
      {"max_duty", [](GpioPwmConfig& c) { c.max_duty = 0.0; }},
      {"deadband", [](GpioPwmConfig& c) { c.deadband = -0.1; }},
      {"deadband", [](GpioPwmConfig& c) { c.deadband = 0.8; }},  // >= 0.8 x 0.95
      {"counts_per_unit", [](GpioPwmConfig& c) { c.counts_per_unit = 0.0; }},
      {"mass", [](GpioPwmConfig& c) { c.mass = 0.0; }},
      {"mass", [](GpioPwmConfig& c) { c.mass = std::nan(""); }},
      {"damping", [](GpioPwmConfig& c) { c.damping = -1.0; }},
      {"reset_pulse", [](GpioPwmConfig& c) { c.reset_pulse_s = 2.0; }},
      {"export_timeout", [](GpioPwmConfig& c) { c.export_timeout_s = 0.0; }},
      {"counter", [](GpioPwmConfig& c) { c.counter = "counter0"; }},
      {"encoder_a_line", [](GpioPwmConfig& c) { c.encoder_a_line = parse_line_spec("encoder_a_line", "9"); }},
      {"encoder_b_line",
       [](GpioPwmConfig& c) {
         c.counter.clear();
         c.encoder_a_line = parse_line_spec("encoder_a_line", "9");
       }},
      {"fault_line", [](GpioPwmConfig& c) { c.fault_line = parse_line_spec("fault_line", "5"); }},
      {"charge_pump_line",
       [](GpioPwmConfig& c) { c.charge_pump_line = parse_line_spec("charge_pump_line", "MOTOR_DIR"); }},
  };
  for (const auto& [key, mutate] : cases) {
    GpioPwmConfig c = valid_counter_config();
    mutate(c);
    std::string message;
    EXPECT_EQ(error_key(c, &message), key) << message;
    EXPECT_NE(message.find(key), std::string::npos) << message;
  }
}

TEST(GpioPwmConfig, DuplicateLineMessageNamesBothRoles) {
  GpioPwmConfig c = valid_counter_config();
  c.brake_line = parse_line_spec("brake_line", "5");
  std::string message;
  EXPECT_EQ(error_key(c, &message), "brake_line");
  EXPECT_EQ(message, "brake_line = 5 is already enable_line; every line has one role");
}

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::config_test
