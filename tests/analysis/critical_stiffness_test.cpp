// Diaz & Gil: critical stiffness as the gain margin of the exact sampled loop
// with delay, the cable mode's parameters, and the relay experiment; every
// verdict cross-checked by simulating the sampled loop.
#include "analysis/critical_stiffness.hpp"

#include <cmath>
#include <complex>
#include <cstdio>
#include <deque>
#include <functional>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/closed_loop.hpp"
#include "analysis/relay_experiment.hpp"
#include "analysis/two_mass.hpp"
#include "world/integrator.hpp"

namespace hapticd::analysis::critical_stiffness_test {
namespace {

using world::Sensor;

const world::LinearPlant rigid = world::RigidPlant{5.4, 3.5}.model();
const world::LinearPlant two_mass = world::TwoMassPlant{}.model();
constexpr double T = 1e-3;

// Independent simulation of the sampled loop with a continuous delay
// td = l T + delta: the plant is advanced over [0, delta) with the older held
// force and over [delta, T) with the newer one, each segment by its own ZOH
// (world::discretize_zoh), instead of the Gamma0/Gamma1 formulas under test.
std::vector<double> simulate(const world::LinearPlant& plant, Sensor sensor, double delay_s, int steps,
                             const std::function<double(double)>& law) {
  const auto l = static_cast<int>(std::floor(delay_s / T + 1e-9));
  double delta = delay_s - l * T;
  if (delta < 1e-12) delta = 0.0;
  const Eigen::MatrixXd b = plant.dynamics.b.col(world::motor_force_input);
  const auto late = world::discretize_zoh({plant.dynamics.a, b}, T - delta);
  const auto early = world::discretize_zoh({plant.dynamics.a, b}, delta > 0.0 ? delta : T);
  const Eigen::RowVectorXd c = plant.position(sensor);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(plant.dynamics.a.rows());
  x += plant.motor_position.transpose() * 1e-3 + plant.body_position.transpose() * 1e-3;  // both at 1 mm
  std::deque<double> forces(static_cast<std::size_t>(l) + 2, 0.0);  // ..., u[k-l-1], u[k-l]
  std::vector<double> y(static_cast<std::size_t>(steps));
  for (int k = 0; k < steps; ++k) {
    y[static_cast<std::size_t>(k)] = c * x;
    forces.push_back(law(y[static_cast<std::size_t>(k)]));
    forces.pop_front();
    const double newer = forces[1];  // u[k-l]
    const double older = forces[0];  // u[k-l-1]
    if (delta > 0.0) {
      x = early.ad * x + early.bd * older;
      x = late.ad * x + late.bd * newer;
    } else {
      x = late.ad * x + late.bd * newer;
    }
  }
  return y;
}

// Envelope of the last tenth over the envelope of the second tenth.
double envelope_ratio(const std::vector<double>& y) {
  const std::size_t w = y.size() / 10;
  double early = 0.0, late = 0.0;
  for (std::size_t i = w; i < 2 * w; ++i) early = std::max(early, std::abs(y[i]));
  for (std::size_t i = y.size() - w; i < y.size(); ++i) late = std::max(late, std::abs(y[i]));
  return late / early;
}

// Closed form for td = 0 (Gil et al. 2004 route): with a = b/m, e = e^{-aT},
// Z[H G] = ((T - (1-e)/a) z + ((1-e)/a - T e)) / (b (z-1)(z-e)); the spring
// gives z^2 + a1 z + a0 with a0 = e + K c0/b. Jury: |a0| < 1 and
// 1 +- a1 + a0 > 0; the binding condition is a0 < 1, so K_CR = b (1-e)/c0 and
// the unit-circle pair sits at cos(w T) = -a1/2.
TEST(CriticalStiffness, RigidNoDelayMatchesJuryClosedForm) {
  const double m = 5.4, b = 3.5, a = b / m, e = std::exp(-a * T);
  const double c1 = T - (1 - e) / a, c0 = (1 - e) / a - T * e;
  const double kcr = b * (1 - e) / c0;
  ASSERT_GT(c1, c0);  // so 1 - a1 + a0 > 0 holds up to K = 2 b (1+e)/(c1-c0) >> kcr
  EXPECT_GT(2 * b * (1 + e) / (c1 - c0), 100 * kcr);
  const double a1 = kcr * c1 / b - 1 - e;
  const double w = std::acos(-a1 / 2) / T;
  const CriticalStiffness k = critical_stiffness(rigid, Sensor::motor, T, 0.0);
  EXPECT_NEAR(k.k_cr, kcr, 1e-6 * kcr);
  EXPECT_NEAR(k.crossover_rad_per_s, w, 1e-6 * w);
  EXPECT_NEAR(k.gain_margin_db, 20 * std::log10(kcr), 1e-9);
  EXPECT_NEAR(kcr, 2 * b / T, 0.01 * kcr);  // the familiar b > K T / 2
}

// A whole-sample delay through the fractional path equals the z^{-l} path.
TEST(CriticalStiffness, FractionalDelayIsContinuousInDelay) {
  const double k1 = critical_stiffness(rigid, Sensor::motor, T, 1e-3).k_cr;
  const double k1m = critical_stiffness(rigid, Sensor::motor, T, 1e-3 - 1e-9).k_cr;
  const double k1p = critical_stiffness(rigid, Sensor::motor, T, 1e-3 + 1e-9).k_cr;
  // dK/dtd ~ 1.6e6 N/m per s here, so 1e-9 s moves K by ~1.6e-3 N/m.
  EXPECT_NEAR(k1m, k1, 1e-2);
  EXPECT_NEAR(k1p, k1, 1e-2);
  EXPECT_NEAR(k1m - k1, k1 - k1p, 1e-4);
  double prev = critical_stiffness(rigid, Sensor::motor, T, 0.0).k_cr;
  for (double td = 0.25e-3; td <= 8e-3; td += 0.25e-3) {
    const double k = critical_stiffness(rigid, Sensor::motor, T, td).k_cr;
    EXPECT_LT(k, prev) << td;
    prev = k;
  }
}

struct Case {
  const world::LinearPlant* plant;
  Sensor sensor;
  double delay_s;
  const char* name;
};

// Time domain: K = 0.97 K_CR decays and 1.03 K_CR grows.
TEST(CriticalStiffness, TimeDomainAgreesAroundKcr) {
  const Case cases[] = {
      {&rigid, Sensor::motor, 0.0, "rigid td=0"},
      {&rigid, Sensor::motor, 1.5e-3, "rigid td=1.5T"},
      {&rigid, Sensor::motor, 4e-3, "rigid td=4T"},
      {&two_mass, Sensor::motor, 0.0, "motor td=0"},
      {&two_mass, Sensor::motor, 1.5e-3, "motor td=1.5T"},
      {&two_mass, Sensor::body, 0.0, "body td=0"},
      {&two_mass, Sensor::body, 1.5e-3, "body td=1.5T"},
      {&two_mass, Sensor::motor, 0.25e-3, "motor td=0.25T"},
  };
  for (const Case& c : cases) {
    const double kcr = critical_stiffness(*c.plant, c.sensor, T, c.delay_s).k_cr;
    const double below = envelope_ratio(
        simulate(*c.plant, c.sensor, c.delay_s, 300000, [&](double y) { return -0.97 * kcr * y; }));
    const double above = envelope_ratio(
        simulate(*c.plant, c.sensor, c.delay_s, 300000, [&](double y) { return -1.03 * kcr * y; }));
    EXPECT_LT(below, 0.9) << c.name;
    EXPECT_GT(above, 1.1) << c.name;
  }
}

// Eq. (11)-(16) and (24) for Table I.
TEST(TwoMass, ResonanceParametersTableI) {
  const ResonanceParameters r = resonance_parameters(world::TwoMassPlant{});
  EXPECT_NEAR(r.omega_1, std::sqrt(79.5e3 / 0.3), 1e-9);
  EXPECT_NEAR(r.omega_2, std::sqrt(79.5e3 / 5.1), 1e-9);
  EXPECT_NEAR(r.omega_n, std::sqrt(79.5e3 * 5.4 / (5.1 * 0.3)), 1e-9);
  EXPECT_NEAR(r.omega_n, 529.706, 1e-3);
  EXPECT_NEAR(r.z_1, 15.1 / 0.3, 1e-12);
  EXPECT_NEAR(r.z_2, 18.4 / 5.1, 1e-12);
  EXPECT_NEAR(r.z_n, 15.1 / 0.3 + 18.4 / 5.1 - 3.5 / 5.4, 1e-12);
  EXPECT_NEAR(r.z_n, 53.293, 1e-3);
  // Eq. (24) with Table I: 0.3 * 53.293 * 529.706 = 8469 -> 78.56 dB. The
  // paper prints 78.16 dB; the equation and the table do not give that.
  EXPECT_NEAR(r.q, 0.3 * r.z_n * r.omega_n, 1e-9);
  EXPECT_NEAR(r.q_db, 78.557, 1e-3);
  EXPECT_GT(std::abs(r.q_db - 78.16), 0.39);
  // The exact distance from the resonant peak of |G_m| to 0 dB (what eq. 24
  // approximates): 79.044 dB at 528.52 rad/s; eq. (24) omits the factor
  // m/m_d ~ 1.06 (0.5 dB): |G_m(j w_n)| ~ m_d / (m m_m z_n w_n).
  const auto peak = resonant_peak(world::TwoMassPlant{});
  ASSERT_TRUE(peak);
  // Independently of motor_transfer() and resonant_peak(): eq. (7)-(9) with
  // Table I written out, |G_m(j w)| scanned every 0.01 rad/s over 10 ..
  // 5000 rad/s for interior local maxima (there must be one, the cable mode),
  // then refined by golden section.
  const auto gm = [](double w) {
    const double m_m = 0.3, m_d = 5.1, b_m = 0.1, b_d = 3.4, k_c = 79.5e3, b_c = 15.0;
    const std::complex<double> s(0.0, w);
    const std::complex<double> p_d = m_d * s * s + (b_d + b_c) * s + k_c;  // eq. 8
    const std::complex<double> p_m = m_m * s * s + (b_m + b_c) * s + k_c;  // eq. 9
    const std::complex<double> coupling = k_c + b_c * s;
    return std::abs(p_d / (p_d * p_m - coupling * coupling));  // eq. 7
  };
  const double h = 0.01;
  std::vector<double> maxima;
  for (double w = 10.0 + h; w < 5000.0; w += h) {
    if (gm(w) > gm(w - h) && gm(w) >= gm(w + h)) maxima.push_back(w);
  }
  ASSERT_EQ(maxima.size(), 1u);
  double a = maxima[0] - h, b = maxima[0] + h;
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  for (int i = 0; i < 100; ++i) {
    const double c = b - g * (b - a), e = a + g * (b - a);
    if (gm(c) > gm(e)) {
      b = e;
    } else {
      a = c;
    }
  }
  const double w_peak = 0.5 * (a + b);
  const double distance_db = -20.0 * std::log10(gm(w_peak));
  std::printf("independent |G_m| peak: %.9f rad/s, %.9f dB\n", w_peak, distance_db);
  // The location of a maximum is set to ~sqrt(eps) of the peak width (z_n ~ 53 rad/s).
  EXPECT_NEAR(peak->omega_rad_per_s, w_peak, 1e-4);
  EXPECT_NEAR(peak->distance_db, distance_db, 1e-9);
  EXPECT_NEAR(peak->distance, 1.0 / gm(w_peak), 1e-9 * peak->distance);
  EXPECT_NEAR(w_peak, 528.52, 0.005);  // the figures quoted above
  EXPECT_NEAR(distance_db, 79.044, 5e-4);
  EXPECT_NEAR(peak->distance, r.q * 5.4 / 5.1, 0.01 * peak->distance);
}

// Eq. (10) versus (5)-(7): same denominator except the s^2 coefficient.
// analyze critical-stiffness --plant two-mass --motor-mass 1e308 printed
// "w_n = -nan" and still "Q < K_CR: the cable mode limits the stiffness":
// k_c m overflowed in omega_n = sqrt(k_c m / (m_d m_m)) = sqrt(inf / inf).
TEST(TwoMass, OverflowingParametersCannotBeAssessed) {
  world::TwoMassPlant p;
  p.motor_mass = 1e308;
  const ResonanceParameters modes = resonance_parameters(p);
  EXPECT_FALSE(modes.assessed());
  EXPECT_NE(modes.numerics.reason().find("omega_n"), std::string::npos) << modes.numerics.reason();
  EXPECT_FALSE(resonant_peak(p).has_value());
  const CriticalStiffness k = critical_stiffness(p.model(), world::Sensor::motor, 1e-3, 0.0);
  EXPECT_FALSE(k.assessed());  // H ~ 1/m_m: -1/H overflows
  EXPECT_FALSE(rigid_model_suffices(modes, k).has_value());
  // Table I: both assessed, and the comparison is made (Q = 78.6 dB < K_CR = 78.9 dB at td = 0).
  const world::TwoMassPlant table1;
  const ResonanceParameters ok = resonance_parameters(table1);
  const CriticalStiffness kcr = critical_stiffness(table1.model(), world::Sensor::motor, 1e-3, 0.0);
  ASSERT_TRUE(ok.assessed());
  ASSERT_TRUE(kcr.assessed());
  ASSERT_TRUE(rigid_model_suffices(ok, kcr).has_value());
  EXPECT_EQ(*rigid_model_suffices(ok, kcr), ok.q >= kcr.k_cr);
}

// A 1e-20 kg mass with b = 3.5 N s/m is a first-order lag whose K_CR is
// 2 b / T = 7000 N/m; the ZOH of its pole at b/m = 3.5e20 rad/s is rounded
// beyond meaning (rho(A) T = 3.5e17) and K_CR came out as 1.04e7 N/m.
TEST(CriticalStiffness, PlantWhoseDiscretizationLosesPrecisionCannotBeAssessed) {
  const CriticalStiffness k =
      critical_stiffness(world::RigidPlant{1e-20, 3.5}.model(), world::Sensor::motor, 1e-3, 0.0);
  EXPECT_FALSE(k.assessed());
  EXPECT_NE(k.numerics.reason().find("3.5e+17 per period"), std::string::npos) << k.numerics.reason();
  // At 1e-9 kg (the loopback's smallest mass) it is still a verdict, and the right one.
  const CriticalStiffness small =
      critical_stiffness(world::RigidPlant{1e-9, 3.5}.model(), world::Sensor::motor, 1e-3, 0.0);
  ASSERT_TRUE(small.assessed()) << small.numerics.reason();
  EXPECT_NEAR(small.k_cr, 7000.0, 1.0);
}

// At T = 1 us the scan used to start at 1e-4/T = 100 rad/s, above the rigid
// LHifAM's corner b/m = 0.65 rad/s: the phase was already past -180 deg there
// (td = 100 us) and K_CR read 0, as for an undamped mass. The scan now starts
// below the slowest mode; the closed-loop poles confirm the crossing.
TEST(CriticalStiffness, CrossoverBelowTheDefaultScanIsFound) {
  const world::LinearPlant plant = world::RigidPlant{5.4, 3.5}.model();
  const double t = 1e-6;
  const CriticalStiffness k = critical_stiffness(plant, world::Sensor::motor, t, 100 * t);
  ASSERT_TRUE(k.assessed()) << k.numerics.reason();
  EXPECT_GT(k.k_cr, 1e4);
  world::DiscreteLinearScene spring;
  spring.a.resize(0, 0);
  spring.b.resize(0, 1);
  spring.c.resize(1, 0);
  spring.d = Eigen::MatrixXd::Constant(1, 1, -0.97 * k.k_cr);
  EXPECT_TRUE(analyze_closed_loop(plant, world::Sensor::motor, spring, t, 100).stable());
  spring.d(0, 0) = -1.03 * k.k_cr;
  EXPECT_FALSE(analyze_closed_loop(plant, world::Sensor::motor, spring, t, 100).stable());
  // A truly undamped mass (double pole at 0) keeps K_CR = 0.
  EXPECT_EQ(critical_stiffness(world::RigidPlant{5.4, 0.0}.model(), world::Sensor::motor, 1e-3, 0.0).k_cr,
            0.0);
}

// b = 1e-30 N s/m on 5.4 kg read K_CR = 0, as if undamped (with the scan
// started below b/m: 6e-10 N/m; it is 2 b / T = 2e-27): the discrete pole
// e^(-b T / m) rounds to 1 and H no longer knows the damping.
// Down to b/m T = 2.2e-10 it does: two-mass with b_d = 1e-4 gives 2 b / T.
TEST(CriticalStiffness, DampingLostInRoundingCannotBeAssessed) {
  const CriticalStiffness k =
      critical_stiffness(world::RigidPlant{5.4, 1e-30}.model(), world::Sensor::motor, 1e-3, 0.0);
  EXPECT_FALSE(k.assessed());
  EXPECT_NE(k.numerics.reason().find("lost in rounding next to z = 1"), std::string::npos)
      << k.numerics.reason();
  world::TwoMassPlant light;
  light.motor_damping = 0.0;
  light.body_damping = 1e-4;
  const CriticalStiffness two = critical_stiffness(light.model(), world::Sensor::motor, 1e-3, 0.0);
  ASSERT_TRUE(two.assessed()) << two.numerics.reason();
  EXPECT_NEAR(two.k_cr, 2.0 * 1e-4 / 1e-3, 1e-3 * 0.2);
}

// The phase scan resolves a delay of max_delay_periods: K_CR there agrees
// with the closed-loop poles (a 102-state matrix) at 0.97 / 1.03 K_CR; a
// longer one is refused rather than answered from a scan that may miss a
// crossover. (td = 1e300 s used to overflow int in the whole-sample count.)
TEST(CriticalStiffness, LongestDelayIsResolvedLongerIsRefused) {
  const world::LinearPlant plant = world::RigidPlant{5.4, 3.5}.model();
  const double t = 1e-3;
  const CriticalStiffness k = critical_stiffness(plant, world::Sensor::motor, t, max_delay_periods * t);
  ASSERT_TRUE(k.assessed()) << k.numerics.reason();
  auto spring = [](double stiffness) {
    world::DiscreteLinearScene s;
    s.a.resize(0, 0);
    s.b.resize(0, 1);
    s.c.resize(1, 0);
    s.d = Eigen::MatrixXd::Constant(1, 1, -stiffness);
    return s;
  };
  EXPECT_TRUE(
      analyze_closed_loop(plant, world::Sensor::motor, spring(0.97 * k.k_cr), t, max_delay_periods).stable());
  EXPECT_FALSE(
      analyze_closed_loop(plant, world::Sensor::motor, spring(1.03 * k.k_cr), t, max_delay_periods).stable());
  EXPECT_THROW(critical_stiffness(plant, world::Sensor::motor, t, (max_delay_periods + 1) * t),
               std::invalid_argument);
  EXPECT_THROW(critical_stiffness(plant, world::Sensor::motor, t, 1e300), std::invalid_argument);
  EXPECT_THROW(critical_stiffness(plant, world::Sensor::motor, t, std::nan("")), std::invalid_argument);
  EXPECT_THROW(discretize_delayed_zoh(plant.dynamics.a, plant.dynamics.b.col(0), t, 1e300),
               std::invalid_argument);
}

TEST(TwoMass, FactorizationEq10IsApproximateInOneCoefficient) {
  const world::TwoMassPlant p;
  const Polynomial exact = two_mass_denominator(p);
  const Polynomial factored = two_mass_factored_denominator(p);
  ASSERT_EQ(exact.size(), factored.size());
  for (std::size_t i : {0u, 1u, 3u, 4u}) EXPECT_NEAR(exact[i], factored[i], 1e-9 * (1 + std::abs(exact[i])));
  const double s2_exact = p.cable_stiffness * p.total_mass() + p.body_damping * p.motor_damping +
                          p.cable_damping * p.total_damping();
  EXPECT_NEAR(exact[2], s2_exact, 1e-9);
  const double diff = factored[2] - exact[2];  // (m_d m_m / m) b z_n - (b_d b_m + b_c b)
  const double zn = (p.motor_damping + p.cable_damping) / p.motor_mass +
                    (p.body_damping + p.cable_damping) / p.body_mass - p.total_damping() / p.total_mass();
  const double predicted = p.body_mass * p.motor_mass / p.total_mass() * p.total_damping() * zn -
                           (p.body_damping * p.motor_damping + p.cable_damping * p.total_damping());
  EXPECT_NEAR(diff, predicted, 1e-8);
  EXPECT_NEAR(diff, 0.00892, 1e-5);  // 52.84892 vs 52.84 N s... in 429352.8
  EXPECT_LT(std::abs(diff) / exact[2], 3e-8);
  // Poles: the mode -26.6465 +- 529.035j in both, agreeing to ~1e-8 relative.
  double worst = 0.0;
  auto re = roots(exact), rf = roots(factored);
  for (const auto& z : re) {
    double best = 1e300;
    for (const auto& w : rf) best = std::min(best, std::abs(z - w));
    worst = std::max(worst, best / std::max(1.0, std::abs(z)));
  }
  EXPECT_LT(worst, 1e-7);
  // And the state-space plant in world/ has the same G_m as eq. (7).
  const std::complex<double> s(0.0, 300.0);
  const Eigen::MatrixXcd resolvent =
      (s * Eigen::MatrixXcd::Identity(4, 4) - two_mass.dynamics.a.cast<std::complex<double>>()).inverse();
  const std::complex<double> gm = (two_mass.motor_position.cast<std::complex<double>>() * resolvent *
                                   two_mass.dynamics.b.col(0).cast<std::complex<double>>())(0);
  EXPECT_NEAR(std::abs(gm - motor_transfer(p, s)), 0.0, 1e-9 * std::abs(gm));
}

// Table II (reduced-pretension cable, whose parameters the paper does not
// give) against the Table I models with the paper's 250 us inherent delay.
// The measurements for td >= 2 ms sit 9-14 dB above every Table I prediction
// and at about twice its frequency; what the math supports is only the trend
// (K_CR and the crossover fall with td) and that the Table I models cannot
// reproduce those rows. See docs/analysis.md.
TEST(CriticalStiffness, TableIIComparison) {
  struct Row {
    double td_ms, hz, db;
  };
  const Row measured[] = {{2, 4.8828, 76.331}, {3, 4.3945, 73.584}, {4, 4.4860, 73.962}, {5, 4.4250, 73.607},
                          {6, 3.1738, 66.736}, {7, 2.7771, 64.343}, {8, 2.3193, 61.165}};
  double prev_db = 1e9;
  for (const Row& r : measured) {
    const CriticalStiffness k = critical_stiffness(two_mass, Sensor::motor, T, r.td_ms * 1e-3 + 250e-6);
    const CriticalStiffness kr = critical_stiffness(rigid, Sensor::motor, T, r.td_ms * 1e-3 + 250e-6);
    std::printf("td %.0f ms: measured %.2f Hz %.1f dB | two-mass %.2f Hz %.1f dB | rigid %.2f Hz %.1f dB\n",
                r.td_ms, r.hz, r.db, k.crossover_hz, k.gain_margin_db, kr.crossover_hz, kr.gain_margin_db);
    EXPECT_LT(k.gain_margin_db, prev_db);
    prev_db = k.gain_margin_db;
    EXPECT_GT(r.db - k.gain_margin_db, 5.0) << r.td_ms;  // the documented disagreement
    EXPECT_GT(r.hz / k.crossover_hz, 1.3) << r.td_ms;
  }
}

// Relay experiment (Diaz & Gil V) on the simulated rigid plant: the
// describing-function estimate versus the exact K_CR.
TEST(RelayExperiment, RigidPlantAgreesWithCriticalStiffness) {
  const double h = 2.0;
  struct RelayCase {
    double damping, td, gain_tol, freq_tol;
  };
  // Tolerances are the errors observed (rounded up), not "a few %": the
  // relay estimate is 14-26 % below K_CR and its frequency 7-14 % below the
  // phase crossover, for b = 3.5 and 35 N s/m alike. The phase of H near the
  // crossover is shallow (d phase/d w ~ b/(m w^2) + T/2 + td, and
  // b/(m w_c^2) ~ T/2 whatever b is), so a fraction of a sample of extra
  // lag -- the sampled relay switches only at samples and its limit cycle
  // locks to the sample grid, which the describing function ignores, as it
  // ignores the harmonics -- moves the frequency by ~10 % and
  // K_u ~ m w^2 twice as much. The estimate errs low (conservative).
  const RelayCase cases[] = {{3.5, 0.0, 0.24, 0.13},  {3.5, 1.5e-3, 0.22, 0.12}, {3.5, 2e-3, 0.18, 0.10},
                             {3.5, 5e-3, 0.16, 0.09}, {35.0, 0.0, 0.27, 0.15},   {35.0, 2e-3, 0.19, 0.10}};
  for (const RelayCase& c : cases) {
    const world::LinearPlant plant = world::RigidPlant{5.4, c.damping}.model();
    const auto y = simulate(plant, Sensor::motor, c.td, 40000, [&](double p) { return p > 0.0 ? -h : h; });
    const std::vector<double> steady(y.begin() + 20000, y.end());
    const auto e = estimate_relay(steady, T, h);
    ASSERT_TRUE(e) << c.td;
    const CriticalStiffness k = critical_stiffness(plant, Sensor::motor, T, c.td);
    std::printf(
        "relay b %.1f td %.1f ms: K_u %.1f (K_CR %.1f, %+.2f%%), f %.3f Hz (%.3f, %+.2f%%), %d cycles\n",
        c.damping, c.td * 1e3, e->ultimate_gain, k.k_cr, 100 * (e->ultimate_gain / k.k_cr - 1),
        e->frequency_hz, k.crossover_hz, 100 * (e->frequency_hz / k.crossover_hz - 1), e->cycles);
    EXPECT_NEAR(e->ultimate_gain, k.k_cr, c.gain_tol * k.k_cr) << c.damping << " " << c.td;
    EXPECT_LT(e->ultimate_gain, k.k_cr);
    EXPECT_NEAR(e->frequency_hz, k.crossover_hz, c.freq_tol * k.crossover_hz) << c.damping << " " << c.td;
  }
}

TEST(RelayExperiment, RecoversAKnownSinusoid) {
  std::vector<double> y;
  const double w = 2 * std::numbers::pi * 7.3, a = 0.004;
  for (int n = 0; n < 5000; ++n)
    y.push_back(0.01 + a * std::sin(w * n * T + 0.3) + 0.0004 * std::sin(3 * w * n * T));
  const auto e = estimate_relay(y, T, 1.5);
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->frequency_rad_per_s, w, 1e-3 * w);
  EXPECT_NEAR(e->amplitude, a, 1e-3 * a);
  EXPECT_NEAR(e->ultimate_gain, 4 * 1.5 / (std::numbers::pi * a), 2e-3 * e->ultimate_gain);
  EXPECT_FALSE(estimate_relay(std::vector<double>(100, 1.0), T, 1.0));
  EXPECT_FALSE(estimate_relay(y, T, 0.0));
}

}  // namespace
}  // namespace hapticd::analysis::critical_stiffness_test
