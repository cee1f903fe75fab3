// The scripted hand: ideal hold (step, sine, ramp), release_at, force,
// impedance, stiff non-ideal hold, hand-over while running, and parsing.

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <string>
#include <thread>

#include "drivers/loopback/loopback_device.hpp"
#include "tests/support/loopback_start.hpp"

namespace loopback_hand_test {

namespace {

using hapticd::drivers::IoResult;
using hapticd::drivers::Motion;
using hapticd::drivers::Reading;
using namespace hapticd::drivers::loopback;
using namespace hapticd::drivers::simulation;

constexpr double pi = 3.14159265358979323846;

LoopbackConfig wheel() {
  LoopbackConfig config = LoopbackConfig::defaults(Motion::rotary);
  config.mass = 0.01;
  config.damping = 0.0;  // frictionless: the expectations below are for an undamped wheel
  return config;
}

TEST(LoopbackHand, IdealHoldTracksStepExactlyWhileTheMotorPushes) {
  // Freudenberg 2.1: the hand turns the wheel 45 degrees at t = 0.5 s and
  // holds it; the virtual spring torque the scene commands is what the hand feels.
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{
      config, parse_hand_script("mode=hold trajectory=step amplitude=0.785398 at=0.5")};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  const double res = config.resolution();
  const double k = 1.0;  // N m/rad virtual spring
  Reading r;
  for (int n = 1; n <= 1500; ++n) {
    ASSERT_EQ(device.read(r), IoResult::ok);
    device.write(-k * r.position);
    const double t = n * config.period_s;
    const double expected = t >= 0.5 ? 0.785398 : 0.0;
    const auto s = plant.snapshot();
    ASSERT_EQ(s.motor_position, expected) << "n=" << n;
    ASSERT_EQ(s.motor_velocity, 0.0) << "n=" << n;
    if (n > 501) {  // holding still: the hand provides the reaction to the motor
      ASSERT_NEAR(s.hand_force, -s.applied_force, 1e-9) << "n=" << n;
      ASSERT_NEAR(s.hand_force, k * std::floor(0.785398 / res) * res, 1e-9);
    }
  }
  device.read(r);
  EXPECT_NEAR(r.position, 0.785398, res);
}

TEST(LoopbackHand, IdealHoldTracksSineExactlyAtSampleTimes) {
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{
      config, parse_hand_script("mode=hold trajectory=sine amplitude=0.0872665 frequency=1 phase=0")};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  for (int n = 1; n <= 2000; ++n) {
    device.write(0.1 * std::sin(n * 0.01));
    const double t = n * config.period_s;
    const auto s = plant.snapshot();
    ASSERT_NEAR(s.motor_position, 0.0872665 * std::sin(2.0 * pi * t), 1e-15) << "n=" << n;
    ASSERT_NEAR(s.motor_velocity, 0.0872665 * 2.0 * pi * std::cos(2.0 * pi * t), 1e-13) << "n=" << n;
  }
}

TEST(LoopbackHand, IdealHoldHandForceIsInertialReaction) {
  // Zero motor force: the hand force is what accelerates the inertia along
  // the sine. The piecewise-constant force that lands a mass on r(t + T)
  // from (r(t), r'(t)) is J r'' at t + T/3, to O((w T)^2). The first step
  // is the impulse that takes the wheel from rest to the sine's velocity.
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{
      config, parse_hand_script("mode=hold trajectory=sine amplitude=0.1 frequency=2")};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  const double w = 2.0 * pi * 2.0;
  device.write(0.0);
  EXPECT_NEAR(plant.snapshot().hand_force, 2.0 * config.mass * 0.1 * w / config.period_s, 1e-3);
  for (int n = 2; n <= 1000; ++n) {
    device.write(0.0);
    const double t = (n - 1 + 1.0 / 3.0) * config.period_s;
    const double expected = -config.mass * 0.1 * w * w * std::sin(w * t);
    ASSERT_NEAR(plant.snapshot().hand_force, expected, 1e-3 * config.mass * 0.1 * w * w) << "n=" << n;
  }
}

TEST(LoopbackHand, RampHoldFollowsRateThenStops) {
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{
      config, parse_hand_script("mode=hold trajectory=ramp rate=2 from=0.1 to=0.5 at=0.1")};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  for (int n = 1; n <= 500; ++n) {
    device.write(0.0);
    const double t = n * config.period_s;
    const double expected = t <= 0.1 ? 0.1 : std::min(0.5, 0.1 + 2.0 * (t - 0.1));
    ASSERT_NEAR(plant.snapshot().motor_position, expected, 1e-12) << "n=" << n;
  }
  EXPECT_EQ(plant.snapshot().motor_velocity, 0.0);
}

TEST(LoopbackHand, ReleaseAtLetsGoAtTheRightSample) {
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{config,
                                           parse_hand_script("mode=hold position=0.1 release_at=0.2")};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  const double force = 0.01;
  for (int n = 1; n <= 400; ++n) {
    device.write(force);
    const double t = n * config.period_s;
    const auto s = plant.snapshot();
    if (n <= 200) {
      ASSERT_EQ(s.motor_position, 0.1) << "n=" << n;
      ASSERT_FALSE(s.hand_released);
    } else {
      const double tr = t - 0.2;
      ASSERT_NEAR(s.motor_position, 0.1 + force * tr * tr / (2.0 * config.mass), 1e-12) << "n=" << n;
      ASSERT_TRUE(s.hand_released);
      ASSERT_EQ(s.hand_force, 0.0);
    }
  }
}

TEST(LoopbackHand, ForceModeStepsAtTheGivenTime) {
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{config, parse_hand_script("mode=force force=0.2 at=1")};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  for (int n = 1; n <= 1500; ++n) {
    device.write(0.0);
    const double t = n * config.period_s;
    const double active = std::max(0.0, t - 1.0);
    const auto s = plant.snapshot();
    ASSERT_NEAR(s.motor_position, 0.2 * active * active / (2.0 * config.mass), 1e-12) << "n=" << n;
    ASSERT_EQ(s.hand_force, (n - 1) * config.period_s >= 1.0 ? 0.2 : 0.0) << "n=" << n;
  }
}

TEST(LoopbackHand, ImpedanceIsAnExactDampedSpring) {
  // J x'' + b x' + k x = 0 from x(0) = 0.1: underdamped closed form.
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  plant.set_initial_state(0.1, 0.0);
  plant.set_hand(parse_hand_script("mode=impedance stiffness=50 damping=1 position=0"));
  hapticd::testing::start(device);
  const double m = config.mass, k = 50.0, b = 1.0;
  const double wn = std::sqrt(k / m), zeta = b / (2.0 * std::sqrt(k * m));
  const double wd = wn * std::sqrt(1.0 - zeta * zeta);
  for (int n = 1; n <= 1000; ++n) {
    device.write(0.0);
    const double t = n * config.period_s;
    const double x = 0.1 * std::exp(-zeta * wn * t) * (std::cos(wd * t) + zeta * wn / wd * std::sin(wd * t));
    ASSERT_NEAR(plant.snapshot().motor_position, x, 1e-12) << "n=" << n;
  }
}

TEST(LoopbackHand, ImpedanceStaticBalanceWithMotorForce) {
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{
      config, parse_hand_script("mode=impedance stiffness=50 damping=1 position=0.2")};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  for (int n = 0; n < 3000; ++n) device.write(0.5);
  const auto s = plant.snapshot();
  EXPECT_NEAR(s.motor_position, 0.2 + 0.5 / 50.0, 1e-12);
  EXPECT_NEAR(s.hand_force, -0.5, 1e-9);
}

TEST(LoopbackHand, StiffNonIdealHoldFollowsClosely) {
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{
      config, parse_hand_script("mode=hold ideal=false trajectory=step amplitude=0.5 at=0.1")};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  for (int n = 1; n <= 400; ++n) {
    device.write(0.0);
    // A spring, not a constraint: just after the step the wheel is still on its way.
    if (n == 102) {
      EXPECT_LT(plant.snapshot().motor_position, 0.25);
    }
  }
  EXPECT_NEAR(plant.snapshot().motor_position, 0.5, 1e-6);
  EXPECT_NEAR(plant.snapshot().hand_force, 0.0, 1e-3);
}

TEST(LoopbackHand, ScriptTimesCountFromActivation) {
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  for (int n = 0; n < 100; ++n) device.write(0.0);
  plant.set_hand(parse_hand_script("mode=hold trajectory=step amplitude=0.3 at=0.05"));
  for (int n = 1; n <= 100; ++n) {
    device.write(0.0);
    ASSERT_EQ(plant.snapshot().motor_position, n * config.period_s >= 0.05 ? 0.3 : 0.0) << n;
  }
}

TEST(LoopbackHand, SetHandFromAnotherThreadWhileRunning) {
  const LoopbackConfig config = wheel();
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  std::atomic<bool> done{false};
  std::atomic<int> torn{0};
  std::thread control([&] {
    int i = 0;
    while (!done.load()) {
      const auto s = plant.snapshot();  // consistent: time and period from the same period
      if (s.time_s != static_cast<double>(s.period) * config.period_s) torn.fetch_add(1);
      plant.set_hand(i++ % 2 == 0 ? std::string("mode=impedance stiffness=20 damping=0.5 position=0.1")
                                  : std::string("mode=hold position=0.1"));
    }
  });
  for (int n = 0; n < 20000; ++n) {
    ASSERT_EQ(device.write(0.0), IoResult::ok);
    ASSERT_TRUE(std::isfinite(plant.snapshot().motor_position));
  }
  done.store(true);
  control.join();
  EXPECT_EQ(torn.load(), 0);
  plant.set_hand("mode=hold position=0.1");
  device.write(0.0);
  EXPECT_EQ(plant.snapshot().motor_position, 0.1);
  EXPECT_EQ(plant.hand().to_text(), parse_hand_script("mode=hold position=0.1").to_text());
}

TEST(HandScriptParse, AcceptsTheDocumentedForms) {
  const HandScript step = parse_hand_script("mode=hold trajectory=step amplitude=0.785398 at=0.5");
  EXPECT_EQ(step.mode, HandMode::hold);
  EXPECT_TRUE(step.ideal);
  EXPECT_EQ(step.trajectory.kind, TrajectoryKind::step);
  EXPECT_EQ(step.trajectory.amplitude, 0.785398);
  EXPECT_EQ(step.trajectory.at, 0.5);
  const HandScript sine =
      parse_hand_script("mode=hold trajectory=sine amplitude=0.0872665 frequency=1 phase=0");
  EXPECT_EQ(sine.trajectory.frequency, 1.0);
  EXPECT_EQ(parse_hand_script("mode=free").mode, HandMode::free);
  const HandScript force = parse_hand_script("mode=force force=0.2 at=1 release_at=2.0");
  EXPECT_EQ(force.force, 0.2);
  EXPECT_EQ(force.force_at, 1.0);
  EXPECT_EQ(force.release_at, 2.0);
  const HandScript imp = parse_hand_script("mode=impedance stiffness=50 damping=1 position=0");
  EXPECT_EQ(imp.stiffness, 50.0);
  EXPECT_EQ(imp.damping, 1.0);
  for (const HandScript& s : {step, sine, force, imp})
    EXPECT_EQ(parse_hand_script(s.to_text()), s) << s.to_text();
}

void expect_error(std::string_view text, std::string_view fragment) {
  std::string error;
  EXPECT_FALSE(try_parse_hand_script(text, error).has_value()) << text;
  EXPECT_NE(error.find(fragment), std::string::npos) << "'" << error << "' lacks '" << fragment << "'";
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  EXPECT_EQ(error.rfind("hand script: ", 0), 0U) << error;
}

TEST(HandScriptParse, ErrorsNameTheKeyAndWhatIsAccepted) {
  expect_error("mode=grab", "mode=grab is not one of free, hold, force, impedance");
  expect_error("trajectory=step", "missing mode");
  expect_error("mode=hold amplitud=1", "unknown key 'amplitud'; accepted: mode, trajectory");
  expect_error("mode=free amplitude=1",
               "key 'amplitude' does not apply to mode=free; accepted: mode, release_at");
  expect_error("mode=hold trajectory=sine amplitude=1 frequency=1 rate=2",
               "key 'rate' does not apply to mode=hold trajectory=sine");
  expect_error("mode=hold trajectory=zigzag", "trajectory=zigzag is not one of constant, step, ramp, sine");
  expect_error("mode=force", "mode=force needs force");
  expect_error("mode=impedance position=0", "mode=impedance needs stiffness");
  expect_error("mode=hold trajectory=step", "needs amplitude");
  expect_error("mode=force force=abc", "force=abc is not a finite number");
  expect_error("mode=force force=1 force=2", "key 'force' given twice");
  expect_error("mode=hold stiffness=10", "only with ideal=false");
  expect_error("mode=hold ideal=maybe", "ideal=maybe is not one of true, false");
  expect_error("mode=impedance stiffness=-1", "stiffness must be > 0");
  expect_error("mode=hold trajectory=sine amplitude=1 frequency=0", "frequency must be > 0");
  expect_error("mode=hold junk", "'junk' is not key=value");
  EXPECT_THROW(parse_hand_script("mode=grab"), std::invalid_argument);
}

// Found by fuzzing (tests/fuzz/regressions/hand_script/): every number was
// accepted if finite, and a sine at 1e308 Hz gave the simulated hand a NaN
// position (sin(inf)), which latched the loop's fault. Now each key has a
// range, named in the refusal, and what it accepts stays finite.
TEST(HandScriptParse, NumbersHaveRangesThatKeepTheTrajectoryFinite) {
  expect_error("mode=hold trajectory=sine amplitude=0.1 frequency=1e308",
               "frequency=1e308 is out of range; accepted: -10000 to 10000");
  expect_error("mode=hold trajectory=sine amplitude=1e308 frequency=1", "amplitude=1e308 is out of range");
  expect_error("mode=hold trajectory=step amplitude=1 at=1e300", "at=1e300 is out of range");
  expect_error("mode=force force=1e7", "force=1e7 is out of range; accepted: -1e+06 to 1e+06");
  const auto edge = parse_hand_script("mode=hold trajectory=sine amplitude=1000 frequency=10000 phase=1e6");
  for (const double t : {0.0, 1.0, 1e9}) {
    const auto r = edge.trajectory.at_time(t);
    EXPECT_TRUE(std::isfinite(r.position) && std::isfinite(r.velocity)) << t;
  }
}

}  // namespace

}  // namespace loopback_hand_test
