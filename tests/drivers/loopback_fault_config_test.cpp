// Fault injection, status, determinism and the configuration keys.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "drivers/loopback/loopback_device.hpp"
#include "tests/support/loopback_start.hpp"

namespace loopback_fault_config_test {

namespace {

using hapticd::drivers::IoResult;
using hapticd::drivers::Motion;
using hapticd::drivers::Reading;
using namespace hapticd::drivers::loopback;
using namespace hapticd::drivers::simulation;

LoopbackConfig wheel() {
  LoopbackConfig config = LoopbackConfig::defaults(Motion::rotary);
  config.mass = 0.01;
  return config;
}

TEST(LoopbackFaults, ReadErrorForNPeriods) {
  hapticd::testing::LoopbackRig device_rig{wheel()};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  plant.inject_fault(Fault::read_error, 3);
  Reading r;
  for (int n = 0; n < 3; ++n) {
    EXPECT_EQ(device.read(r), IoResult::error) << n;
    EXPECT_EQ(device.write(0.0), IoResult::ok);
  }
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_EQ(device.status().read_errors, 3U);
}

TEST(LoopbackFaults, ReadErrorUntilCleared) {
  hapticd::testing::LoopbackRig device_rig{wheel()};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  plant.inject_fault(Fault::read_error);
  Reading r;
  for (int n = 0; n < 50; ++n) {
    ASSERT_EQ(device.read(r), IoResult::error);
    device.write(0.0);
  }
  EXPECT_NE(device.status().last_error.find("read-error (until cleared)"), std::string::npos)
      << device.status().last_error;
  plant.clear_faults();
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_TRUE(device.status().last_error.empty());
}

TEST(LoopbackFaults, StallFreezesTimeReturnsStaleValueAndRefusesWrites) {
  hapticd::testing::LoopbackRig device_rig{wheel()};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  Reading before;
  for (int n = 0; n < 100; ++n) device.write(0.05);
  device.read(before);
  const auto frozen = plant.snapshot();
  plant.inject_fault(Fault::stall);
  for (int n = 0; n < 50; ++n) {
    Reading r;
    ASSERT_EQ(device.read(r), IoResult::ok);
    ASSERT_EQ(r.position, before.position);
    ASSERT_EQ(device.write(0.8), IoResult::error);
  }
  EXPECT_EQ(plant.snapshot().period, frozen.period);
  EXPECT_EQ(plant.snapshot().motor_position, frozen.motor_position);
  EXPECT_EQ(device.status().write_errors, 50U);
  plant.clear_faults();
  EXPECT_EQ(device.write(0.05), IoResult::ok);
  EXPECT_EQ(plant.snapshot().period, frozen.period + 1);
  Reading after;
  device.read(after);
  EXPECT_GT(after.position, before.position);
}

TEST(LoopbackFaults, StallForNPeriods) {
  hapticd::testing::LoopbackRig device_rig{wheel()};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  plant.inject_fault(Fault::stall, 2);
  EXPECT_EQ(device.write(0.1), IoResult::error);
  EXPECT_EQ(device.write(0.1), IoResult::error);
  EXPECT_EQ(device.write(0.1), IoResult::ok);
  EXPECT_EQ(plant.snapshot().period, 1U);
}

TEST(LoopbackFaults, NanReading) {
  hapticd::testing::LoopbackRig device_rig{wheel()};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  plant.inject_fault(Fault::nan, 1);
  Reading r;
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_TRUE(std::isnan(r.position));
  device.write(0.0);
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_EQ(r.position, 0.0);
  plant.inject_fault(Fault::nan);
  device.read(r);
  EXPECT_TRUE(std::isnan(r.position));
  plant.clear_faults();
  device.read(r);
  EXPECT_EQ(r.position, 0.0);
}

TEST(LoopbackFaults, EncoderJumpOnceAndClear) {
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  plant.set_initial_state(100.5 * config.resolution(), 0.0);
  hapticd::testing::start(device);
  Reading r;
  device.read(r);
  EXPECT_NEAR(r.position, 100 * config.resolution(), 1e-15);
  plant.inject_fault(Fault::encoder_jump, 5);
  for (int n = 0; n < 3; ++n) {  // a jump, not a drift: the same offset every period
    device.read(r);
    EXPECT_NEAR(r.position, 105 * config.resolution(), 1e-15);
    device.write(0.0);
  }
  plant.inject_fault(Fault::encoder_jump, -7);
  device.read(r);
  EXPECT_NEAR(r.position, 98 * config.resolution(), 1e-15);
  EXPECT_EQ(plant.snapshot().motor_position, 100.5 * config.resolution());  // the plant did not move
  plant.clear_faults();
  device.read(r);
  EXPECT_NEAR(r.position, 100 * config.resolution(), 1e-15);
}

TEST(LoopbackFaults, DeviceFaultZeroesTheMotorAndReports) {
  hapticd::testing::LoopbackRig device_rig{wheel()};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  plant.inject_fault(Fault::fault);
  Reading r;
  for (int n = 0; n < 10; ++n) {
    ASSERT_EQ(device.read(r), IoResult::fault);
    ASSERT_EQ(device.write(0.5), IoResult::fault);
  }
  EXPECT_EQ(plant.snapshot().period, 10U);  // time goes on, the amplifier is off
  EXPECT_EQ(plant.snapshot().motor_position, 0.0);
  EXPECT_EQ(plant.snapshot().applied_force, 0.0);
  // Every fault return is the simulator's to count; the framework counts latches.
  EXPECT_EQ(plant.simulator().counters().faults, 20U);
  EXPECT_EQ(device.status().faults, 1U);
  plant.clear_faults();
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_EQ(device.write(0.5), IoResult::ok);
  EXPECT_EQ(plant.snapshot().applied_force, 0.5);
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
  hapticd::testing::LoopbackRig device_rig{
      config, parse_hand_script("mode=impedance stiffness=2000 damping=20 trajectory=sine "
                                "amplitude=0.01 frequency=3 release_at=3")};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  std::uint64_t lcg = 12345;
  std::vector<double> trace;
  Reading r;
  for (int n = 0; n < 5000; ++n) {
    device.read(r);
    lcg = lcg * 6364136223846793005ULL + 1442695040888963407ULL;
    const double noise = static_cast<double>(lcg >> 11) / 9007199254740992.0 - 0.5;
    device.write(-300.0 * r.position + 4.0 * noise);
    const auto s = plant.snapshot();
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

// The loopback's keys come from its registry entry (drivers/registry.hpp):
// the messages below are the registry's, naming the dotted key and what is
// accepted. The period is the loop's ([loop] period, given at configure()),
// no longer a loopback key.
TEST(LoopbackConfigKeys, EveryDocumentedKeyParsesWithItsDefault) {
  const auto& parameters = loopback_parameters();
  std::set<std::string> names;
  std::map<std::string, hapticd::drivers::ParameterValue, std::less<>> all;
  for (const auto& p : parameters) {
    EXPECT_FALSE(p.help.empty()) << p.name;
    EXPECT_TRUE(names.insert(p.name).second) << "duplicate " << p.name;
    if (!p.default_value) continue;  // the hand table
    const std::map<std::string, hapticd::drivers::ParameterValue, std::less<>> one{
        {p.name, *p.default_value}};
    EXPECT_NO_THROW(loopback_config_from(hapticd::drivers::DriverParameters("loopback", parameters, one)))
        << p.name << "=" << hapticd::drivers::to_text(*p.default_value);
    all[p.name] = *p.default_value;
  }
  for (const char* key : {"motion", "plant", "mass", "damping", "coulomb", "motor_mass", "body_mass",
                          "motor_damping", "body_damping", "cable_stiffness", "cable_damping", "sensor",
                          "counts", "max_force", "delay", "hand"}) {
    EXPECT_EQ(names.count(key), 1U) << key;
  }
  // All defaults together give the default config.
  const LoopbackConfig parsed =
      loopback_config_from(hapticd::drivers::DriverParameters("loopback", parameters, all));
  const LoopbackConfig defaults;
  EXPECT_EQ(parsed.mass, defaults.mass);
  EXPECT_EQ(parsed.damping, defaults.damping);
  EXPECT_EQ(parsed.counts, defaults.counts);
  EXPECT_EQ(parsed.max_force, defaults.max_force);
  EXPECT_EQ(parsed.two_mass.cable_stiffness, defaults.two_mass.cable_stiffness);
}

TEST(LoopbackConfigKeys, MotionSelectsDefaultsAndKeysOverride) {
  const LoopbackConfig linear = parse_loopback_config("mass=0.2 motion=linear delay=2 plant=two-mass");
  EXPECT_EQ(linear.motion, Motion::linear);
  EXPECT_EQ(linear.mass, 0.2);  // given after motion's defaults, whatever the order
  EXPECT_NEAR(linear.counts, 1.0 / 3.14e-6, 1e-6);
  EXPECT_EQ(linear.max_force, 10.0);
  EXPECT_EQ(linear.damping, 0.0);
  EXPECT_EQ(linear.delay, 2);
  EXPECT_EQ(linear.plant, PlantKind::two_mass);
  const LoopbackConfig rotary = parse_loopback_config("");
  EXPECT_EQ(rotary.motion, Motion::rotary);
  EXPECT_EQ(rotary.mass, 0.01);
  EXPECT_EQ(rotary.counts, 16384.0);
  EXPECT_EQ(rotary.max_force, 1.2);
  EXPECT_EQ(rotary.damping, 0.002);
}

/// The refusal of `text` names `key` (structurally) and contains `fragment`.
void expect_config_error(std::string_view text, std::string_view key, std::string_view fragment) {
  try {
    parse_loopback_config(text);
    ADD_FAILURE() << "accepted: " << text;
  } catch (const hapticd::drivers::ParameterError& e) {
    const std::string message = e.what();
    EXPECT_EQ(e.key(), key) << message;
    EXPECT_NE(message.find(fragment), std::string::npos) << "'" << message << "' lacks '" << fragment << "'";
    EXPECT_EQ(message.find('\n'), std::string::npos);
  } catch (const std::invalid_argument& e) {
    EXPECT_TRUE(key.empty()) << "no key named for " << text << ": " << e.what();
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(LoopbackConfigKeys, ErrorsNameTheKey) {
  expect_config_error(
      "mas=1", "mas",
      "device.loopback.mas is not a parameter of the loopback driver; accepted: motion, plant, mass,");
  expect_config_error(
      "motion=spherical", "motion",
      "device.loopback.motion = \"spherical\" is not accepted; accepted: one of rotary, linear");
  expect_config_error("plant=three-mass", "plant", "accepted: one of rigid, two-mass");
  expect_config_error(
      "mass=heavy", "mass",
      "device.loopback.mass = \"heavy\" is not accepted; accepted: a number in [1e-09, 1e+06]");
  expect_config_error("mass=0", "mass", "is out of range; accepted: a number in [1e-09, 1e+06] kg m^2 | kg");
  expect_config_error("coulomb=-1", "coulomb", "is out of range; accepted: a number in [0, 1e+06]");
  expect_config_error("delay=1.5", "delay", "accepted: a whole number in [0, 64] periods");
  expect_config_error("delay=65", "delay", "is out of range; accepted: a whole number in [0, 64]");
  expect_config_error("sensor=elbow", "sensor", "accepted: one of motor, body");
  expect_config_error("plant=two-mass cable_stiffness=0", "cable_stiffness",
                      "accepted: a number in (0, 1e+09]");
  expect_config_error("max_force", "", "'max_force' is not key=value");
  LoopbackConfig bad;
  bad.mass = -1.0;
  EXPECT_THROW(LoopbackDevice{bad}, std::invalid_argument);
}

// Every number has a finite range: a 1e-300 kg mass or a 1e308 N force is a
// typo, not a device (these were accepted).
TEST(LoopbackConfigKeys, NumbersOutsideTheirRangeAreRefusedNamingIt) {
  expect_config_error(
      "mass=1e-300", "mass",
      "device.loopback.mass = \"1e-300\" is out of range; accepted: a number in [1e-09, 1e+06]");
  expect_config_error("mass=2e6", "mass", "accepted: a number in [1e-09, 1e+06]");
  expect_config_error("damping=1e308", "damping", "accepted: a number in [0, 1e+06]");
  expect_config_error("coulomb=1e7", "coulomb", "accepted: a number in [0, 1e+06]");
  expect_config_error("max_force=1e308", "max_force", "accepted: a number in (0, 1e+06]");
  expect_config_error("counts=0.5", "counts", "accepted: a number in [1, 1e+12]");
  expect_config_error("plant=two-mass motor_mass=1e308", "motor_mass",
                      "accepted: a number in [1e-09, 1e+06]");
  expect_config_error("plant=two-mass body_mass=1e-10", "body_mass", "accepted: a number in [1e-09, 1e+06]");
  expect_config_error("plant=two-mass cable_stiffness=1e10", "cable_stiffness",
                      "accepted: a number in (0, 1e+09]");
  expect_config_error("plant=two-mass cable_damping=2e6", "cable_damping",
                      "accepted: a number in [0, 1e+06]");
  expect_config_error("plant=two-mass body_damping=1e300", "body_damping",
                      "accepted: a number in [0, 1e+06]");
  expect_config_error("plant=two-mass motor_damping=1e300", "motor_damping",
                      "accepted: a number in [0, 1e+06]");
  // The bounds themselves are accepted.
  EXPECT_NO_THROW(parse_loopback_config("mass=1e-9 damping=1e6 max_force=1e6 counts=1"));
  EXPECT_NO_THROW(parse_loopback_config("mass=1e6 counts=1e12 coulomb=1e6"));
  // The simulator checks the same ranges (a config built in code).
  LoopbackConfig tiny;
  tiny.mass = 1e-300;
  EXPECT_THROW(LoopbackDevice{tiny}, hapticd::drivers::ParameterError);
  LoopbackConfig fast;
  fast.period_s = 1e-300;
  EXPECT_THROW(LoopbackDevice{fast}, hapticd::drivers::ParameterError);
}

}  // namespace

}  // namespace loopback_fault_config_test
