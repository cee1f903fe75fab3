// The loopback device's plant against closed forms: free mass, viscous
// damping, Coulomb friction with stiction, encoder, saturation, delay,
// two-mass static deflection and cable mode.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <vector>

#include <Eigen/Dense>

#include "drivers/loopback/loopback_device.hpp"
#include "tests/support/loopback_start.hpp"

namespace loopback_plant_test {

namespace {

using hapticd::drivers::IoResult;
using hapticd::drivers::Motion;
using hapticd::drivers::Reading;
using namespace hapticd::drivers::loopback;
using namespace hapticd::drivers::simulation;

LoopbackConfig rotary_rigid(double mass, double damping = 0.0) {
  LoopbackConfig config = LoopbackConfig::defaults(Motion::rotary);
  config.mass = mass;
  config.damping = damping;
  return config;
}

TEST(LoopbackPlant, FreeMassUnderConstantForceIsParabolaAtSampleTimes) {
  const LoopbackConfig config = rotary_rigid(0.01);
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  const double force = 0.01;
  const double res = config.resolution();
  for (int n = 1; n <= 500; ++n) {
    ASSERT_EQ(device.write(force), IoResult::ok);
    const double t = n * config.period_s;
    const auto s = plant.snapshot();
    EXPECT_EQ(s.period, static_cast<std::uint64_t>(n));
    EXPECT_NEAR(s.motor_position, force * t * t / (2.0 * config.mass), 1e-12) << "n=" << n;
    EXPECT_NEAR(s.motor_velocity, force * t / config.mass, 1e-12) << "n=" << n;
    Reading r;
    ASSERT_EQ(device.read(r), IoResult::ok);
    // Encoder truncation: the reading lies in (x - res, x].
    EXPECT_LE(r.position, s.motor_position + 1e-12);
    EXPECT_GT(r.position, s.motor_position - res - 1e-12);
  }
}

TEST(LoopbackPlant, ViscousDampingMatchesClosedForm) {
  LoopbackConfig config = LoopbackConfig::defaults(Motion::linear);
  config.mass = 0.1;
  config.damping = 2.0;
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  const double f = 1.0, m = config.mass, b = config.damping;
  for (int n = 1; n <= 2000; ++n) {
    device.write(f);
    const double t = n * config.period_s;
    const double x = f / b * t - f * m / (b * b) * (1.0 - std::exp(-b * t / m));
    const double v = f / b * (1.0 - std::exp(-b * t / m));
    const auto s = plant.snapshot();
    ASSERT_NEAR(s.body_position, x, 1e-12) << "n=" << n;
    ASSERT_NEAR(s.body_velocity, v, 1e-12) << "n=" << n;
  }
}

TEST(LoopbackPlant, CoulombBelowLevelStaysAtRest) {
  LoopbackConfig config = rotary_rigid(0.01);
  config.coulomb = 0.1;
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  for (int n = 0; n < 1000; ++n) device.write(n % 2 == 0 ? 0.099 : -0.05);
  const auto s = plant.snapshot();
  EXPECT_EQ(s.motor_position, 0.0);
  EXPECT_EQ(s.motor_velocity, 0.0);
  EXPECT_TRUE(s.stuck);
  EXPECT_DOUBLE_EQ(s.friction_force, 0.05);  // stiction balances the last load (-0.05)
}

TEST(LoopbackPlant, CoulombAboveLevelAcceleratesWithNetForce) {
  LoopbackConfig config = rotary_rigid(0.01);
  config.coulomb = 0.1;
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  for (const double force : {0.3, -0.3}) {
    device.disable();
    plant.set_initial_state(0.0, 0.0);
    hapticd::testing::start(device);
    const auto start = plant.snapshot();
    for (int n = 1; n <= 300; ++n) {
      device.write(force);
      const double t = n * config.period_s;
      const double net = force - std::copysign(config.coulomb, force);
      const auto s = plant.snapshot();
      ASSERT_NEAR(s.motor_position, net * t * t / (2.0 * config.mass), 1e-12) << "F=" << force << " n=" << n;
      ASSERT_FALSE(s.stuck);
    }
    EXPECT_EQ(start.motor_position, 0.0);
  }
}

TEST(LoopbackPlant, CoulombSlidingMassStopsAndSticks) {
  LoopbackConfig config = rotary_rigid(0.01);
  config.coulomb = 0.1;  // deceleration Fc/m = 10 rad/s^2
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  plant.set_initial_state(0.0, 1.0);
  hapticd::testing::start(device);
  for (int n = 1; n <= 400; ++n) device.write(0.05);  // below the friction level
  // v0^2 / (2 (Fc - F)/m) with F helping: deceleration (0.1 - 0.05)/0.01 = 5.
  const auto s = plant.snapshot();
  EXPECT_TRUE(s.stuck);
  EXPECT_EQ(s.motor_velocity, 0.0);
  EXPECT_NEAR(s.motor_position, 1.0 / (2.0 * 5.0), 1e-12);
  for (int n = 0; n < 100; ++n) device.write(0.05);
  EXPECT_EQ(plant.snapshot().motor_position, s.motor_position);
}

TEST(LoopbackPlant, EncoderQuantizesToCounts) {
  const LoopbackConfig config = rotary_rigid(0.01);
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  const double res = 2.0 * std::acos(-1.0) / 16384.0;
  EXPECT_DOUBLE_EQ(plant.model().position_resolution, res);
  for (int count = -3; count <= 3; ++count) {
    for (const double fraction : {0.001, 0.5, 0.999}) {
      device.disable();
      plant.set_initial_state((count + fraction) * res, 0.0);
      hapticd::testing::start(device);
      Reading r;
      ASSERT_EQ(device.read(r), IoResult::ok);
      EXPECT_NEAR(r.position, count * res, 1e-15) << count << " + " << fraction;
    }
  }
  LoopbackConfig linear = LoopbackConfig::defaults(Motion::linear);
  EXPECT_NEAR(LoopbackDevice(linear).model().position_resolution, 3.14e-6, 1e-18);
}

TEST(LoopbackPlant, SaturationClampsTheForce) {
  LoopbackConfig config = rotary_rigid(0.01);
  config.max_force = 0.8;
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  ASSERT_EQ(device.write(5.0), IoResult::ok);
  EXPECT_EQ(plant.snapshot().applied_force, 0.8);
  EXPECT_EQ(plant.snapshot().commanded_force, 0.8);
  ASSERT_EQ(device.write(-5.0), IoResult::ok);
  EXPECT_EQ(plant.snapshot().applied_force, -0.8);
  ASSERT_EQ(device.write(0.3), IoResult::ok);
  EXPECT_EQ(plant.snapshot().applied_force, 0.3);
  // Position after +0.8, -0.8, +0.3 held one period each.
  const double t = config.period_s, m = config.mass;
  double x = 0.0, v = 0.0;
  for (const double f : {0.8, -0.8, 0.3}) {
    x += v * t + f * t * t / (2.0 * m);
    v += f * t / m;
  }
  EXPECT_NEAR(plant.snapshot().motor_position, x, 1e-15);
}

TEST(LoopbackPlant, NonFiniteCommandIsRefusedAndZeroApplied) {
  hapticd::testing::LoopbackRig device_rig{rotary_rigid(0.01)};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  EXPECT_EQ(device.write(std::nan("")), IoResult::error);
  EXPECT_EQ(plant.snapshot().applied_force, 0.0);
  EXPECT_EQ(device.status().write_errors, 1U);
}

TEST(LoopbackPlant, DelayShiftsResponseByExactlyDSamples) {
  for (const int d : {1, 3, 7}) {
    LoopbackConfig config = rotary_rigid(0.01, 0.01);
    LoopbackConfig delayed = config;
    delayed.delay = d;
    hapticd::testing::LoopbackRig a_rig{config}, b_rig{delayed};
    hapticd::drivers::Device& a = a_rig.device;
    hapticd::drivers::Device& b = b_rig.device;
    hapticd::drivers::loopback::LoopbackDevice& a_plant = a_rig.plant;
    hapticd::drivers::loopback::LoopbackDevice& b_plant = b_rig.plant;
    EXPECT_EQ(b_plant.model().delay_periods, d);
    hapticd::testing::start(a);
    hapticd::testing::start(b);
    std::vector<double> xa, xb;
    for (int n = 0; n < 300; ++n) {
      const double f = 0.5 * std::sin(0.05 * n) + (n == 10 ? 0.3 : 0.0);
      a.write(f);
      b.write(f);
      xa.push_back(a_plant.snapshot().motor_position);
      xb.push_back(b_plant.snapshot().motor_position);
    }
    for (int n = 0; n < d; ++n) EXPECT_EQ(xb[n], 0.0) << "d=" << d;
    for (int n = d; n < 300; ++n) ASSERT_EQ(xb[n], xa[n - d]) << "d=" << d << " n=" << n;
  }
}

TEST(LoopbackPlant, WriteBeforeStartIsRefused) {
  hapticd::testing::LoopbackRig device_rig{rotary_rigid(0.01)};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  Reading r;
  EXPECT_EQ(device.read(r), IoResult::error);
  EXPECT_EQ(device.write(0.1), IoResult::error);
  EXPECT_EQ(plant.snapshot().period, 0U);
  hapticd::testing::start(device);
  EXPECT_EQ(device.write(0.1), IoResult::ok);
  device.disable();
  EXPECT_EQ(device.write(0.1), IoResult::error);
  EXPECT_EQ(plant.snapshot().period, 1U);
  EXPECT_EQ(device.status().state, hapticd::drivers::DeviceState::configured);
}

LoopbackConfig two_mass_linear() {
  LoopbackConfig config = LoopbackConfig::defaults(Motion::linear);
  config.plant = PlantKind::two_mass;
  return config;
}

TEST(LoopbackTwoMass, InfoReportsTotalMassAndFullModel) {
  hapticd::testing::LoopbackRig device_rig{two_mass_linear()};
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  EXPECT_DOUBLE_EQ(plant.model().effective_mass, 5.4);
  EXPECT_DOUBLE_EQ(plant.model().viscous_damping, 3.5);
  ASSERT_TRUE(plant.two_mass().has_value());
  EXPECT_EQ(plant.two_mass()->cable_stiffness, 79.5e3);
  EXPECT_FALSE(LoopbackDevice(rotary_rigid(0.01)).two_mass().has_value());
}

TEST(LoopbackTwoMass, StaticDeflectionUnderHeldBodyIsForceOverCableStiffness) {
  hapticd::testing::LoopbackRig device_rig{two_mass_linear()};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  plant.set_hand(parse_hand_script("mode=hold trajectory=constant position=0"));
  hapticd::testing::start(device);
  const double force = 5.0;
  for (int n = 0; n < 3000; ++n) device.write(force);
  const auto s = plant.snapshot();
  EXPECT_EQ(s.body_position, 0.0);
  EXPECT_NEAR(s.motor_position, force / 79.5e3, 1e-12);
  EXPECT_NEAR(s.motor_velocity, 0.0, 1e-12);
  EXPECT_NEAR(s.hand_force, -force, 1e-6);  // the hand resists the cable pull
  // Motor sensing (default) reads the deflection, quantized to 3.14 um.
  hapticd::drivers::Reading r;
  device.read(r);
  EXPECT_NEAR(r.position, std::floor(force / 79.5e3 / 3.14e-6) * 3.14e-6, 1e-12);
}

TEST(LoopbackTwoMass, BodySensorReadsTheBody) {
  LoopbackConfig config = two_mass_linear();
  config.sensor = hapticd::world::Sensor::body;
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  plant.set_hand(parse_hand_script("mode=hold position=0.01"));
  hapticd::testing::start(device);
  for (int n = 0; n < 100; ++n) device.write(5.0);
  hapticd::drivers::Reading r;
  device.read(r);
  EXPECT_NEAR(r.position, std::floor(0.01 / 3.14e-6) * 3.14e-6, 1e-12);
  EXPECT_NE(plant.snapshot().motor_position, plant.snapshot().body_position);
}

// Polynomial product, coefficients lowest power first.
std::vector<double> poly_mul(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> c(a.size() + b.size() - 1, 0.0);
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (std::size_t j = 0; j < b.size(); ++j) c[i + j] += a[i] * b[j];
  }
  return c;
}

// All roots of c[0] + c[1] s + ... + c[n] s^n by Durand-Kerner (Weierstrass)
// iteration, polished by Newton steps; independent of Eigen's eigensolver.
std::vector<std::complex<double>> durand_kerner(const std::vector<double>& c) {
  const std::size_t n = c.size() - 1;
  const auto eval = [&](std::complex<double> s) {
    std::complex<double> p = c[n];
    for (std::size_t i = n; i-- > 0;) p = p * s + c[i];
    return p / c[n];  // monic
  };
  // Start on a circle of the Cauchy bound radius, at non-symmetric angles.
  double radius = 0.0;
  for (std::size_t i = 0; i < n; ++i) radius = std::max(radius, std::abs(c[i] / c[n]));
  radius += 1.0;
  std::vector<std::complex<double>> z(n);
  for (std::size_t k = 0; k < n; ++k)
    z[k] = std::polar(radius, 0.4 + 2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(n));
  for (int iteration = 0; iteration < 10000; ++iteration) {
    double change = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      std::complex<double> denominator = 1.0;
      for (std::size_t j = 0; j < n; ++j) {
        if (j != k) denominator *= z[k] - z[j];
      }
      const std::complex<double> step = eval(z[k]) / denominator;
      z[k] -= step;
      change = std::max(change, std::abs(step) / std::max(1.0, std::abs(z[k])));
    }
    if (change < 1e-15) break;
  }
  for (auto& root : z) {  // Newton polish with the derivative by Horner
    for (int i = 0; i < 3; ++i) {
      std::complex<double> p = c[n], dp = 0.0;
      for (std::size_t j = n; j-- > 0;) {
        dp = dp * root + p;
        p = p * root + c[j];
      }
      if (dp != 0.0) root -= p / dp;
    }
  }
  return z;
}

