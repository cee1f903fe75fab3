// Fault injection, status, determinism and the configuration keys.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "drivers/loopback/loopback_device.hpp"

namespace {

using hapticd::drivers::IoResult;
using hapticd::drivers::Motion;
using hapticd::drivers::Reading;
using namespace hapticd::drivers::loopback;

LoopbackConfig wheel() {
  LoopbackConfig config = LoopbackConfig::defaults(Motion::rotary);
  config.mass = 0.01;
  return config;
}

TEST(LoopbackFaults, ReadErrorForNPeriods) {
  LoopbackDevice device(wheel());
  device.start();
  device.inject_fault(Fault::read_error, 3);
  Reading r;
  for (int n = 0; n < 3; ++n) {
    EXPECT_EQ(device.read(r), IoResult::error) << n;
    EXPECT_EQ(device.write(0.0), IoResult::ok);
  }
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_EQ(device.status().read_errors, 3U);
}

TEST(LoopbackFaults, ReadErrorUntilCleared) {
  LoopbackDevice device(wheel());
  device.start();
  device.inject_fault(Fault::read_error);
  Reading r;
  for (int n = 0; n < 50; ++n) {
    ASSERT_EQ(device.read(r), IoResult::error);
    device.write(0.0);
  }
  EXPECT_NE(device.status().last_error.find("read-error (until cleared)"), std::string::npos)
      << device.status().last_error;
  device.clear_faults();
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_TRUE(device.status().last_error.empty());
}

TEST(LoopbackFaults, StallFreezesTimeReturnsStaleValueAndRefusesWrites) {
  LoopbackDevice device(wheel());
  device.start();
  Reading before;
  for (int n = 0; n < 100; ++n) device.write(0.05);
  device.read(before);
  const auto frozen = device.snapshot();
  device.inject_fault(Fault::stall);
  for (int n = 0; n < 50; ++n) {
    Reading r;
    ASSERT_EQ(device.read(r), IoResult::ok);
    ASSERT_EQ(r.position, before.position);
    ASSERT_EQ(device.write(0.8), IoResult::error);
  }
  EXPECT_EQ(device.snapshot().period, frozen.period);
  EXPECT_EQ(device.snapshot().motor_position, frozen.motor_position);
  EXPECT_EQ(device.status().write_errors, 50U);
  device.clear_faults();
  EXPECT_EQ(device.write(0.05), IoResult::ok);
  EXPECT_EQ(device.snapshot().period, frozen.period + 1);
  Reading after;
  device.read(after);
  EXPECT_GT(after.position, before.position);
}

TEST(LoopbackFaults, StallForNPeriods) {
  LoopbackDevice device(wheel());
  device.start();
  device.inject_fault(Fault::stall, 2);
  EXPECT_EQ(device.write(0.1), IoResult::error);
  EXPECT_EQ(device.write(0.1), IoResult::error);
  EXPECT_EQ(device.write(0.1), IoResult::ok);
  EXPECT_EQ(device.snapshot().period, 1U);
}

TEST(LoopbackFaults, NanReading) {
  LoopbackDevice device(wheel());
  device.start();
  device.inject_fault(Fault::nan, 1);
  Reading r;
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_TRUE(std::isnan(r.position));
  device.write(0.0);
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_EQ(r.position, 0.0);
  device.inject_fault(Fault::nan);
  device.read(r);
  EXPECT_TRUE(std::isnan(r.position));
  device.clear_faults();
  device.read(r);
  EXPECT_EQ(r.position, 0.0);
}

TEST(LoopbackFaults, EncoderJumpOnceAndClear) {
  const LoopbackConfig config = wheel();
  LoopbackDevice device(config);
  device.set_initial_state(100.5 * config.resolution(), 0.0);
  device.start();
  Reading r;
  device.read(r);
  EXPECT_NEAR(r.position, 100 * config.resolution(), 1e-15);
  device.inject_fault(Fault::encoder_jump, 5);
  for (int n = 0; n < 3; ++n) {  // a jump, not a drift: the same offset every period
    device.read(r);
    EXPECT_NEAR(r.position, 105 * config.resolution(), 1e-15);
    device.write(0.0);
  }
  device.inject_fault(Fault::encoder_jump, -7);
  device.read(r);
  EXPECT_NEAR(r.position, 98 * config.resolution(), 1e-15);
  EXPECT_EQ(device.snapshot().motor_position, 100.5 * config.resolution());  // the plant did not move
  device.clear_faults();
  device.read(r);
  EXPECT_NEAR(r.position, 100 * config.resolution(), 1e-15);
}

TEST(LoopbackFaults, DeviceFaultZeroesTheMotorAndReports) {
  LoopbackDevice device(wheel());
  device.start();
  device.inject_fault(Fault::fault);
  Reading r;
  for (int n = 0; n < 10; ++n) {
    ASSERT_EQ(device.read(r), IoResult::fault);
    ASSERT_EQ(device.write(0.5), IoResult::fault);
  }
  EXPECT_EQ(device.snapshot().period, 10U);  // time goes on, the amplifier is off
  EXPECT_EQ(device.snapshot().motor_position, 0.0);
  EXPECT_EQ(device.snapshot().applied_force, 0.0);
  EXPECT_EQ(device.status().faults, 20U);
  device.clear_faults();
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_EQ(device.write(0.5), IoResult::ok);
  EXPECT_EQ(device.snapshot().applied_force, 0.5);
}

TEST(LoopbackFaults, FaultNames) {
  for (const Fault f : {Fault::read_error, Fault::stall, Fault::nan, Fault::encoder_jump, Fault::fault}) {
    EXPECT_EQ(parse_fault(to_string(f)), f);
  }
  EXPECT_EQ(to_string(Fault::encoder_jump), "encoder-jump");
  EXPECT_FALSE(parse_fault("explode").has_value());
}

std::vector<double> run_scenario() {
  LoopbackConfig config = LoopbackConfig::defaults(Motion::linear);
  config.plant = PlantKind::two_mass;
  config.coulomb = 0.5;
  config.delay = 2;
  LoopbackDevice device(config, parse_hand_script("mode=impedance stiffness=2000 damping=20 trajectory=sine "
                                                  "amplitude=0.01 frequency=3 release_at=3"));
  device.start();
  std::uint64_t lcg = 12345;
  std::vector<double> trace;
  Reading r;
  for (int n = 0; n < 5000; ++n) {
    device.read(r);
    lcg = lcg * 6364136223846793005ULL + 1442695040888963407ULL;
    const double noise = static_cast<double>(lcg >> 11) / 9007199254740992.0 - 0.5;
    device.write(-300.0 * r.position + 4.0 * noise);
    const auto s = device.snapshot();
    trace.insert(trace.end(), {r.position, s.motor_position, s.body_position, s.motor_velocity,
                               s.body_velocity, s.hand_force, s.friction_force});
  }
  return trace;
}

TEST(LoopbackDeterminism, TwoRunsAreBitIdentical) {
  const std::vector<double> a = run_scenario();
  const std::vector<double> b = run_scenario();
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0);
  // And the scenario did something: the body moved and friction acted.
  double max_body = 0.0, max_friction = 0.0;
  for (std::size_t i = 0; i < a.size(); i += 7) {
    max_body = std::max(max_body, std::abs(a[i + 2]));
    max_friction = std::max(max_friction, std::abs(a[i + 6]));
  }
  EXPECT_GT(max_body, 1e-3);
  EXPECT_GT(max_friction, 0.0);
}

