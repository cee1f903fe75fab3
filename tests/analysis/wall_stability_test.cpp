// Hulin, Preusche, Hirzinger (2006): the virtual wall's exact stability
// region, reproduced from eq. (3) and checked against simulations of the
// sampled loop. Where the paper and the math disagree, the test asserts the
// math and says so.
#include "analysis/wall_stability.hpp"

#include <cmath>
#include <cstdio>
#include <deque>

#include <gtest/gtest.h>

namespace hapticd::analysis::wall_stability_test {
namespace {

const double sqrt2 = std::sqrt(2.0);

// Eq. (3) on the unit circle, solved by hand (independent of the code's
// boundary_curve / stable_intervals). With z = e^{j theta}:
//   z (z + 1) = 2 cos(theta/2) e^{j 3theta/2},  z^2 - 1 = 2j sin(theta) e^{j theta},
//   2 z^{1+d} (z - 1)^2 = -8 sin^2(theta/2) e^{j (d+2) theta};
// dividing eq. (3) by e^{j 3theta/2}, the imaginary part gives beta and the
// real part alpha:
//   beta(theta)  = 2 sin(theta/2) sin((d + 1/2) theta) / cos^2(theta/2),
//   alpha(theta) = [4 sin^2(theta/2) cos((d + 1/2) theta) - beta sin(theta) sin(theta/2)] / cos(theta/2).
double boundary_beta(double theta, int d) {
  const double h = theta / 2.0;
  return 2.0 * std::sin(h) * std::sin((d + 0.5) * theta) / (std::cos(h) * std::cos(h));
}
double boundary_alpha(double theta, int d) {
  const double h = theta / 2.0;
  return (4.0 * std::sin(h) * std::sin(h) * std::cos((d + 0.5) * theta) -
          boundary_beta(theta, d) * std::sin(theta) * std::sin(h)) /
         std::cos(h);
}

// The first branch of the curve leaves the origin (both ~ theta^2) and ends
// where alpha returns to 0 (at beta_max_at_zero_stiffness). Its end, found by
// a scan of alpha's sign and bisection; beta must increase along the branch.
double branch_end(int d) {
  double lo = 1e-3;
  while (boundary_alpha(lo + 1e-3, d) > 0.0) lo += 1e-3;
  double hi = lo + 1e-3;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (boundary_alpha(mid, d) > 0.0 ? lo : hi) = mid;
  }
  return lo;
}

// theta on the first branch with beta(theta) = target, by bisection.
double theta_for_beta(double target, int d) {
  double lo = 0.0, hi = branch_end(d);
  EXPECT_LT(target, boundary_beta(hi, d));
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (boundary_beta(mid, d) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// max over theta of alpha(theta) on the first branch, by golden section.
BoundaryPoint closed_form_max_stiffness(int d) {
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = 0.0, b = branch_end(d);
  for (int i = 0; i < 200 && b - a > 1e-15; ++i) {
    const double c = b - g * (b - a), e = a + g * (b - a);
    if (boundary_alpha(c, d) > boundary_alpha(e, d)) {
      b = e;
    } else {
      a = c;
    }
  }
  const double theta = 0.5 * (a + b);
  return {boundary_beta(theta, d), boundary_alpha(theta, d)};
}

// Before relying on the closed form: it reproduces the code's alpha_max
// (and the branch is monotone in beta, so bisection finds the right theta).
TEST(WallStability, ClosedFormBoundaryAgreesWithTheCode) {
  // d = 1, beta = 0.46: alpha_max = 0.14342013571857 (also mpmath, 30 digits:
  // theta = 0.5695224801679519, alpha = 0.1434201357185735).
  const double theta = theta_for_beta(0.46, 1);
  EXPECT_NEAR(boundary_beta(theta, 1), 0.46, 1e-15);
  EXPECT_NEAR(boundary_alpha(theta, 1), 0.1434201357185735, 1e-14);
  EXPECT_NEAR(alpha_max(0.46, 1), boundary_alpha(theta, 1), 1e-12);
  for (int d = 0; d <= 3; ++d) {
    const double end = branch_end(d);
    EXPECT_NEAR(boundary_beta(end, d), beta_max_at_zero_stiffness(d), 1e-9) << d;
    for (int i = 1; i < 200; ++i) {
      ASSERT_GT(boundary_beta(end * i / 200.0, d), boundary_beta(end * (i - 1) / 200.0, d)) << d;
    }
    for (double frac : {0.05, 0.2, 0.5, 0.8, 0.95}) {
      const double beta = frac * beta_max_at_zero_stiffness(d);
      const double closed = boundary_alpha(theta_for_beta(beta, d), d);
      EXPECT_NEAR(alpha_max(beta, d), closed, 1e-9 * closed) << d << " " << beta;
    }
  }
  // Remark 2, d = 1: max alpha over theta (mpmath: theta = 0.5459436984736499,
  // alpha = 0.1444693492260521, beta = 0.4246937898825979).
  const BoundaryPoint top = closed_form_max_stiffness(1);
  EXPECT_NEAR(top.alpha, 0.1444693492260521, 1e-12);
  EXPECT_NEAR(top.beta, 0.4246937898825979, 1e-6);  // a maximum: beta only to sqrt(eps)
  const BoundaryPoint code = max_stiffness_point(1);
  EXPECT_NEAR(code.alpha, top.alpha, 1e-12);
  EXPECT_NEAR(code.beta, top.beta, 1e-6);
  // d = 0: the exact [12 - 8 sqrt2, -2 + 2 sqrt2] of Remark 2.
  const BoundaryPoint top0 = closed_form_max_stiffness(0);
  EXPECT_NEAR(top0.alpha, 12.0 - 8.0 * sqrt2, 1e-12);
  EXPECT_NEAR(top0.beta, -2.0 + 2.0 * sqrt2, 1e-6);
}

// Remark 2: maximum stiffness point.
TEST(WallStability, MaxStiffnessPointNoDelayIsExact) {
  const BoundaryPoint p = max_stiffness_point(0);
  EXPECT_NEAR(p.alpha, 12.0 - 8.0 * sqrt2, 1e-8);
  EXPECT_NEAR(p.beta, -2.0 + 2.0 * sqrt2, 1e-8);
}

TEST(WallStability, MaxStiffnessPointOneDelayMatchesRemark2) {
  const BoundaryPoint p = max_stiffness_point(1);
  EXPECT_NEAR(p.alpha, 0.144469, 1e-6);
  EXPECT_NEAR(p.beta, 0.424694, 1e-6);
}

TEST(WallStability, MaxStiffnessPointIsOnTheBoundary) {
  for (int d = 0; d <= 3; ++d) {
    const BoundaryPoint p = max_stiffness_point(d);
    EXPECT_TRUE(wall_stable(p.alpha * (1 - 1e-6), p.beta, d)) << d;
    EXPECT_FALSE(wall_stable(p.alpha * (1 + 1e-6), p.beta, d)) << d;
    // No damping makes a stiffer wall stable (a local check around beta).
    for (double db : {-0.05, -0.01, 0.01, 0.05}) {
      EXPECT_LE(alpha_max(p.beta + db, d), p.alpha + 1e-12) << d << " " << db;
    }
  }
}

TEST(WallStability, BetaMaxAtZeroStiffness) {
  EXPECT_NEAR(beta_max_at_zero_stiffness(0), 2.0, 1e-12);
  EXPECT_NEAR(beta_max_at_zero_stiffness(1), 2.0 * sqrt2 - 2.0, 1e-12);
  // d = 2: 2 z^3 (z - 1) + beta (z + 1) has a unit-circle root at beta = 4 - 2 sqrt3
  // (found numerically first; the closed form then checked by hand).
  EXPECT_NEAR(beta_max_at_zero_stiffness(2), 4.0 - 2.0 * std::sqrt(3.0), 1e-12);
}

// Remark 1: alpha_max ~ 2 beta (d = 0), 2/3 beta (d = 1) near the origin.
// Derived from the closed-form boundary above for every d: for small theta,
// sin(theta/2) ~ theta/2, sin((d + 1/2) theta) ~ (d + 1/2) theta and the
// cosines ~ 1, so beta ~ (d + 1/2) theta^2 and alpha ~ theta^2 - beta theta^2/2
// ~ theta^2, hence alpha / beta -> 1 / (d + 1/2) = 2 / (2d + 1):
// 2, 2/3, 2/5, 2/7 for d = 0..3 (the paper states d = 0 and d = 1 only).
TEST(WallStability, SlopeAtOrigin) {
  const double beta = 1e-6;
  EXPECT_NEAR(alpha_max(beta, 0) / beta, 2.0, 1e-5);
  EXPECT_NEAR(alpha_max(beta, 1) / beta, 2.0 / 3.0, 1e-5);
  for (int d = 0; d <= 3; ++d) {
    const double slope = 2.0 / (2.0 * d + 1.0);
    // The closed form's own ratio approaches the limit (the correction is O(theta^2) = O(beta)).
    const double theta = theta_for_beta(beta, d);
    EXPECT_NEAR(boundary_alpha(theta, d) / boundary_beta(theta, d), slope, 1e-5) << d;
    // The code's boundary is the closed form's at this beta, and has the slope.
    EXPECT_NEAR(alpha_max(beta, d), boundary_alpha(theta, d), 1e-9 * beta) << d;
    EXPECT_NEAR(alpha_max(beta, d) / beta, slope, 1e-5) << d;
  }
}

double poly5(double b) {
  return 2 * b - 1.984 * b * b + 0.924 * std::pow(b, 3) - 0.35 * std::pow(b, 4) + 0.0865 * std::pow(b, 5) -
         0.00975 * std::pow(b, 6);
}
double poly6(double b) {
  return 2.0 / 3.0 * b - 0.7425 * b * b - 0.048 * std::pow(b, 3) - 0.03278 * std::pow(b, 4);
}

double max_fit_error(int d, double (*fit)(double), double* where) {
  const double top = beta_max_at_zero_stiffness(d);
  double worst = 0.0;
  for (int i = 0; i <= 2000; ++i) {
    const double b = top * i / 2000.0;
    const double e = std::abs(fit(b) - alpha_max(b, d));
    if (e > worst) {
      worst = e;
      *where = b;
    }
  }
  return worst;
}

// Eq. (5): the paper claims |error| < 0.0003 over the boundary. Measured on
// 2001 betas over [0, 2]: 2.78e-4 at beta = 0.308, so the claim holds.
TEST(WallStability, PolynomialFitEq5) {
  double where = 0.0;
  const double err = max_fit_error(0, poly5, &where);
  RecordProperty("eq5_max_error", std::to_string(err) + " at beta " + std::to_string(where));
  std::printf("eq. (5) max error %.6g at beta %.6g\n", err, where);
  EXPECT_LT(err, 0.0003) << "at beta " << where;
}

// Eq. (6): the paper claims |error| < 0.0001. Measured on the same grid over
// [0, 2 sqrt2 - 2]: 9.15e-5 at beta = 0.7307, so the claim holds (narrowly).
TEST(WallStability, PolynomialFitEq6) {
  double where = 0.0;
  const double err = max_fit_error(1, poly6, &where);
  RecordProperty("eq6_max_error", std::to_string(err) + " at beta " + std::to_string(where));
  std::printf("eq. (6) max error %.6g at beta %.6g\n", err, where);
  EXPECT_LT(err, 0.0001) << "at beta " << where;
}

// Section 6.2, Fig. 9: the global minimum of the pole radius along the
// minimum-radius path. For d = 0 it is a triple root z = r = 4^(1/3) - 1 of
// 2z^3 + (alpha + beta - 4) z^2 + (alpha + 2) z - beta, so alpha = 6r^2 - 2,
// beta = 2r^3.
TEST(WallStability, MinimumRadiusNoDelayIsTripleRoot) {
  const double r = std::cbrt(4.0) - 1.0;
  const MinimumRadiusPoint p = minimum_radius_point(0);
  EXPECT_NEAR(p.alpha, 6 * r * r - 2, 1e-5);
  EXPECT_NEAR(p.beta, 2 * r * r * r, 1e-5);
  EXPECT_NEAR(p.radius, r, 1e-4);
  EXPECT_NEAR(p.alpha, 0.070, 5e-4);  // paper, 3 digits
  EXPECT_NEAR(p.beta, 0.405, 5e-4);
}

// For d = 1 the optimum is a triple root r with a fourth root s:
// 2 (z - r)^3 (z - s) = 2 z^4 - 4 z^3 + (2 + alpha + beta) z^2 + alpha z - beta
// (eq. 3). Matching z^3: s = 2 - 3r; z^1: alpha = -2 r^2 (3s + r) = 4 r^2 (4r - 3);
// z^0: beta = -2 r^3 s = 2 r^3 (3r - 2); z^2: 12 r - 12 r^2 = 2 + alpha + beta,
// i.e. 3 r^4 + 6 r^3 - 6 r + 1 = 0. Near 0.75: r = 0.7521143395,
// alpha = 0.0191364971, beta = 0.2181238206, |s| = 0.2563 < r.
TEST(WallStability, MinimumRadiusOneDelay) {
  const auto quartic = [](double r) { return 3 * r * r * r * r + 6 * r * r * r - 6 * r + 1; };
  double lo = 0.7, hi = 0.8;
  ASSERT_LT(quartic(lo), 0.0);
  ASSERT_GT(quartic(hi), 0.0);
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (quartic(mid) < 0.0 ? lo : hi) = mid;
  }
  const double r = 0.5 * (lo + hi);
  EXPECT_NEAR(r, 0.7521143395063479, 1e-15);  // mpmath findroot
  const double alpha = 4 * r * r * (4 * r - 3), beta = 2 * r * r * r * (3 * r - 2), s = 2 - 3 * r;
  ASSERT_LT(std::abs(s), r);
  const MinimumRadiusPoint p = minimum_radius_point(1);
  EXPECT_NEAR(p.alpha, alpha, 1e-5);
  EXPECT_NEAR(p.beta, beta, 1e-5);
  EXPECT_NEAR(p.radius, r, 1e-5);
  EXPECT_NEAR(p.alpha, 0.0191, 5e-5);  // paper, 3 digits
  EXPECT_NEAR(p.beta, 0.218, 5e-4);
}

bool all_real(double alpha, double beta, int d) {
  for (const auto& z : wall_poles(alpha, beta, d)) {
    if (std::abs(z.imag()) > 1e-4) return false;  // near-multiple roots: rounding gives ~1e-5
  }
  return true;
}

// Footnote 2 prints alpha in [0, 0.702] for the real-pole part of the d = 0
// path; the minimum is a triple root z = 4^(1/3) - 1, alpha = 6 z^2 - 2 =
// 0.0702, where the poles stop being real, so 0.702 is a misplaced decimal
// point: at alpha = 0.1 .. 0.6 the optimal poles are complex.
TEST(WallStability, Footnote2RealPolesEndAt0_0702NotAt0_702) {
  for (double a : {0.02, 0.04, 0.06, 0.069}) {
    const auto p = minimum_radius_damping(a, 0);
    ASSERT_TRUE(p);
    EXPECT_TRUE(all_real(a, p->beta, 0)) << a;
  }
  for (double a : {0.08, 0.2, 0.4, 0.6, 0.68}) {
    const auto p = minimum_radius_damping(a, 0);
    ASSERT_TRUE(p);
    EXPECT_FALSE(all_real(a, p->beta, 0)) << a;
  }
  for (double a : {0.005, 0.01, 0.018}) {
    const auto p = minimum_radius_damping(a, 1);
    ASSERT_TRUE(p);
    EXPECT_TRUE(all_real(a, p->beta, 1)) << a;
  }
  const auto q = minimum_radius_damping(0.05, 1);
  ASSERT_TRUE(q);
  EXPECT_FALSE(all_real(0.05, q->beta, 1));
}

TEST(WallStability, Fig8PoleRadius) { EXPECT_NEAR(pole_radius(0.075, 0.371, 1), 0.893, 5e-4); }

// The damping range at a stiffness is one interval and agrees with a grid.
TEST(WallStability, DampingRangeIsOneIntervalMatchingAGrid) {
  for (int d = 0; d <= 2; ++d) {
    const BoundaryPoint top = max_stiffness_point(d);
    for (double frac : {0.1, 0.5, 0.9}) {
      const double a = frac * top.alpha;
      const auto range = stable_damping_range(a, d);
      ASSERT_TRUE(range);
      int transitions = 0;
      bool prev = wall_stable(a, 0.0, d);
      for (int i = 1; i <= 400; ++i) {
        const double b = 3.0 * i / 400.0;
        const bool s = wall_stable(a, b, d);
        if (s != prev) ++transitions;
        prev = s;
        if (std::abs(b - range->lower) > 1e-9 && std::abs(b - range->upper) > 1e-9) {
          EXPECT_EQ(s, range->contains(b)) << d << " " << a << " " << b;
        }
      }
      EXPECT_EQ(transitions, 2);
    }
    EXPECT_FALSE(stable_damping_range(top.alpha * 1.001, d));
  }
}

// Simulates the sampled wall of eq. (1) with m = T = 1 (so K = alpha,
// B = beta): exact ZOH of the free mass, PD on the sampled position, force
// applied d samples late. Returns late/early envelope ratio.
double simulate_wall(double alpha, double beta, int d, int steps) {
  double x = 1.0, v = 0.0, x_prev = 1.0;
  std::deque<double> pending(static_cast<std::size_t>(d), 0.0);
  const int window = steps / 10;
  double early = 0.0, late = 0.0;
  for (int n = 0; n < steps; ++n) {
    const double f = -alpha * x - beta * (x - x_prev);
    x_prev = x;
    pending.push_back(f);
    const double u = pending.front();
    pending.pop_front();
    x += v + 0.5 * u;
    v += u;
    if (n >= window && n < 2 * window) early = std::max(early, std::abs(x));
    if (n >= steps - window) late = std::max(late, std::abs(x));
  }
  return late / early;
}

TEST(WallStability, TimeDomainAgreesJustInsideAndOutsideTheBoundary) {
  for (int d = 0; d <= 2; ++d) {
    const double top = beta_max_at_zero_stiffness(d);
    for (double frac : {0.3, 0.7}) {
      const double beta = frac * top;
      const double am = alpha_max(beta, d);
      ASSERT_GT(am, 0.0);
      EXPECT_LT(simulate_wall(0.98 * am, beta, d, 60000), 0.5) << d << " " << beta;
      EXPECT_GT(simulate_wall(1.02 * am, beta, d, 60000), 2.0) << d << " " << beta;
    }
  }
}

// Section 7 (m = 0.1 kg, T = 1 ms, d = 1). The paper writes B = 0.46 m/T =
// 4.6 N s/m; 0.46 m/T is 46 N s/m. With 46 N s/m the wall is stable; with
// the printed 4.6 N s/m (beta = 0.046) it is not (alpha_max(0.046) = 0.0291,
// below alpha = 0.09): on the closed-form boundary, beta(theta) = 0.046 at
// theta = 0.1755709393, alpha = 0.0290935745, so K_max = alpha m / T^2 = 2909.357 N/m.
TEST(WallStability, Section7Phantom) {
  const WallVerdict ok = analyze_wall(0.1, 1e-3, 1, 9000.0, 46.0);
  EXPECT_NEAR(ok.alpha, 0.09, 1e-12);
  EXPECT_NEAR(ok.beta, 0.46, 1e-12);
  EXPECT_TRUE(ok.stable());
  EXPECT_TRUE(refusal_message(ok).empty());

  const WallVerdict typo = analyze_wall(0.1, 1e-3, 1, 9000.0, 4.6);
  EXPECT_FALSE(typo.stable());
  const double alpha_typo = boundary_alpha(theta_for_beta(0.046, 1), 1);
  EXPECT_NEAR(alpha_typo, 0.0290935744869607, 1e-13);  // mpmath, 30 digits
  const double k_typo = alpha_typo * 0.1 / (1e-3 * 1e-3);
  EXPECT_NEAR(typo.k_max_for_damping, k_typo, 1e-6 * k_typo);
  EXPECT_LT(typo.k_max_for_damping, 3000.0);

  const WallVerdict stiff = analyze_wall(0.1, 1e-3, 1, 20000.0, 4.6);
  EXPECT_FALSE(stiff.stable());
  EXPECT_FALSE(stiff.damping_range);  // 20 kN/m > k_max for any damping
  const BoundaryPoint top = closed_form_max_stiffness(1);
  EXPECT_NEAR(stiff.k_max, top.alpha * 0.1 / 1e-6, 1e-6 * top.alpha * 0.1 / 1e-6);
  EXPECT_NEAR(stiff.b_at_k_max, top.beta * 0.1 / 1e-3, 1e-4);  // beta at a maximum: ~sqrt(eps)
  EXPECT_NEAR(stiff.b_at_k_max, 0.424694 * 0.1 / 1e-3, 1e-3);  // Remark 2, 6 digits
  const std::string msg = refusal_message(stiff);
  EXPECT_NE(msg.find("K = 20000 N/m"), std::string::npos) << msg;
  EXPECT_NE(msg.find("m = 0.1 kg, T = 1 ms, d = 1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("largest stable K for B = 4.6 N s/m is 2909 N/m"), std::string::npos) << msg;
  EXPECT_NE(msg.find("14447 N/m"), std::string::npos) << msg;
}

TEST(WallStability, VerdictEdgeCases) {
  // Free mass with a damper only: the drift root is not an instability.
  EXPECT_TRUE(analyze_wall(0.1, 1e-3, 1, std::nullopt, 20.0).stable());
  EXPECT_FALSE(analyze_wall(0.1, 1e-3, 1, std::nullopt, 90.0).stable());  // beta 0.9 > 0.828
  EXPECT_TRUE(analyze_wall(0.1, 1e-3, 1, std::nullopt, std::nullopt).stable());
  // A spring without damping is never stable (Hulin: beta = 0 is outside).
  EXPECT_FALSE(analyze_wall(0.1, 1e-3, 0, 100.0, std::nullopt).stable());
  EXPECT_THROW(analyze_wall(0.0, 1e-3, 0, 1.0, 1.0), std::invalid_argument);
  EXPECT_THROW(analyze_wall(0.1, 1e-3, -1, 1.0, 1.0), std::invalid_argument);
  EXPECT_THROW(analyze_wall(0.1, 1e-3, 0, -1.0, 1.0), std::invalid_argument);
}

// analyze wall --mass 0.1 --period 1ms --delay 1 --stiffness 9000 --damping
// 1e300 said "UNSTABLE, pole radius 2": with beta = 1e298 the mass term
// 2 z^2 (z-1)^2 of eq. (3) is below the rounding of the companion matrix, and
// the roots it returned are not those of the wall (true ones reach 7e148).
// A 1e-300 kg mass overflows alpha. Neither is a verdict.
TEST(WallStability, SwampedOrOverflowingTermsCannotBeAssessed) {
  const WallVerdict damped = analyze_wall(0.1, 1e-3, 1, 9000.0, 1e300);
  EXPECT_EQ(damped.verdict.state, VerdictState::cannot_assess);
  EXPECT_FALSE(damped.stable());
  EXPECT_NE(damped.verdict.reason.find("mass term"), std::string::npos) << damped.verdict.reason;
  EXPECT_TRUE(std::isnan(damped.pole_radius));
  // The region at the (resolvable) requested stiffness is still reported.
  ASSERT_TRUE(damped.damping_range.has_value());
  EXPECT_NEAR(damped.damping_range->lower, 16.6054, 1e-3);
  const std::string msg = refusal_message(damped);
  EXPECT_NE(msg.find("cannot be assessed"), std::string::npos) << msg;
  EXPECT_NE(msg.find("mass term"), std::string::npos) << msg;

  const WallVerdict light = analyze_wall(1e-300, 1e-3, 1, 9000.0, 46.0);
  EXPECT_EQ(light.verdict.state, VerdictState::cannot_assess);
  EXPECT_NE(light.verdict.reason.find("mass term"), std::string::npos) << light.verdict.reason;
  const WallVerdict overflow = analyze_wall(1e-3, 1.0, 1, 1e308, 0.0);
  EXPECT_EQ(overflow.verdict.state, VerdictState::cannot_assess);
  EXPECT_NE(overflow.verdict.reason.find("alpha = K T^2 / m overflowed to inf"), std::string::npos)
      << overflow.verdict.reason;
  // Up to alpha + beta = 1e6 (K = 1e11 N/m at m = 0.1 kg, T = 1 ms) it is a verdict.
  EXPECT_EQ(analyze_wall(0.1, 1e-3, 1, 1e11, 46.0).verdict.state, VerdictState::unstable);
}

TEST(WallStability, NormalizationRoundTrips) {
  EXPECT_DOUBLE_EQ(normalized_stiffness(9000.0, 0.1, 1e-3), 0.09);
  EXPECT_NEAR(physical_damping(normalized_damping(4.6, 0.1, 1e-3), 0.1, 1e-3), 4.6, 1e-12);
  EXPECT_NEAR(physical_stiffness(0.09, 0.1, 1e-3), 9000.0, 1e-9);
}

}  // namespace
}  // namespace hapticd::analysis::wall_stability_test
