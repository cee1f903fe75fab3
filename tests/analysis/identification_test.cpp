// Identification of the device model from the chirp's frequency response:
// the rigid model within 2 % and the two-mass model within 5 % at the
// encoder quantization of the loopback device, the parameters the data
// cannot tell apart, and the conditions that identify nothing.
//
// The plant is simulated here independently of the fit's model: the exact
// ZOH step of world::discretize_zoh, Coulomb friction as the loopback
// applies it (-F_c sign(v) held over the period, on the mass or body), a
// hand spring on the body, floor quantization, an output delay line.

#include "analysis/identification.hpp"

#include <cmath>
#include <cstdio>
#include <deque>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "world/chirp_scene.hpp"
#include "world/integrator.hpp"

namespace hapticd::analysis::identification_test {
namespace {

constexpr double T = 1e-3;

struct Run {
  std::vector<double> position, force;
  std::int64_t sweep_steps = 0;
};

struct Bench {
  world::LinearPlant plant;
  world::Sensor sensor = world::Sensor::motor;
  int delay = 0;
  double resolution = 3.14e-6;
  double coulomb = 0.0;
  double hand_stiffness = 0.0;  ///< on the body (a spring hand)
  double hand_damping = 0.0;
  bool hold_body = false;  ///< body pinned (two-mass)
};

Run excite(const Bench& bench, const world::ChirpParameters& chirp_parameters) {
  world::ChirpScene chirp(chirp_parameters, T);
  world::LinearPlant plant = bench.plant;
  const Eigen::Index n = plant.dynamics.a.rows();
  const Eigen::Index body = n == 2 ? 0 : 1;
  const Eigen::Index body_v = n == 2 ? 1 : 3;
  if (bench.hand_stiffness > 0.0) {
    const double inv_m = plant.dynamics.b(body_v, world::hand_force_input);
    plant.dynamics.a(body_v, body) -= bench.hand_stiffness * inv_m;
    plant.dynamics.a(body_v, body_v) -= bench.hand_damping * inv_m;
  }
  const world::DiscreteStateSpace d = world::discretize_zoh(plant.dynamics, T);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  std::deque<double> line(static_cast<std::size_t>(bench.delay), 0.0);
  Run run;
  run.sweep_steps = chirp.sweep_steps();
  for (std::int64_t k = 0; k < chirp.duration_steps(); ++k) {
    double y = plant.position(bench.sensor) * x;
    y = std::floor(y / bench.resolution) * bench.resolution;
    const double f = chirp.step(y);
    run.position.push_back(y);
    run.force.push_back(f);
    line.push_back(f);
    const double applied = line.front();
    line.pop_front();
    const double v = x(body_v);
    const double friction = v > 0 ? -bench.coulomb : (v < 0 ? bench.coulomb : 0.0);
    x = d.ad * x + d.bd * Eigen::Vector2d(applied, friction);
    if (bench.hold_body) x(body) = x(body_v) = 0.0;
  }
  return run;
}

FrequencyResponse response_of(const Run& run, double f0, double f1) {
  return measure_frequency_response(run.position, run.force, T, run.sweep_steps, f0 * 1.05, f1 / 1.05);
}

void expect_within(const Identification& id, const char* name, double truth, double tolerance) {
  const IdentifiedParameter* p = id.find(name);
  ASSERT_NE(p, nullptr) << name;
  std::printf("  %-24s %12.6g +- %-10.3g (configured %g: %+.3f %%)\n", name, p->value, p->half_width, truth,
              100 * (p->value / truth - 1));
  EXPECT_NEAR(p->value, truth, tolerance * std::abs(truth)) << name;
}

TEST(Identification, RigidTableIFreeWithDelayAndFriction) {
  for (const int delay : {0, 3}) {
    Bench bench;
    bench.plant = world::RigidPlant{5.4, 3.5}.model();
    bench.delay = delay;
    bench.coulomb = 0.4;
    const world::ChirpParameters c{5.0, 0.5, 50.0, 20.0, 62.0};
    const FrequencyResponse data = response_of(excite(bench, c), c.start_frequency, c.end_frequency);
    const Identification id =
        identify(data, IdentifiedPlant::rigid, HandCondition::free, world::Motion::linear);
    std::printf("rigid, delay %d, fit error %.2e, %zu bins:\n", delay, id.fit_error, data.size());
    expect_within(id, "mass", 5.4, 0.02);
    expect_within(id, "damping", 3.5, 0.02);
    expect_within(id, "coulomb", 0.4, 0.05);
    EXPECT_NEAR(id.delay_periods, delay, 0.02);
    EXPECT_TRUE(id.complete);
    EXPECT_TRUE(id.confounded.empty());
  }
}

TEST(Identification, RigidUndampedLinearLoopbackDefault) {
  Bench bench;
  bench.plant = world::RigidPlant{0.1, 0.0}.model();
  const world::ChirpParameters c{1.0, 0.5, 100.0, 10.0, 32.0};
  const FrequencyResponse data = response_of(excite(bench, c), c.start_frequency, c.end_frequency);
  const Identification id =
      identify(data, IdentifiedPlant::rigid, HandCondition::free, world::Motion::linear);
  expect_within(id, "mass", 0.1, 0.02);
  const IdentifiedParameter* b = id.find("damping");
  EXPECT_LT(std::abs(b->value), 1e-3);  // no damping to find: ~0 within its interval
  EXPECT_LE(std::abs(b->value), b->half_width + 1e-6);
}

TEST(Identification, TwoMassTableIFree) {
  Bench bench;
  bench.plant = world::TwoMassPlant{}.model();
  bench.delay = 1;
  const world::ChirpParameters c{5.0, 0.5, 200.0, 20.0, 62.0};
  const FrequencyResponse data = response_of(excite(bench, c), c.start_frequency, c.end_frequency);
  const Identification id =
      identify(data, IdentifiedPlant::two_mass, HandCondition::free, world::Motion::linear);
  std::printf("two-mass, fit error %.2e, %zu bins:\n", id.fit_error, data.size());
  const world::TwoMassPlant p;
  expect_within(id, "motor_mass", p.motor_mass, 0.05);
  expect_within(id, "body_mass", p.body_mass, 0.05);
  expect_within(id, "cable_stiffness", p.cable_stiffness, 0.05);
  expect_within(id, "cable_damping", p.cable_damping, 0.05);
  EXPECT_NEAR(id.delay_periods, 1.0, 0.02);
  // b_m (0.1 of the 3.5 N s/m to ground) shows in the motor's response only
  // through b_m + b_d at low frequency: the fit says so, and the sum is right.
  ASSERT_EQ(id.confounded.size(), 1u);
  const Confounded& c2 = id.confounded.front();
  std::printf("  cannot tell %s from %s (correlation %.4f): %s = %.5g +- %.3g\n", c2.first.c_str(),
              c2.second.c_str(), c2.correlation, c2.sum_name.c_str(), c2.sum, c2.sum_half_width);
  EXPECT_EQ(c2.first, "motor_damping");
  EXPECT_EQ(c2.second, "body_damping");
  EXPECT_EQ(c2.sum_name, "motor_damping + body_damping");
  EXPECT_NEAR(c2.sum, p.motor_damping + p.body_damping, 0.05 * (p.motor_damping + p.body_damping));
  EXPECT_LT(c2.sum_half_width, 0.01 * c2.sum);
  expect_within(id, "body_damping", p.body_damping, 0.05);  // the larger share
  const IdentifiedParameter* bm = id.find("motor_damping");
  EXPECT_NEAR(bm->value, p.motor_damping, bm->half_width);  // within its (wide) interval
  EXPECT_TRUE(id.complete);
}

TEST(Identification, TwoMassBodyHeldGivesTheCableOnly) {
  // Diaz & Gil's cable experiment: the body locked, the motor excited.
  Bench bench;
  bench.plant = world::TwoMassPlant{}.model();
  bench.hold_body = true;
  const world::ChirpParameters c{5.0, 2.0, 200.0, 10.0, 30.5};
  const FrequencyResponse data = response_of(excite(bench, c), c.start_frequency, c.end_frequency);
  const Identification id =
      identify(data, IdentifiedPlant::two_mass, HandCondition::hold, world::Motion::linear);
  const world::TwoMassPlant p;
  expect_within(id, "motor_mass", p.motor_mass, 0.05);
  expect_within(id, "cable_stiffness", p.cable_stiffness, 0.05);
  expect_within(id, "motor_and_cable_damping", p.motor_damping + p.cable_damping, 0.05);
  EXPECT_FALSE(id.complete);
  EXPECT_FALSE(id.notes.empty());
}

TEST(Identification, RigidHeldThroughASpring) {
  Bench bench;
  bench.plant = world::RigidPlant{5.4, 3.5}.model();
  bench.hand_stiffness = 400.0;
  bench.hand_damping = 2.0;
  const world::ChirpParameters c{5.0, 0.5, 50.0, 20.0, 62.0};
  const FrequencyResponse data = response_of(excite(bench, c), c.start_frequency, c.end_frequency);
  const Identification id =
      identify(data, IdentifiedPlant::rigid, HandCondition::spring, world::Motion::linear);
  expect_within(id, "mass", 5.4, 0.02);
  expect_within(id, "hand_stiffness", 400.0, 0.02);
  expect_within(id, "damping", 5.5, 0.02);  // b + the hand's: one number
  EXPECT_EQ(id.find("damping")->note, "includes the hand's damping");
  EXPECT_FALSE(id.complete);
}

TEST(Identification, RefusesWhatIdentifiesNothing) {
  FrequencyResponse empty;
  empty.period_s = T;
  empty.frequency_hz = {1.0, 2.0, 3.0, 4.0};
  empty.force = empty.position = empty.friction_sign = std::vector<std::complex<double>>(4, 1.0);
  EXPECT_THROW(identify(empty, IdentifiedPlant::rigid, HandCondition::hold, world::Motion::linear),
               std::invalid_argument);
  EXPECT_THROW(identify(empty, IdentifiedPlant::two_mass, HandCondition::hold, world::Motion::linear,
                        world::Sensor::body),
               std::invalid_argument);
  // A rigid device's data offered as two-mass: no cable mode in the band.
  Bench bench;
  bench.plant = world::RigidPlant{5.4, 3.5}.model();
  const world::ChirpParameters c{5.0, 0.5, 50.0, 10.0, 32.0};
  const FrequencyResponse data = response_of(excite(bench, c), c.start_frequency, c.end_frequency);
  try {
    identify(data, IdentifiedPlant::two_mass, HandCondition::free, world::Motion::linear);
    ADD_FAILURE() << "a rigid response fitted as two-mass";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no cable mode"), std::string::npos) << e.what();
  }
  std::vector<double> y(100, 0.0), u(100, 0.0);
  EXPECT_THROW(measure_frequency_response(y, u, T, 1000, 1.0, 10.0), std::invalid_argument);
}

}  // namespace
}  // namespace hapticd::analysis::identification_test