TEST(LoopbackConfigKeys, EveryDocumentedKeyParsesWithItsDefault) {
  const auto parameters = loopback_parameters();
  std::set<std::string> names;
  for (const auto& p : parameters) {
    EXPECT_FALSE(p.help.empty()) << p.name;
    EXPECT_TRUE(p.type == "number" || p.type == "integer" || p.type == "string" || p.type == "bool")
        << p.name;
    EXPECT_TRUE(names.insert(p.name).second) << "duplicate " << p.name;
    EXPECT_NO_THROW(parse_loopback_config({{p.name, p.default_value}})) << p.name << "=" << p.default_value;
  }
  for (const char* key : {"motion", "plant", "mass", "damping", "coulomb", "motor_mass", "body_mass",
                          "motor_damping", "body_damping", "cable_stiffness", "cable_damping", "sensor",
                          "counts", "max_force", "delay", "period"}) {
    EXPECT_EQ(names.count(key), 1U) << key;
  }
  // All defaults together give the default config.
  std::vector<std::pair<std::string, std::string>> all;
  for (const auto& p : parameters) all.emplace_back(p.name, p.default_value);
  const LoopbackConfig parsed = parse_loopback_config(all);
  const LoopbackConfig defaults;
  EXPECT_EQ(parsed.mass, defaults.mass);
  EXPECT_EQ(parsed.counts, defaults.counts);
  EXPECT_EQ(parsed.max_force, defaults.max_force);
  EXPECT_EQ(parsed.period_s, defaults.period_s);
  EXPECT_EQ(parsed.two_mass.cable_stiffness, defaults.two_mass.cable_stiffness);
}