TEST(LoopbackTwoMass, CableModeMatchesContinuousEigenvalues) {
  const LoopbackConfig config = two_mass_linear();
  hapticd::testing::LoopbackRig device_rig{config};
  hapticd::drivers::Device& device = device_rig.device;
  hapticd::drivers::loopback::LoopbackDevice& plant = device_rig.plant;
  hapticd::testing::start(device);
  device.write(10.0);  // one-period force pulse, then the free response
  std::vector<double> d;
  for (int n = 0; n < 120; ++n) {
    device.write(0.0);
    const auto s = plant.snapshot();
    d.push_back(s.motor_position - s.body_position);
  }
  // The cable deflection is a sum of three discrete modes (the position
  // integrator does not show in it): fit d[n+3] = a0 d[n] + a1 d[n+1] + a2 d[n+2].
  const int rows = static_cast<int>(d.size()) - 3;
  Eigen::MatrixXd h(rows, 3);
  Eigen::VectorXd y(rows);
  for (int n = 0; n < rows; ++n) {
    h(n, 0) = d[n];
    h(n, 1) = d[n + 1];
    h(n, 2) = d[n + 2];
    y(n) = d[n + 3];
  }
  const Eigen::Vector3d a = h.colPivHouseholderQr().solve(y);
  Eigen::Matrix3d companion = Eigen::Matrix3d::Zero();
  companion(0, 1) = 1.0;
  companion(1, 2) = 1.0;
  companion.row(2) = a.transpose();
  const Eigen::Vector3cd z = companion.eigenvalues();
  std::complex<double> lambda_measured;
  for (int i = 0; i < 3; ++i) {
    if (z(i).imag() > 0.0) lambda_measured = std::log(z(i)) / config.period_s;
  }
  const Eigen::VectorXcd lambda = plant.plant_model().dynamics.a.eigenvalues();
  std::complex<double> lambda_model;
  for (Eigen::Index i = 0; i < lambda.size(); ++i) {
    if (lambda(i).imag() > 0.0) lambda_model = lambda(i);
  }
  ASSERT_GT(lambda_model.imag(), 0.0);
  EXPECT_NEAR(lambda_measured.imag(), lambda_model.imag(), 1e-6 * lambda_model.imag());
  EXPECT_NEAR(lambda_measured.real(), lambda_model.real(), 1e-5 * std::abs(lambda_model));

  // Independently of the device's A: the characteristic polynomial of Diaz &
  // Gil eq. 5-9, p_d(s) p_m(s) - (k_c + b_c s)^2, with Table I written out here.
  const double m_m = 0.3, m_d = 5.1, b_m = 0.1, b_d = 3.4, k_c = 79.5e3, b_c = 15.0;
  const std::vector<double> p_d{k_c, b_d + b_c, m_d};  // eq. 8, lowest power first
  const std::vector<double> p_m{k_c, b_m + b_c, m_m};  // eq. 9
  std::vector<double> quartic = poly_mul(p_d, p_m);
  const std::vector<double> coupling = poly_mul({k_c, b_c}, {k_c, b_c});
  for (std::size_t i = 0; i < coupling.size(); ++i) quartic[i] -= coupling[i];
  ASSERT_EQ(quartic.size(), 5u);
  // By hand: m_d m_m s^4 + (m_d (b_m + b_c) + m_m (b_d + b_c)) s^3
  //   + (k_c m + b_d b_m + b_c (b_d + b_m)) s^2 + k_c b s + 0.
  const double m = m_m + m_d, b = b_m + b_d;
  EXPECT_DOUBLE_EQ(quartic[4], m_d * m_m);
  EXPECT_DOUBLE_EQ(quartic[3], m_d * (b_m + b_c) + m_m * (b_d + b_c));
  EXPECT_DOUBLE_EQ(quartic[2], k_c * m + b_d * b_m + b_c * (b_d + b_m));
  EXPECT_DOUBLE_EQ(quartic[1], k_c * b);
  EXPECT_EQ(quartic[0], 0.0);  // k_c^2 - k_c^2: the free rigid-body mode s = 0
  const std::vector<double> cubic(quartic.begin() + 1, quartic.end());  // divided by s
  const std::vector<std::complex<double>> roots = durand_kerner(cubic);
  ASSERT_EQ(roots.size(), 3u);
  std::complex<double> cable, rigid;
  for (const auto& r : roots) {
    if (r.imag() > 1.0) cable = r;
    if (std::abs(r.imag()) < 1e-9 * std::abs(r)) rigid = r;
  }
  // mpmath polyroots, 30 digits: -26.646514154485796 +- 529.035152657098401 j, -0.648148161616643.
  EXPECT_NEAR(cable.real(), -26.646514154485796, 1e-9);
  EXPECT_NEAR(cable.imag(), 529.035152657098401, 1e-9);
  EXPECT_NEAR(rigid.real(), -0.648148161616643, 1e-12);
  // The model's four eigenvalues are {0, rigid, cable, conj(cable)}.
  std::vector<std::complex<double>> expected{0.0, rigid, cable, std::conj(cable)};
  for (Eigen::Index i = 0; i < lambda.size(); ++i) {
    auto nearest = std::min_element(expected.begin(), expected.end(), [&](auto p, auto q) {
      return std::abs(p - lambda(i)) < std::abs(q - lambda(i));
    });
    EXPECT_LT(std::abs(*nearest - lambda(i)), 1e-9 * std::max(1.0, std::abs(*nearest))) << lambda(i);
    expected.erase(nearest);
  }
  // The device's measured free response against the independent roots.
  EXPECT_NEAR(lambda_measured.imag(), cable.imag(), 1e-6 * cable.imag());
  EXPECT_NEAR(lambda_measured.real(), cable.real(), 1e-5 * std::abs(cable));
  EXPECT_LT(std::abs(lambda_measured - cable), 1e-6 * std::abs(cable));
  // The closed form of eq. 13-16, -z_n/2 +- j sqrt(w_n^2 - z_n^2/4), is the
  // cable pair to first order in the damping: -26.6465142 +- 529.0351582 j,
  // 1e-8 from the exact roots (it was a 1% check of |lambda| against w_n).
  const double wn = std::sqrt(k_c * m / (m_d * m_m));               // eq. 13
  const double zn = (b_m + b_c) / m_m + (b_d + b_c) / m_d - b / m;  // eq. 14-16
  const std::complex<double> approx(-zn / 2.0, std::sqrt(wn * wn - zn * zn / 4.0));
  EXPECT_NEAR(wn, std::sqrt(79.5e3 * 5.4 / (5.1 * 0.3)), 1e-12);
  EXPECT_LT(std::abs(approx - cable), 1e-7 * std::abs(cable));
  EXPECT_NEAR(std::abs(lambda_model), wn, 0.01 * wn);
}

}  // namespace

}  // namespace loopback_plant_test
