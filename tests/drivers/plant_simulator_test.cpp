// The shared plant simulator is what the loopback driver is: a run through
// the Device interface and a run of the simulator alone, with the same
// commands, agree bit for bit (DRIVERS.md: a peer run can be compared sample
// by sample with a loopback run of the same plant and delay).

#include <gtest/gtest.h>

#include <cmath>

#include "drivers/loopback/loopback_device.hpp"
#include "drivers/simulation/plant_simulator.hpp"
#include "tests/support/loopback_start.hpp"

namespace plant_simulator_test {

namespace {

using hapticd::drivers::IoResult;
using hapticd::drivers::Reading;
using namespace hapticd::drivers::simulation;
using hapticd::drivers::loopback::LoopbackDevice;

void expect_same_run(const PlantConfig& config, const char* hand) {
  hapticd::testing::LoopbackRig device_rig{config, parse_hand_script(hand)};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  PlantSimulator simulator(config, parse_hand_script(hand));
  hapticd::testing::start(device);
  simulator.reset_actuator();
  for (int n = 0; n < 3000; ++n) {
    Reading r;
    double position = 0.0;
    ASSERT_EQ(device.read(r), IoResult::ok);
    ASSERT_EQ(simulator.sense(position), IoResult::ok);
    ASSERT_EQ(r.position, position) << "period " << n;  // bit-identical, not close
    // A torque that depends on the reading, as a scene's does.
    const double force = -2.0 * position + 0.1 * std::sin(0.01 * n);
    ASSERT_EQ(device.write(force), IoResult::ok);
    ASSERT_EQ(simulator.step(force), IoResult::ok);
  }
  const PlantSnapshot a = plant.snapshot();
  const PlantSnapshot b = simulator.snapshot();
  EXPECT_EQ(a.period, b.period);
  EXPECT_EQ(a.motor_position, b.motor_position);
  EXPECT_EQ(a.body_position, b.body_position);
  EXPECT_EQ(a.applied_force, b.applied_force);
  EXPECT_EQ(a.hand_force, b.hand_force);
}

TEST(PlantSimulator, LoopbackRunIsTheSimulatorRunBitForBit) {
  PlantConfig rigid = PlantConfig::defaults(hapticd::drivers::Motion::rotary);
  rigid.coulomb = 0.01;
  rigid.delay = 3;
  expect_same_run(rigid, "mode=hold trajectory=step amplitude=0.785398 at=0.2 ideal=false release_at=2");
  PlantConfig two_mass = PlantConfig::defaults(hapticd::drivers::Motion::linear);
  two_mass.plant = PlantKind::two_mass;
  two_mass.sensor = hapticd::world::Sensor::body;
  expect_same_run(two_mass, "mode=force force=0.5 at=0.1");
}

}  // namespace

}  // namespace plant_simulator_test
