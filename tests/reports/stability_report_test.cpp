// The numbers behind `hapticctl report stability`: the maps against the
// papers' closed forms (Hulin Remarks 1 and 2 and Fig. 8, Freudenberg 2.14,
// the Jury closed form of Diaz & Gil's K_CR at td = 0), and the sweep's
// agreement rule and determinism.
#include <cmath>
#include <map>
#include <numbers>

#include <gtest/gtest.h>

#include "analysis/stability_maps.hpp"
#include "analysis/stability_sweep.hpp"
#include "analysis/wall_stability.hpp"

namespace hapticd::analysis::stability_report_test {
namespace {

const double sqrt2 = std::sqrt(2.0);

const WallRegionMap& wall_map() {
  static const WallRegionMap map = [] {
    StudyProgress progress;
    return wall_region_map(1, 40, progress);
  }();
  return map;
}

TEST(StabilityMaps, WallMaximaAreHulinsRemark2) {
  const auto& maxima = wall_map().maximum_stiffness;
  ASSERT_EQ(maxima.size(), 2u);
  EXPECT_NEAR(maxima[0].alpha, 12 - 8 * sqrt2, 1e-9);
  EXPECT_NEAR(maxima[0].beta, 2 * sqrt2 - 2, 1e-6);
  EXPECT_NEAR(maxima[1].alpha, 0.144469, 1e-6);
  EXPECT_NEAR(maxima[1].beta, 0.424694, 1e-6);
}

// Remark 1: near the origin alpha < 2 beta (d = 0) and alpha < 2/3 beta
// (d = 1); Remark 2: the boundary reaches alpha = 0 at beta = 2 and 2 sqrt2 - 2.
TEST(StabilityMaps, WallBoundaryEndsAreHulinsRemarks) {
  const double slope[] = {2.0, 2.0 / 3.0};
  const double end[] = {2.0, 2 * sqrt2 - 2};
  for (int d = 0; d <= 1; ++d) {
    const WallMapPoint* first = nullptr;
    const WallMapPoint* last = nullptr;
    for (const auto& p : wall_map().boundary) {
      if (p.delay != d) continue;
      if (first == nullptr) first = &p;
      last = &p;
    }
    ASSERT_NE(first, nullptr);
    EXPECT_NEAR(first->alpha / first->beta, slope[d], 2e-3 * slope[d]) << "d=" << d;
    EXPECT_NEAR(last->beta, end[d], 1e-5) << "d=" << d;
    EXPECT_LT(last->alpha, 1e-4) << "d=" << d;
  }
}

// Hulin 6.1 / Fig. 8 right: d = 1, alpha = 0.075, beta = 0.371 has damping
// D = 0.229 and pole radius 0.893; the maximum-damping path does better there.
TEST(StabilityMaps, DiscreteDampingIsHulinsFig8) {
  EXPECT_NEAR(discrete_damping_ratio(0.075, 0.371, 1), 0.229, 5e-4);
  EXPECT_NEAR(pole_radius(0.075, 0.371, 1), 0.893, 5e-4);
  const auto best = maximum_damping_beta(0.075, 1);
  ASSERT_TRUE(best.has_value());
  EXPECT_GT(best->damping, 0.229);
  EXPECT_TRUE(wall_stable(0.075, best->beta, 1));
  for (const double beta : {best->beta * 0.98, best->beta * 1.02}) {
    EXPECT_LE(discrete_damping_ratio(0.075, beta, 1), best->damping + 1e-9);
  }
}

// Forward Euler (Freudenberg 2.13-2.14): |lambda|^2 = 1 - 2 zeta h + h^2
// is below 1 for zeta > h / 2; overdamped, the fast real root 1 - h (zeta +
// sqrt(zeta^2 - 1)) must stay above -1: zeta < 1/h + h/4.
// Semi-implicit Euler and RK4 undamped: stable for h < 2 and h < 2 sqrt2.
TEST(StabilityMaps, IntegratorRegionsFollowTheClosedForms) {
  StudyProgress progress;
  const auto rows = integrator_region_map(
      {world::Integrator::forward_euler, world::Integrator::semi_implicit_euler, world::Integrator::rk4}, 8,
      progress);
  int checked = 0;
  for (const auto& r : rows) {
    if (r.integrator == world::Integrator::forward_euler) {
      if (r.wn_t >= 1.9) continue;  // the band closes at h = 2
      // The verdict calls |lambda| <= 1 + 1e-12 (+ rounding) stable, which moves
      // the edge by 2e-12 / h^2 relative (|lambda| - 1 = h (h/2 - zeta)).
      const double moved = 3e-12 / (r.wn_t * r.wn_t) + 1e-8;
      EXPECT_NEAR(r.zeta_lower / (r.wn_t / 2), 1.0, moved) << "h=" << r.wn_t;
      if (std::isfinite(r.zeta_upper)) {
        EXPECT_NEAR(r.zeta_upper / (1 / r.wn_t + r.wn_t / 4), 1.0, moved) << "h=" << r.wn_t;
      }
      ++checked;
    }
    if (r.zeta_lower == 0.0 && r.integrator == world::Integrator::semi_implicit_euler) {
      EXPECT_LT(r.wn_t, 2.0);
    }
    if (r.zeta_lower == 0.0 && r.integrator == world::Integrator::rk4) {
      EXPECT_LT(r.wn_t, 2 * sqrt2);
    }
  }
  EXPECT_GT(checked, 20);
  // ... and the undamped band reaches right up to those limits.
  const auto reaches = [&](world::Integrator i, double h) {
    for (const auto& r : rows) {
      if (r.integrator == i && r.zeta_lower == 0.0 && std::abs(r.wn_t - h) < 1e-9) return true;
    }
    return false;
  };
  EXPECT_TRUE(reaches(world::Integrator::semi_implicit_euler, std::pow(10.0, 2.0 / 8.0)));  // 1.78
  EXPECT_TRUE(reaches(world::Integrator::rk4, std::pow(10.0, 3.0 / 8.0)));                  // 2.37
}

// Jury on the ZOH of 1/(m s^2 + b s), written out here from the z-transform:
// H(z) = (n1 z + n0) / ((z - 1)(z - a)); the pair reaches |z| = 1 at a + K n0 = 1.
TEST(StabilityMaps, CriticalStiffnessAtZeroDelayIsTheJuryClosedForm) {
  StudyProgress progress;
  const auto rows = critical_stiffness_curves(1e-3, 4e-3, 1e-3, progress);
  const double m = 5.4, b = 3.5, t = 1e-3, c = b / m, a = std::exp(-c * t);
  const double n0 = ((1 - a) - c * t * a) / (m * c * c);
  const double jury = (1 - a) / n0;
  EXPECT_NEAR(rigid_critical_stiffness_jury(m, b, t) / jury, 1.0, 1e-9);
  double previous = INFINITY;
  for (const auto& r : rows) {
    if (r.plant != "rigid") continue;
    if (r.delay_s == 0.0) {
      EXPECT_NEAR(r.k_cr / jury, 1.0, 1e-6);
    }
    EXPECT_LT(r.k_cr, previous);  // Diaz & Gil: K_CR falls with the delay
    previous = r.k_cr;
  }
  EXPECT_NEAR(jury, 2 * b / t, 0.01 * jury);  // the familiar K T / 2 < b
}

SweepResult judged(double predicted_radius, double measured_log_growth, long window, bool gate_accepts,
                   bool bound_only = false) {
  SweepResult r;
  r.predicted_radius = predicted_radius;
  r.predicted_log_growth = std::log(predicted_radius);
  r.measured_log_growth = measured_log_growth;
  r.gate_accepts = gate_accepts;
  judge_growth(r, window, bound_only);
  return r;
}

TEST(StabilitySweep, AgreementRule) {
  // Unstable: two-sided within 5 % + 4 / window.
  EXPECT_EQ(judged(1.1, std::log(1.1), 1000, false).agreement, SweepAgreement::agree);
  EXPECT_EQ(judged(1.1, 1.2 * std::log(1.1), 1000, false).agreement, SweepAgreement::disagree);
  EXPECT_EQ(judged(1.1, -0.01, 1000, false).agreement, SweepAgreement::disagree);
  // ... and the gate must not accept it.
  const SweepResult accepted = judged(1.1, std::log(1.1), 1000, true);
  EXPECT_EQ(accepted.agreement, SweepAgreement::disagree);
  EXPECT_NE(accepted.why.find("gate accepts"), std::string::npos);
  // Stable: the run decays at least as fast as predicted.
  EXPECT_EQ(judged(0.99, std::log(0.99), 1000, true).agreement, SweepAgreement::agree);
  EXPECT_EQ(judged(0.99, 3 * std::log(0.99), 1000, true).agreement, SweepAgreement::agree);
  EXPECT_EQ(judged(0.99, 0.2 * std::log(0.99), 100000, true).agreement, SweepAgreement::disagree);
  EXPECT_EQ(judged(0.99, 0.001, 100000, true).agreement, SweepAgreement::disagree);
  // Too fast to fit: only the sign counts.
  EXPECT_EQ(judged(1e-100, -50.0, 3, true, true).agreement, SweepAgreement::agree);
  // Within 1e-6 of the unit circle: reported, not judged.
  EXPECT_EQ(judged(1.0 + 5e-7, -1.0, 1000, true).agreement, SweepAgreement::marginal);
  EXPECT_EQ(judged(1.0 - 5e-7, 1.0, 1000, true).agreement, SweepAgreement::marginal);
}

TEST(StabilitySweep, QuickSweepAgreesAndIsDeterministic) {
  const auto cases = sweep_cases(true);
  StudyProgress progress;
  const auto first = run_stability_sweep(cases, {}, progress);
  const auto second = run_stability_sweep(cases, {}, progress);
  ASSERT_EQ(first.size(), cases.size());
  std::map<std::string, int> families;
  for (std::size_t i = 0; i < first.size(); ++i) {
    const SweepResult& r = first[i];
    EXPECT_NE(r.agreement, SweepAgreement::disagree) << r.input.name << ": " << r.why;
    EXPECT_FALSE(r.gate_decision.empty()) << r.input.name;
    EXPECT_EQ(r.input.name, second[i].input.name);
    if (r.ran) {
      EXPECT_EQ(r.measured_log_growth, second[i].measured_log_growth) << r.input.name;  // bitwise
    }
    ++families[r.input.family];
  }
  for (const char* family :
       {"w_n T", "k/J", "period", "delay", "inertia", "damping", "two-mass", "encoder", "non-finite"}) {
    EXPECT_GT(families[family], 0) << family;
  }
}

TEST(StabilitySweep, NonFiniteInputsAreRefusedAndNeverRun) {
  for (const SweepCase& c : sweep_cases(false)) {
    if (c.family != "non-finite" || c.fault != MeasurementFault::none) continue;
    const SweepResult r = run_sweep_case(c, {});
    EXPECT_FALSE(r.gate_accepts) << c.name;
    EXPECT_FALSE(r.ran) << c.name;
    EXPECT_EQ(r.agreement, SweepAgreement::not_run) << c.name;
  }
}

// A NaN read poisons the spring's integrator state (the engine's guard then
// zeroes the output and latches a fault); the wall forgets it within d + 1
// samples (its only memory is the backward difference and the delay line).
TEST(StabilitySweep, NonFiniteReadsShowWhatTheSceneEmits) {
  for (const SweepCase& c : sweep_cases(false)) {
    if (c.fault != MeasurementFault::nan && c.fault != MeasurementFault::inf) continue;
    const SweepResult r = run_sweep_case(c, {});
    EXPECT_EQ(r.agreement, SweepAgreement::fault_handled) << c.name;
    if (c.scene == "wall") {
      EXPECT_NE(r.run_note.find("not finite in 1 of"), std::string::npos) << c.name << ": " << r.run_note;
    } else {
      EXPECT_NE(r.run_note.find("not finite in 64 of"), std::string::npos) << c.name << ": " << r.run_note;
    }
  }
}

}  // namespace
}  // namespace hapticd::analysis::stability_report_test