TEST(LoopbackConfigKeys, MotionSelectsDefaultsAndKeysOverride) {
  const LoopbackConfig linear =
      parse_loopback_config("mass=0.2 motion=linear period=250us delay=2 plant=two-mass");
  EXPECT_EQ(linear.motion, Motion::linear);
  EXPECT_EQ(linear.mass, 0.2);  // given after motion's defaults, whatever the order
  EXPECT_NEAR(linear.counts, 1.0 / 3.14e-6, 1e-6);
  EXPECT_EQ(linear.max_force, 10.0);
  EXPECT_EQ(linear.period_s, 250e-6);
  EXPECT_EQ(linear.delay, 2);
  EXPECT_EQ(linear.plant, PlantKind::two_mass);
  const LoopbackConfig rotary = parse_loopback_config("");
  EXPECT_EQ(rotary.motion, Motion::rotary);
  EXPECT_EQ(rotary.mass, 0.01);
  EXPECT_EQ(rotary.counts, 16384.0);
  EXPECT_EQ(rotary.max_force, 1.2);
  EXPECT_EQ(rotary.damping, 0.002);
}

void expect_config_error(std::string_view text, std::string_view fragment) {
  try {
    parse_loopback_config(text);
    ADD_FAILURE() << "accepted: " << text;
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(fragment), std::string::npos) << "'" << message << "' lacks '" << fragment << "'";
    EXPECT_EQ(message.find('\n'), std::string::npos);
  }
}

TEST(LoopbackConfigKeys, ErrorsNameTheKey) {
  expect_config_error("mas=1", "unknown key 'mas'; accepted: motion, plant, mass,");
  expect_config_error("motion=spherical", "motion=spherical is not one of rotary, linear");
  expect_config_error("plant=three-mass", "plant=three-mass is not one of rigid, two-mass");
  expect_config_error("mass=heavy", "mass=heavy is not a finite number");
  expect_config_error("mass=0", "mass must be >= 1e-09 and <= 1e+06 (got 0)");
  expect_config_error("coulomb=-1", "coulomb must be >= 0");
  expect_config_error("delay=1.5", "delay=1.5 is not an integer");
  expect_config_error("delay=65", "delay must be an integer in 0..64");
  expect_config_error("period=fast", "period=fast is not a duration");
  expect_config_error("sensor=elbow", "sensor=elbow is not one of motor, body");
  expect_config_error("plant=two-mass cable_stiffness=0", "cable_stiffness must be > 0");
  expect_config_error("max_force", "'max_force' is not key=value");
  LoopbackConfig bad;
  bad.mass = -1.0;
  EXPECT_THROW(LoopbackDevice{bad}, std::invalid_argument);
}

// Every number has a finite range: a 1e-300 kg mass or a 1e308 N force is a
// typo, not a device (these were accepted).
TEST(LoopbackConfigKeys, NumbersOutsideTheirRangeAreRefusedNamingIt) {
  expect_config_error("mass=1e-300", "mass must be >= 1e-09 and <= 1e+06 (got 1e-300)");
  expect_config_error("mass=2e6", "mass must be >= 1e-09 and <= 1e+06");
  expect_config_error("damping=1e308", "damping must be >= 0 and <= 1e+06 (got 1e+308)");
  expect_config_error("coulomb=1e7", "coulomb must be >= 0 and <= 1e+06");
  expect_config_error("max_force=1e308", "max_force must be > 0 and <= 1e+06");
  expect_config_error("counts=0.5", "counts must be >= 1 and <= 1e+12");
  expect_config_error("period=1e-300", "period must be >= 1e-06 and <= 1 (got 1e-300)");
  expect_config_error("period=10s", "period must be >= 1e-06 and <= 1");
  expect_config_error("plant=two-mass motor_mass=1e308", "motor_mass must be >= 1e-09 and <= 1e+06");
  expect_config_error("plant=two-mass body_mass=1e-10", "body_mass must be >= 1e-09");
  expect_config_error("plant=two-mass cable_stiffness=1e10", "cable_stiffness must be > 0 and <= 1e+09");
  expect_config_error("plant=two-mass cable_damping=2e6", "cable_damping must be >= 0 and <= 1e+06");
  expect_config_error("plant=two-mass body_damping=1e300", "body_damping must be >= 0 and <= 1e+06");
  expect_config_error("plant=two-mass motor_damping=1e300", "motor_damping must be >= 0 and <= 1e+06");
  // The bounds themselves are accepted.
  EXPECT_NO_THROW(parse_loopback_config("mass=1e-9 damping=1e6 max_force=1e6 period=1us counts=1"));
  EXPECT_NO_THROW(parse_loopback_config("mass=1e6 period=1s counts=1e12 coulomb=1e6"));
}

}  // namespace
