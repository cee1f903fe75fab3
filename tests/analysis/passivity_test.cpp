// Colgate & Schenkel (1997): the damping a sampled virtual environment needs
// from the device to be passive, checked against closed forms derived here
// by hand and against an independent brute-force reference (10^6 points of
// the condition as printed, then golden section), written separately below.
#include "analysis/passivity.hpp"

#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "analysis/wall_stability.hpp"
#include "world/spring_scene.hpp"
#include "world/wall_scene.hpp"

namespace hapticd::analysis::passivity_test {
namespace {

constexpr double pi = std::numbers::pi;
const double inf = std::numeric_limits<double>::infinity();
const double nan = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------
// The reference: (CS) as printed, (T/2) Re{(1 - e^{-j theta}) H} / (1 - cos theta),
// with 1 - cos theta = 2 sin^2(theta/2) and 1 - e^{-j theta} = (1 - cos theta)
// + j sin theta (the same numbers without cancellation), on 10^6 points of
// (0, pi], then golden section on the two grid steps around the best point.

using Transfer = std::function<std::complex<double>(double theta)>;  // H(e^{j theta})

double cs_value(const Transfer& h, double theta, double period_s) {
  const double half = std::sin(theta / 2.0);
  const double one_minus_cos = 2.0 * half * half;
  const std::complex<double> one_minus_z_inv(one_minus_cos, std::sin(theta));
  return period_s / 2.0 * (one_minus_z_inv * h(theta)).real() / one_minus_cos;
}

struct Reference {
  double value = 0.0;
  double theta = 0.0;
};

Reference brute_force_supremum(const Transfer& h, double period_s) {
  constexpr int n = 1'000'000;
  Reference best{-inf, 0.0};
  int best_i = 1;
  for (int i = 1; i <= n; ++i) {
    const double theta = pi * i / n;
    const double v = cs_value(h, theta, period_s);
    if (v > best.value) {
      best = {v, theta};
      best_i = i;
    }
  }
  // Golden section (maximizing) on [theta_{i-1}, theta_{i+1}] within (0, pi].
  double a = std::max(pi * (best_i - 1) / n, 1e-300), b = std::min(pi * (best_i + 1) / n, pi);
  const double r = (std::sqrt(5.0) - 1.0) / 2.0;
  double c = b - r * (b - a), d = a + r * (b - a);
  double fc = cs_value(h, c, period_s), fd = cs_value(h, d, period_s);
  for (int k = 0; k < 200 && b - a > 1e-15; ++k) {
    if (fc >= fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - r * (b - a);
      fc = cs_value(h, c, period_s);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + r * (b - a);
      fd = cs_value(h, d, period_s);
    }
  }
  if (fc > best.value) best = {fc, c};
  if (fd > best.value) best = {fd, d};
  return best;
}

/// H(z) = z^-d (K + B (1 - z^-1)/T), the wall as Colgate writes it.
Transfer wall_transfer(double k, double b, double t, int d) {
  return [=](double theta) {
    const double half = std::sin(theta / 2.0);
    const std::complex<double> backward(2.0 * half * half, std::sin(theta));  // 1 - z^-1
    return std::polar(1.0, -d * theta) * (k + b * backward / t);
  };
}

/// H(z) = -z^-d (C (zI - A)^-1 B + D) from a scene's linear model, by a complex solve.
Transfer scene_transfer(const world::DiscreteLinearScene& m, int extra_delay) {
  using Small = Eigen::Matrix<std::complex<double>, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>;
  using SmallVector = Eigen::Matrix<std::complex<double>, Eigen::Dynamic, 1, 0, 3, 1>;
  const Eigen::Index q = m.a.rows();
  const Small a = m.a.cast<std::complex<double>>();
  const SmallVector b = m.b.cast<std::complex<double>>();
  const Eigen::Matrix<std::complex<double>, 1, Eigen::Dynamic, Eigen::RowMajor, 1, 3> c =
      m.c.cast<std::complex<double>>();
  const double dd = m.d(0, 0);
  const int delay = m.output_delay_samples + extra_delay;
  return [=](double theta) {
    const std::complex<double> z = std::polar(1.0, theta);
    const Small zi_a = z * Small::Identity(q, q) - a;
    const SmallVector x = zi_a.partialPivLu().solve(b);
    const std::complex<double> g = (c * x)(0, 0) + dd;
    return -std::polar(1.0, -delay * theta) * g;
  };
}

void expect_relative(double actual, double expected, double tolerance, const std::string& what) {
  EXPECT_NEAR(actual, expected, tolerance * std::max(std::abs(expected), 1e-300)) << what;
}

// ---------------------------------------------------------------------------
// Closed forms. For the wall, with theta = w T:
//   Re{(1 - e^{-j theta}) e^{-j d theta}} = cos d theta - cos (d+1) theta
//       = 2 sin((2d+1) theta/2) sin(theta/2),  1 - cos theta = 2 sin^2(theta/2),
// so the stiffness term is (K T/2) sin((2d+1) theta/2) / sin(theta/2), the
// Dirichlet kernel D_d = 1 + 2 sum_{k=1..d} cos k theta; and
// (1 - e^{-j theta})^2 = -4 sin^2(theta/2) e^{-j theta} makes the damping term
// (T/2)(B/T)(-2 cos (d+1) theta) = -B cos (d+1) theta:
//   f(theta) = (K T/2) D_d(theta) - B cos((d+1) theta).

// d = 0: D_0 = 1, so f = K T/2 - B cos theta, largest at theta = pi: b > K T/2 + B.
TEST(WallPassivity, NoDelayIsKTOverTwoPlusB) {
  for (const double k : {0.0, 1.0, 9000.0, 2e5, 1e9}) {
    for (const double b : {0.0, 0.3, 46.0, 1e3}) {
      for (const double t : {1e-6, 2.5e-4, 1e-3, 0.01}) {
        const PassivityBound p = wall_passivity(k, b, t, 0);
        ASSERT_TRUE(p.bounded()) << p.reason;
        expect_relative(p.required_damping, k * t / 2.0 + b, 1e-12, "K " + std::to_string(k));
        if (b > 0.0) {
          EXPECT_NEAR(p.frequency_hz, 1.0 / (2.0 * t), 1e-9 / t);  // Nyquist
        }
      }
    }
  }
}

// B = 0, delay d: |D_d(theta)| = |sum_{k=-d..d} e^{jk theta}| < 2d + 1 for
// 0 < theta <= pi (the terms align only at theta = 0), and D_d -> 2d + 1 as
// theta -> 0. So the supremum is the limit at w -> 0, not attained:
//   b >= (K T/2)(2d + 1) = K T (d + 1/2).
TEST(WallPassivity, PureStiffnessWithDelayIsKTTimesDPlusHalf) {
  for (const int d : {1, 2, 3, 7, 64}) {
    for (const double k : {1.0, 9000.0, 1e6}) {
      const double t = 1e-3;
      const PassivityBound p = wall_passivity(k, 0.0, t, d);
      ASSERT_TRUE(p.bounded()) << p.reason;
      expect_relative(p.required_damping, k * t * (d + 0.5), 1e-12, "d " + std::to_string(d));
      EXPECT_TRUE(p.at_zero_frequency_limit) << d;
      EXPECT_EQ(p.frequency_hz, 0.0);
    }
  }
}

// d = 1 with damping: D_1 = 1 + 2c and cos 2 theta = 2c^2 - 1 with c = cos theta:
//   f = K T/2 + B + K T c - 2 B c^2, a parabola in c in [-1, 1).
// Its vertex c* = K T / (4 B): if c* < 1, b >= K T/2 + B + (K T)^2 / (8 B);
// else the supremum is the limit c -> 1: b >= 3 K T / 2 - B.
double d1_required(double k, double b, double t) {
  const double kt = k * t;
  if (b > 0.0 && kt < 4.0 * b) return kt / 2.0 + b + kt * kt / (8.0 * b);
  return 1.5 * kt - b;
}

TEST(WallPassivity, OneSampleDelayWithDampingIsAParabolaInCosTheta) {
  const double t = 1e-3;
  for (const double k : {100.0, 9000.0, 40000.0, 2e5}) {
    for (const double b : {0.5, 10.0, 46.0, 400.0}) {
      const PassivityBound p = wall_passivity(k, b, t, 1);
      ASSERT_TRUE(p.bounded());
      expect_relative(p.required_damping, d1_required(k, b, t), 1e-12,
                      "K " + std::to_string(k) + " B " + std::to_string(b));
      if (k * t < 4.0 * b) {
        EXPECT_NEAR(std::cos(2.0 * pi * p.frequency_hz * t), k * t / (4.0 * b), 1e-9);
      } else {
        EXPECT_TRUE(p.at_zero_frequency_limit);
      }
    }
  }
}

// Hulin's section 7 wall (K = 9 kN/m, B = 46 N s/m, T = 1 ms, d = 1): stable,
// but it needs 4.5 + 46 + 81/368 = 50.7201 N s/m of device damping to be
// passive (c* = 9/184, 252 Hz). With B = 46 no K > 0 is passive on b = 0,
// 0.5 or 2 N s/m (B alone needs b >= B). Without damping: K <= 2 b / (3 T).
TEST(WallPassivity, HulinSectionSevenWallIsStableButNotPassive) {
  ASSERT_TRUE(wall_stable(0.09, 0.46, 1));
  const PassivityVerdict v = analyze_wall_passivity(9000.0, 46.0, 1e-3, 1, 2.0);
  ASSERT_TRUE(v.bound.bounded());
  EXPECT_NEAR(v.bound.required_damping, 50.5 + 81.0 / 368.0, 1e-12);
  EXPECT_NEAR(v.bound.frequency_hz, std::acos(9.0 / 184.0) / (2.0 * pi * 1e-3), 1e-9);
  EXPECT_FALSE(v.passive);
  for (const double b : {0.0, 0.5, 2.0}) {
    EXPECT_EQ(analyze_wall_passivity(9000.0, 46.0, 1e-3, 1, b).max_stiffness, 0.0) << b;
    EXPECT_NEAR(analyze_wall_passivity(0.0, 0.0, 1e-3, 1, b).max_stiffness, 2.0 * b / 3e-3, 1e-9 * (1 + b))
        << b;
  }
}

// The largest passive K: d = 0: K T/2 + B = b; B = 0: K T (d + 1/2) = b;
// d = 1 inverts the parabola: with x = K T, x^2 + 4 B x + 8 B (B - b) = 0 on
// the branch x < 4 B gives x = -2B + 2 sqrt(2 B b - B^2); else 3x/2 - B = b.
double d1_max_kt(double b_wall, double b_device) {
  const double x = -2.0 * b_wall + 2.0 * std::sqrt(2.0 * b_wall * b_device - b_wall * b_wall);
  if (b_wall > 0.0 && x < 4.0 * b_wall) return x;
  return 2.0 * (b_device + b_wall) / 3.0;
}

TEST(WallPassivity, MaxStiffnessClosedForms) {
  const double t = 1e-3;
  for (const double bd : {0.5, 2.0, 46.0, 100.0}) {
    for (const double bw : {0.0, 0.1, 0.4, 1.0, 10.0, 46.0}) {
      const double expected0 = bw < bd ? 2.0 * (bd - bw) / t : 0.0;
      expect_relative(analyze_wall_passivity(1.0, bw, t, 0, bd).max_stiffness, expected0, 1e-12, "d0");
      const double expected1 = bw < bd ? d1_max_kt(bw, bd) / t : 0.0;
      EXPECT_NEAR(analyze_wall_passivity(1.0, bw, t, 1, bd).max_stiffness, expected1, 1e-9 * expected1 + 1e-9)
          << "B " << bw << " b " << bd;
    }
    for (const int d : {2, 3, 10}) {
      expect_relative(analyze_wall_passivity(1.0, 0.0, t, d, bd).max_stiffness, bd / (t * (d + 0.5)), 1e-12,
                      "B = 0");
    }
  }
}

// At the largest passive K the requirement is the device's damping exactly;
// a little stiffer is not passive.
TEST(WallPassivity, MaxStiffnessIsOnTheBoundary) {
  const double t = 1e-3, b = 2.0;
  for (const int d : {0, 1, 2, 3, 5, 8}) {
    for (const double bw : {0.0, 0.05, 0.5, 1.5}) {
      const double k = analyze_wall_passivity(1.0, bw, t, d, b).max_stiffness;
      ASSERT_GT(k, 0.0);
      const PassivityVerdict at = analyze_wall_passivity(k, bw, t, d, b);
      EXPECT_NEAR(at.bound.required_damping, b, 1e-12 * b) << d << " " << bw;
      EXPECT_FALSE(analyze_wall_passivity(k * (1 + 1e-9), bw, t, d, b).passive) << d << " " << bw;
      EXPECT_TRUE(analyze_wall_passivity(k * (1 - 1e-9), bw, t, d, b).passive) << d << " " << bw;
    }
  }
}

// ---------------------------------------------------------------------------
// The independent reference.

TEST(WallPassivity, AgreesWithTheBruteForceReference) {
  struct Case {
    double k, b, t;
    int d;
  };
  std::vector<Case> cases{{9000, 46, 1e-3, 1},    {9000, 46, 1e-3, 0}, {20000, 5, 1e-3, 3},
                          {3000, 0.5, 2.5e-4, 8}, {1e5, 20, 1e-4, 2},  {500, 3, 1e-3, 16},
                          {9000, 0, 1e-3, 4},     {0, 46, 1e-3, 5},    {14447, 42.5, 1e-3, 1}};
  std::mt19937 random(21);
  std::uniform_real_distribution<double> exponent(0.0, 1.0);
  for (int i = 0; i < 8; ++i) {
    cases.push_back({std::pow(10.0, 1.0 + 5.0 * exponent(random)),
                     std::pow(10.0, -2.0 + 4.0 * exponent(random)),
                     std::pow(10.0, -5.0 + 3.0 * exponent(random)), static_cast<int>(exponent(random) * 24)});
  }
  for (const Case& c : cases) {
    const PassivityBound p = wall_passivity(c.k, c.b, c.t, c.d);
    ASSERT_TRUE(p.bounded());
    const Reference r = brute_force_supremum(wall_transfer(c.k, c.b, c.t, c.d), c.t);
    const std::string what = "K " + std::to_string(c.k) + " B " + std::to_string(c.b) + " T " +
                             std::to_string(c.t) + " d " + std::to_string(c.d);
    expect_relative(p.required_damping, r.value, 1e-9, what);
    EXPECT_GE(p.required_damping, r.value - 1e-12 * std::abs(r.value)) << what;  // never below a grid point
  }
}

// The wall's own linear model (world::WallScene) through the general path
// gives the closed form's answer.
TEST(ScenePassivity, WallLinearModelMatchesTheClosedForm) {
  for (const int d : {1, 2, 5}) {
    for (const double b : {0.0, 4.6, 46.0}) {
      world::WallParameters w;
      w.stiffness = 9000.0;
      w.damping = b;
      w.delay_samples = d;
      world::DiscreteLinearScene model;
      if (b == 0.0) {
        model = world::WallScene<world::WallDamping::none, world::WallDelay::samples>(w, 1e-3).linear_model();
      } else {
        model = world::WallScene<world::WallDamping::backward_difference, world::WallDelay::samples>(w, 1e-3)
                    .linear_model();
      }
      const PassivityBound general = scene_passivity(model, 1e-3, 0);
      const PassivityBound closed = wall_passivity(9000.0, b, 1e-3, d);
      ASSERT_TRUE(general.bounded()) << general.reason;
      expect_relative(general.required_damping, closed.required_damping, 1e-11,
                      "d " + std::to_string(d) + " B " + std::to_string(b));
      EXPECT_NEAR(general.frequency_hz, closed.frequency_hz, 1e-6);
    }
  }
}

// ---------------------------------------------------------------------------
// Monotonicity. The requirement is a maximum of functions affine in K (with
// slope T D_d / 2 >= T/2 > 0 where B's term peaks), so it grows with K. In B
// it is convex, but not monotone once d >= 1: the delayed spring's
// low-frequency activity is offset by B (d = 1: 3 K T/2 - B while K T >= 4B),
// down to K T (1/2 + 1/sqrt2) at B = K T / (2 sqrt2); for d = 0 it is K T/2 + B.
TEST(WallPassivity, RequirementGrowsWithStiffnessAndIsConvexInDamping) {
  const double t = 1e-3;
  for (const int d : {0, 1, 2, 4}) {
    for (const double b : {0.0, 1.0, 46.0}) {
      double previous = -1.0;
      for (double k = 0.0; k <= 2e5; k += 2500.0) {
        const double r = wall_passivity(k, b, t, d).required_damping;
        EXPECT_GE(r, previous) << "d " << d << " K " << k;
        previous = r;
      }
    }
    std::vector<double> r;
    for (double b = 0.0; b <= 50.0; b += 0.25) r.push_back(wall_passivity(9000.0, b, t, d).required_damping);
    for (std::size_t i = 1; i + 1 < r.size(); ++i) EXPECT_GE(r[i - 1] + r[i + 1] - 2 * r[i], -1e-9) << d;
    if (d == 0) {
      for (std::size_t i = 1; i < r.size(); ++i) EXPECT_GT(r[i], r[i - 1]);
    }
  }
  const double kt = 9000.0 * t, best = kt / (2.0 * std::sqrt(2.0));
  EXPECT_NEAR(wall_passivity(9000.0, best, t, 1).required_damping, kt * (0.5 + 1.0 / std::sqrt(2.0)), 1e-12);
  EXPECT_GT(wall_passivity(9000.0, best * 0.9, t, 1).required_damping, kt * (0.5 + 1.0 / std::sqrt(2.0)));
  EXPECT_GT(wall_passivity(9000.0, best * 1.1, t, 1).required_damping, kt * (0.5 + 1.0 / std::sqrt(2.0)));
  // More device damping never lowers the largest passive K.
  for (const int d : {0, 1, 3}) {
    double previous = 0.0;
    for (double bd = 0.0; bd <= 10.0; bd += 0.5) {
      const double k = analyze_wall_passivity(1.0, 0.5, t, d, bd).max_stiffness;
      EXPECT_GE(k, previous) << d << " " << bd;
      previous = k;
    }
  }
}

// Hulin's plane: b T/m = device_beta; the boundary starts at 2 beta_b / (2d+1)
// (B = 0) and reaches alpha = 0 at beta = beta_b; every point is on it.
TEST(WallPassivity, NormalizedBoundary) {
  const double beta_b = 0.02;
  for (const int d : {0, 1, 3}) {
    const auto points = passivity_boundary(beta_b, d, 30);
    ASSERT_EQ(points.size(), 30u);
    EXPECT_EQ(points.front().beta, 0.0);
    EXPECT_NEAR(points.front().alpha, 2.0 * beta_b / (2 * d + 1), 1e-15);
    EXPECT_EQ(points.back().beta, beta_b);
    EXPECT_EQ(points.back().alpha, 0.0);
    for (std::size_t i = 1; i + 1 < points.size(); ++i) {
      EXPECT_GT(points[i].beta, points[i - 1].beta);
      ASSERT_GT(points[i].alpha, 0.0);
      const WallSupremum w = wall_supremum(points[i].alpha / 2.0, points[i].beta, d);
      EXPECT_NEAR(w.value, beta_b, 1e-13) << d << " " << i;
    }
    // The same as SI on m = 0.1 kg, T = 1 ms: b = beta_b m / T.
    const double m = 0.1, t = 1e-3;
    const double k = analyze_wall_passivity(1.0, 0.3 * beta_b * m / t, t, d, beta_b * m / t).max_stiffness;
    EXPECT_NEAR(normalized_stiffness(k, m, t), passive_alpha_max(0.3 * beta_b, beta_b, d), 1e-12);
  }
  EXPECT_TRUE(passivity_boundary(0.0, 1, 30).empty());
}

// ---------------------------------------------------------------------------
// Springs.

world::DiscreteLinearScene forward_euler_absolute(double k, double j, double b, double t) {
  world::SpringParameters p{k, j, b, world::Integrator::forward_euler};
  return world::SpringScene<world::SpringDamping::absolute>(p, t).linear_model();
}

// By hand: forward Euler, damping against the frame (absolute), w' = w + T v,
// v' = (1 - c) v + (p/T)(y - w) with c = b T/J, p = k T^2/J and F = k (w - y):
//   w/y = p / ((z-1)(z-1+c) + p),   H = -F/y = k (z-1)(z-1+c) / ((z-1)(z-1+c) + p).
// Take c = 1, p = 1/2 (T = 1 ms, J = 1, b = 1000, k = 5e5): H = k z (z-1)/(z^2 - z + 1/2),
// poles 0.5 +- 0.5j. Then (1 - z^-1) H = k (z-1)^2 / (z^2 - z + 1/2), (z-1)^2 =
// -4 sin^2(theta/2) e^{j theta}, so (1 - z^-1) H / (1 - cos theta)
// = -2k / (e^{j theta} - 1 + e^{-j theta}/2) = -2k / ((1.5c - 1) + 0.5 j s):
//   f = -k T (1.5 c - 1) / (2 c^2 - 3 c + 1.25),  c = cos theta.
// d f/dc = 0 where 3 c^2 - 4 c + 1.125 = 0: c = (4 -+ sqrt 2.5)/6; the smaller
// root is the maximum (f = 1.0811 k T there; at c = -1 f = 0.4 k T, c -> 1: -2 k T).
TEST(ScenePassivity, ForwardEulerSpringAgainstTheHandComputedExample) {
  const double k = 5e5, j = 1.0, b = 1000.0, t = 1e-3;
  const PassivityBound p = scene_passivity(forward_euler_absolute(k, j, b, t), t, 0);
  ASSERT_TRUE(p.bounded()) << p.reason;
  const double c = (4.0 - std::sqrt(2.5)) / 6.0;
  const double expected = -k * t * (1.5 * c - 1.0) / (2.0 * c * c - 3.0 * c + 1.25);
  EXPECT_NEAR(expected / (k * t), 1.0811, 1e-4);
  expect_relative(p.required_damping, expected, 1e-12, "hand");
  EXPECT_NEAR(p.frequency_hz, std::acos(c) / (2.0 * pi * t), 1e-6);
}

TEST(ScenePassivity, SpringsAgreeWithTheBruteForceReference) {
  struct Case {
    std::string name;
    world::DiscreteLinearScene model;
    int delay;
  };
  const double t = 1e-3;
  const auto relative = [&](double k, double m, double b, world::Integrator i) {
    return world::SpringScene<world::SpringDamping::relative>({k, m, b, i}, t).linear_model();
  };
  const auto absolute = [&](double k, double m, double b, world::Integrator i) {
    return world::SpringScene<world::SpringDamping::absolute>({k, m, b, i}, t).linear_model();
  };
  const double k_wheel = 0.8 / (pi / 4.0), j_wheel = k_wheel / (4.0 * pi * pi);  // Freudenberg 2.1: 1 Hz
  std::vector<Case> cases{
      {"spring-mass exact relative", relative(79.0, 0.5, 2.0, world::Integrator::exact), 0},
      {"spring-mass exact relative d=1", relative(79.0, 0.5, 2.0, world::Integrator::exact), 1},
      {"spring-mass exact relative d=3", relative(79.0, 0.5, 2.0, world::Integrator::exact), 3},
      {"wheel exact b = T k", relative(k_wheel, j_wheel, t * k_wheel, world::Integrator::exact), 0},
      {"stiff trapezoid relative", relative(2e4, 0.05, 5.0, world::Integrator::trapezoid), 1},
      {"rk4 absolute", absolute(5000.0, 0.2, 3.0, world::Integrator::rk4), 0},
      {"semi-implicit absolute", absolute(500.0, 0.1, 1.0, world::Integrator::semi_implicit_euler), 2},
      {"forward Euler relative", relative(100.0, 1.0, 2.0, world::Integrator::forward_euler), 0},
      // k = 0: a damper to a free virtual mass; its position (z = 1) is read by nothing.
      {"damper to a free mass", relative(0.0, 0.5, 2.0, world::Integrator::exact), 0},
  };
  for (const Case& c : cases) {
    const PassivityBound p = scene_passivity(c.model, t, c.delay);
    ASSERT_TRUE(p.bounded()) << c.name << ": " << p.reason;
    const Reference r = brute_force_supremum(scene_transfer(c.model, c.delay), t);
    expect_relative(p.required_damping, r.value, 1e-9, c.name);
    EXPECT_GE(p.required_damping, r.value - 1e-12 * std::abs(r.value)) << c.name;
  }
}

// An undamped virtual body is lossless, but sampled its resonance makes the
// supremum infinite: no device damping is enough (exact ZOH, semi-implicit
// Euler: poles on the unit circle). Forward Euler's is outside: unstable.
TEST(ScenePassivity, UndampedOrUnstableVirtualBodyIsUnbounded) {
  const double t = 1e-3;
  const double k = 0.8 / (pi / 4.0), j = k / (4.0 * pi * pi);  // the 1 Hz wheel
  SpringPassivityInput in;
  in.parameters = {k, j, 0.0, world::Integrator::exact};
  in.period_s = t;
  const PassivityBound exact = spring_passivity(in);
  EXPECT_EQ(exact.state, PassivityState::unbounded);
  EXPECT_EQ(exact.required_damping, inf);
  EXPECT_NEAR(exact.frequency_hz, 1.0, 1e-9);
  EXPECT_NE(exact.reason.find("not passive at any device damping: the virtual body's undamped mode at 1 Hz"),
            std::string::npos)
      << exact.reason;

  in.parameters.integrator = world::Integrator::semi_implicit_euler;
  const PassivityBound semi = spring_passivity(in);
  EXPECT_EQ(semi.state, PassivityState::unbounded) << semi.reason;
  EXPECT_NEAR(semi.frequency_hz, std::acos(1.0 - k * t * t / (2.0 * j)) / (2.0 * pi * t), 1e-9);

  in.parameters.integrator = world::Integrator::forward_euler;
  const PassivityBound euler = spring_passivity(in);
  EXPECT_EQ(euler.state, PassivityState::unbounded);
  EXPECT_NE(euler.reason.find("unstable (pole radius " + short_number(std::sqrt(1.0 + k * t * t / j))),
            std::string::npos)
      << euler.reason;

  const PassivityVerdict on_device = analyze_spring_passivity(in, 100.0);
  EXPECT_FALSE(on_device.passive);
  EXPECT_FALSE(std::isnan(on_device.bound.required_damping));

  // Damped (b = T k, Freudenberg 2.24), the same wheel is bounded.
  in.parameters.integrator = world::Integrator::exact;
  in.damping_auto = true;
  const PassivityBound damped = spring_passivity(in);
  ASSERT_TRUE(damped.bounded()) << damped.reason;
  EXPECT_GT(damped.required_damping, 0.0);
}

// The largest passive spring stiffness: passive just below, not just above.
TEST(ScenePassivity, SpringMaxStiffnessIsTheEndOfThePassiveInterval) {
  SpringPassivityInput in;
  in.parameters = {79.0, 0.5, 2.0, world::Integrator::exact};
  in.period_s = 1e-3;
  const double b = 3.0;
  const PassivityVerdict v = analyze_spring_passivity(in, b);
  ASSERT_TRUE(v.bound.bounded());
  ASSERT_GT(v.max_stiffness, 0.0);
  EXPECT_FALSE(v.max_stiffness_at_range_top);
  SpringPassivityInput below = in, above = in;
  below.parameters.stiffness = v.max_stiffness * (1 - 1e-8);
  above.parameters.stiffness = v.max_stiffness * (1 + 1e-8);
  EXPECT_LE(spring_passivity(below).required_damping, b);
  EXPECT_GT(spring_passivity(above).required_damping, b);
  // A device damping below the spring's own damper: B alone needs more (Nyquist).
  EXPECT_EQ(analyze_spring_passivity(in, 1.0).max_stiffness, 0.0);
}

// ---------------------------------------------------------------------------
// No answer from meaningless numbers (verdict.hpp's rule), never a NaN.

TEST(WallPassivity, NonFiniteOrOutOfRangeInputCannotBeAssessed) {
  struct Bad {
    double k, b, t;
    int d;
    std::string reason;
  };
  const std::vector<Bad> cases{
      {nan, 46, 1e-3, 1, "the stiffness K is NaN"},
      {inf, 46, 1e-3, 1, "the stiffness K overflowed to inf"},
      {9000, nan, 1e-3, 1, "the damping B is NaN"},
      {9000, 46, nan, 1, "the period T is NaN"},
      {-1, 46, 1e-3, 1, "the stiffness K = -1 N/m is negative"},
      {9000, -2, 1e-3, 1, "the damping B = -2 N s/m is negative"},
      {9000, 46, 0.0, 1, "the period T = 0 s must be > 0"},
      {9000, 46, 1e-3, -1, "the delay d = -1 samples must be 0 to 1000"},
      {9000, 46, 1e-3, 1001, "the delay d = 1001 samples must be 0 to 1000"},
      {1e308, 0, 10.0, 3, "K T / 2 overflowed to inf"},
      {1e308, 0, 1.0, 3, "the required damping overflowed to inf"},
  };
  for (const Bad& c : cases) {
    const PassivityBound p = wall_passivity(c.k, c.b, c.t, c.d);
    EXPECT_EQ(p.state, PassivityState::cannot_assess) << c.reason;
    EXPECT_NE(p.reason.find(c.reason), std::string::npos) << p.reason;
    EXPECT_FALSE(std::isnan(p.required_damping));
    EXPECT_FALSE(analyze_wall_passivity(c.k, c.b, c.t, c.d, 1.0).passive);
  }
  const PassivityVerdict b_nan = analyze_wall_passivity(9000, 46, 1e-3, 1, nan);
  EXPECT_EQ(b_nan.bound.state, PassivityState::cannot_assess);
  EXPECT_NE(b_nan.bound.reason.find("the device damping b is NaN"), std::string::npos) << b_nan.bound.reason;
  EXPECT_FALSE(b_nan.passive);

  SpringPassivityInput in;
  in.parameters = {79.0, nan, 2.0, world::Integrator::exact};
  EXPECT_NE(spring_passivity(in).reason.find("the inertia J is NaN"), std::string::npos);
  world::DiscreteLinearScene broken = forward_euler_absolute(5e5, 1.0, 1000.0, 1e-3);
  broken.a(0, 1) = inf;
  const PassivityBound p = scene_passivity(broken, 1e-3, 0);
  EXPECT_EQ(p.state, PassivityState::cannot_assess);
  EXPECT_NE(p.reason.find("overflowed to inf"), std::string::npos) << p.reason;
}

}  // namespace
}  // namespace hapticd::analysis::passivity_test
